// Packing files (JSON): the output of `cdshear prepare`, the input of every shear run.
#pragma once

#include <filesystem>
#include <string>

#include "packing.hpp"
#include "preparation.hpp"

namespace cdshear {

void write_packing(const std::filesystem::path& path, const Packing& packing);
/// Checks, before a packing is prepared (minutes to hours), that write_packing will be able to
/// write it to `path`: a file name, not a folder; nothing but a regular file in its place (a FIFO
/// or a device would be replaced by the packing); a folder that exists, or is made now, and takes
/// a new file. Throws ConfigError naming the path and the problem. An existing packing there is
/// replaced, as `-o` asks.
void check_packing_destination(const std::filesystem::path& path);
/// Throws ConfigError naming the file and the key for a missing file, a wrong format, or
/// inconsistent content (non-positive sizes or radii, a disk crossing a horizontal wall by more
/// than `overlap_tolerance`). Overlaps between disks are checked when the shear world is built.
Packing read_packing(const std::filesystem::path& path, double overlap_tolerance = 1e-3);

/// Cache name of a packing prepared with these options, for example
/// "n511_h20_d0.8-1_seed1_s0.25_1a2b3c4d.json" (the last part hashes every option of the
/// protocol): one packing serves every V of a system.
std::string packing_cache_name(const PreparationOptions& o);

}  // namespace cdshear
