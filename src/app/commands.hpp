// Subcommands of the cdshear executable; each registers itself on the CLI11 app.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "config_error.hpp"
#include "threads.hpp"

namespace cdshear {

/// Largest --threads accepted.
inline constexpr int kMaxThreads = 1024;

/// A file or folder argument: an empty one (an unset shell variable, `--resume "$RUN"`) is bad
/// input, not the absence of the option (which would start the default job instead of the
/// resume, or write to the default folder).
inline CLI::Validator non_empty(const std::string& type_name) {
  return CLI::Validator(
      [](std::string& value) {
        return value.empty() ? std::string("is empty (an unset shell variable?)") : std::string();
      },
      type_name);
}
inline const CLI::Validator kNonEmptyPath = non_empty("PATH");
/// A number argument: spaces around it are dropped (the conversion would take ` 1` and refuse
/// `1 `), and an empty one is refused, not read as 0.
inline const CLI::Validator kNonEmptyNumber = CLI::Validator(
    [](std::string& value) {
      const auto first = value.find_first_not_of(" \t");
      value = first == std::string::npos
                  ? std::string()
                  : value.substr(first, value.find_last_not_of(" \t") - first + 1);
      return value.empty() ? std::string("is empty (an unset shell variable?)") : std::string();
    },
    "");

/// An option NAME taking a whole number from 1 to kMaxThreads (threads, jobs); a value outside
/// is bad input naming the option.
inline CLI::Option* add_count_option(CLI::App* cmd, const std::string& name, int& value,
                                     const std::string& description) {
  return cmd
      ->add_option_function<int>(
          name,
          [&value, name](int n) {
            if (n < 1 || n > kMaxThreads)
              throw ConfigError(name, "",
                                "must be a whole number from 1 to " + std::to_string(kMaxThreads) +
                                    ", got " + std::to_string(n));
            value = n;
          },
          description)
      ->transform(kNonEmptyNumber)
      ->type_name("N");
}

/// CASE, `--system K`, `-V/--velocity V` and `--set key=value`: the options that choose a shear
/// case (docs/case-files.md, "Precedence"), shared by `prepare`, `run` and `settings`.
inline void add_case_choice_options(CLI::App* cmd, std::string& file, std::optional<int>& system,
                                    std::optional<double>& velocity,
                                    std::vector<std::string>& overrides) {
  cmd->add_option("case", file, "case file (TOML); default: the built-in case (system 1)")
      ->check(kNonEmptyPath);
  cmd->add_option_function<int>(
         "--system", [&system](int k) { system = k; },
         "preset of docs/model.md section 6, 1..7 (n, L_y, sigma_yy, duration)")
      ->transform(kNonEmptyNumber);
  cmd->add_option_function<double>(
         "-V,--velocity", [&velocity](double v) { velocity = v; },
         "wall velocity V (bottom -V, top +V)")
      ->transform(kNonEmptyNumber);
  cmd->add_option("--set", overrides, "override a case key: --set shear.duration=50 (repeatable)");
}

/// `--threads N`: threads of contact detection and of the coloured contact order's sweeps
/// (default: every processor, the steps on one or all of them as measured faster: run_loop.hpp,
/// thread_chooser.hpp). Not part of the case: the results are the same for any N
/// (docs/performance.md).
inline CLI::Option* add_threads_option(CLI::App* cmd, int& threads, bool chosen_by_speed) {
  return add_count_option(
      cmd, "--threads", threads,
      "threads of contact detection and of the coloured order's sweeps (default: all " +
          std::to_string(processors_available()) + " processors" +
          (chosen_by_speed ? ", each step on one or all of them, whichever is measured faster)"
                           : ")"));
}

/// `cdshear scene FILE.toml [--set key=value ...] -o DIR`
void register_scene_command(CLI::App& app);

/// `cdshear prepare ...` and `cdshear run ...` (shear cell)
void register_shear_commands(CLI::App& app);

/// `cdshear settings [CASE] [--system K] [-V V] [--set key=value ...] [--markdown]
/// [--scene-solver]`
void register_settings_command(CLI::App& app);

/// `cdshear sweep CAMPAIGN.toml [-o DIR] [--jobs N] [--threads N] [-q] [--force] [--dry-run]
/// [--progress-every S]`
void register_sweep_command(CLI::App& app);

}  // namespace cdshear
