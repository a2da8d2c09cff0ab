// `cdshear settings`: every key of a shear case with its value, unit, range, phase and meaning,
// from the settings table (src/io/case_settings.hpp): as an annotated case file, or as the
// table of docs/case-files.md.
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "build_info.hpp"
#include "case_file.hpp"
#include "case_settings.hpp"
#include "commands.hpp"

namespace cdshear {
namespace {

struct SettingsArgs {
  CaseSource source;  ///< case file, --system, -V, --set (not --threads: no effect on a case)
  bool markdown = false;
  bool scene_solver = false;
};

std::string describe(const CaseSource& a) {
  std::string what = a.file.empty() ? "the built-in default case" : a.file;
  if (a.system) what += ", --system " + std::to_string(*a.system);
  if (a.velocity) what += ", -V " + format_number(*a.velocity);
  for (const std::string& o : a.overrides) what += ", --set " + o;
  return what;
}

void print_settings(const SettingsArgs& a) {
  if (a.scene_solver) {
    std::fputs(scene_solver_settings_as_markdown().c_str(), stdout);
    return;
  }
  const ShearCase c = load_case(a.source);
  for (const std::string& note : case_settings_without_effect(c))
    std::fprintf(stderr, "warning: %s\n", note.c_str());
  const std::string text =
      a.markdown ? settings_as_markdown(c)
                 : settings_as_toml(c, "Every key of a shear case file with its value for " +
                                           describe(a.source) +
                                           " (cdshear " CDSHEAR_VERSION
                                           " settings). Each key: its meaning above it; its "
                                           "unit and range beside it. Run it with `cdshear run "
                                           "FILE`; docs/case-files.md.");
  std::fputs(text.c_str(), stdout);
}

}  // namespace

void register_settings_command(CLI::App& app) {
  auto args = std::make_shared<SettingsArgs>();
  CLI::App* cmd = app.add_subcommand(
      "settings",
      "Print every key of a shear case with its value (the defaults, or those of a case file, "
      "preset and overrides), unit, range and meaning");
  CaseSource& source = args->source;
  add_case_choice_options(cmd, source.file, source.system, source.velocity, source.overrides);
  cmd->add_flag("--markdown", args->markdown,
                "the table of docs/case-files.md instead of an annotated case file");
  cmd->add_flag("--scene-solver", args->scene_solver,
                "the [solver] table of scene files with the engine's defaults, as markdown "
                "(docs/scene-files.md)");
  cmd->callback([args]() { print_settings(*args); });
}

}  // namespace cdshear
