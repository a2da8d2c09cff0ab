// Subcommands of the cdshear executable; each registers itself on the CLI11 app.
#pragma once

#include <CLI/CLI.hpp>

namespace cdshear {

/// `cdshear scene FILE.toml [--set key=value ...] -o DIR`
void register_scene_command(CLI::App& app);

/// `cdshear prepare ...` and `cdshear run ...` (shear cell)
void register_shear_commands(CLI::App& app);

}  // namespace cdshear
