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
  std::string file;
  std::optional<int> system;
  std::optional<double> velocity;
  std::vector<std::string> overrides;
  bool markdown = false;
  bool scene_solver = false;
};

std::string describe(const SettingsArgs& a) {
  std::string what = a.file.empty() ? "the built-in default case" : a.file;
  if (a.system) what += ", --system " + std::to_string(*a.system);
  if (a.velocity) what += ", -V " + format_number(*a.velocity);
  for (const std::string& o : a.overrides) what += ", --set " + o;
  return what;
}

void print_settings(const SettingsArgs& a) {
  CaseSource source;
  source.file = a.file;
  source.system = a.system;
  source.velocity = a.velocity;
  source.overrides = a.overrides;
  if (a.scene_solver) {
    std::fputs(scene_solver_settings_as_markdown().c_str(), stdout);
    return;
  }
  const ShearCase c = load_case(source);
  const std::string text =
      a.markdown
          ? settings_as_markdown(c)
          : settings_as_toml(c, "Every key of a shear case file with its value for " + describe(a) +
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
  cmd->add_option("case", args->file, "case file (TOML); default: the built-in case")
      ->check(kNonEmptyPath);
  cmd->add_option_function<int>(
      "--system", [args](int k) { args->system = k; }, "preset of docs/model.md section 6, 1..7");
  cmd->add_option_function<double>(
      "-V,--velocity", [args](double v) { args->velocity = v; }, "wall velocity V");
  cmd->add_option("--set", args->overrides, "override a case key: --set shear.duration=50");
  cmd->add_flag("--markdown", args->markdown,
                "the table of docs/case-files.md instead of an annotated case file");
  cmd->add_flag("--scene-solver", args->scene_solver,
                "the [solver] table of scene files with the engine's defaults, as markdown "
                "(docs/scene-files.md)");
  cmd->callback([args]() { print_settings(*args); });
}

}  // namespace cdshear
