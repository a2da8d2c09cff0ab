// cdshear: Contact Dynamics for dense 2D granular shear flow. Command-line entry point.
#include <CLI/CLI.hpp>

#include <cerrno>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <new>
#include <string>
#include <string_view>

#include "analysis_command.hpp"
#include "build_info.hpp"
#include "commands.hpp"
#include "config_error.hpp"
#include "stop_signals.hpp"

namespace {

/// Whether this processor runs what the build was compiled for (CMakeLists.txt, CDSHEAR_ARCH): a
/// build for x86-64-v3 would otherwise die of an illegal instruction somewhere in a run. This
/// file itself is built for the x86-64 baseline, so the check runs on any x86-64 processor.
bool processor_runs_this_build() {
#if defined(__x86_64__)
  // "x86-64-v3", "x86-64-v3-solver" or "x86-64-v3-solver-nofma" (only the solver's files:
  // CDSHEAR_ARCH=solver, solver-nofma).
  if (!std::string_view(CDSHEAR_INSTRUCTION_SET).starts_with("x86-64-v3")) return true;
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
         __builtin_cpu_supports("bmi2");
#else
  return true;
#endif
}

}  // namespace

int main(int argc, char** argv) {
  if (!processor_runs_this_build()) {
    std::fprintf(stderr,
                 "error: this cdshear was built for the instruction set " CDSHEAR_INSTRUCTION_SET
                 " (AVX2, FMA), which this processor lacks; rebuild it here (scripts/setup.sh "
                 "does), or with cmake -DCDSHEAR_ARCH=none for any x86-64 processor\n");
    return 1;  // not the input's fault (docs/reliability.md)
  }
  CLI::App app{"cdshear " CDSHEAR_VERSION
               ": Contact Dynamics simulation of dense granular flow sheared between walls"};
  app.set_version_flag("--version", [] {
    const cdshear::AnalysisPackage package = cdshear::find_analysis_package();
    return cdshear::build_description() + "\nanalysis package: " + package.dir.string() + " (" +
           package.source + (package.found ? "" : ", missing") + ")";
  });
  app.require_subcommand(1);
  // A malformed command line reads as every other error does ("error: ..."); set before the
  // commands are registered, which copy it.
  app.failure_message([](const CLI::App*, const CLI::Error& e) {
    return "error: " + std::string(e.what()) + "\nRun with --help for more information.\n";
  });
  cdshear::register_scene_command(app);
  cdshear::register_shear_commands(app);
  cdshear::register_settings_command(app);
  cdshear::register_sweep_command(app);
  cdshear::register_analysis_commands(app);
  // From the start, so that a signal during set-up still ends in a clean stop with a checkpoint.
  cdshear::install_stop_handlers();
  // An unknown command is named (CLI11 would only say that a subcommand is required).
  if (argc > 1 && argv[1][0] != '-') {
    bool known = false;
    std::string names;  // from the registered commands, so that the list never goes stale
    for (const CLI::App* sub : app.get_subcommands({})) {
      known = known || sub->check_name(argv[1]);
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      std::fprintf(stderr, "error: unknown command '%s'; the commands are %s (cdshear --help)\n",
                   argv[1], names.c_str());
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return app.exit(e);  // a command's own exit status (3 blown up, 130 interrupted, ...)
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; a malformed command line is bad input like any other: 2.
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  } catch (const cdshear::ConfigError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const cdshear::WriteError& e) {
    std::fprintf(stderr, "error: %s; files written before it are kept\n", e.what());
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // A path that cannot be followed (a symbolic-link loop, a name too long, a file where a
    // folder is expected) is bad input; any other refusal of the file system (permissions, a
    // full or failing disk) is not the input's fault.
    const int code = e.code().value();
    const bool bad_path =
        code == ELOOP || code == ENAMETOOLONG || code == ENOTDIR || code == ENOENT;
    std::string paths = e.path1().string();
    if (!e.path2().empty()) paths += ", " + e.path2().string();
    std::fprintf(stderr, "error: %s: %s%s\n", paths.empty() ? "a path" : paths.c_str(),
                 e.code().message().c_str(), bad_path ? "" : "; files written before it are kept");
    return bad_path ? 2 : 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr,
                 "error: cdshear %s: out of memory (the limits on sizes are in "
                 "docs/reliability.md); files already written are kept\n",
                 argc > 1 ? argv[1] : "");
    return 1;
  } catch (const std::exception& e) {
    // Every reader turns its failures into ConfigError (file, key, problem); what reaches here
    // is unexpected: say which command it stopped, and that it is ours to fix.
    std::fprintf(stderr,
                 "error: cdshear %s stopped by an unexpected error (please report it): %s\n",
                 argc > 1 ? argv[1] : "", e.what());
    return 1;
  }
  return 0;
}
