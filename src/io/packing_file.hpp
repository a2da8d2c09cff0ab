// Packing files (JSON): the output of `cdshear prepare`, the input of every shear run.
#pragma once

#include <filesystem>
#include <string>

#include "packing.hpp"
#include "preparation.hpp"

namespace cdshear {

void write_packing(const std::filesystem::path& path, const Packing& packing);
/// Throws ConfigError naming the file and the key for a missing file, a wrong format, or
/// inconsistent content (disk outside the cell, overlap above `overlap_tolerance`).
Packing read_packing(const std::filesystem::path& path, double overlap_tolerance = 1e-3);

/// Cache name of a packing prepared with these options, for example
/// "n511_h20_d0.8-1_seed1_s0.25.json": one packing serves every V of a system.
std::string packing_cache_name(const PreparationOptions& o);

}  // namespace cdshear
