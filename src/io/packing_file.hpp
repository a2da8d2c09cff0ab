// Packing files (JSON): the output of `cdshear prepare`, the input of every shear run.
#pragma once

#include <filesystem>
#include <string>

#include "packing.hpp"
#include "preparation.hpp"
#include "shear_case.hpp"

namespace cdshear {

/// Writes `packing` to `path` atomically, first removing the temporaries that killed writes of it
/// left (remove_dead_writers_temporaries).
void write_packing(const std::filesystem::path& path, const Packing& packing);
/// Checks, before a packing is prepared (minutes to hours), that write_packing will be able to
/// write it to `path`: a file name, not a folder; nothing but a regular file in its place (a FIFO
/// or a device would be replaced by the packing); a folder that exists, or is made now, and takes
/// a new file. Throws ConfigError naming the path and the problem. An existing packing there is
/// replaced, as `-o` asks; any other file there (a case file, a run's run.h5) is refused.
void check_packing_destination(const std::filesystem::path& path);

/// True when `path` holds a cdshear packing: a JSON object whose "format" is "cdshear-packing"
/// (whether the rest is a valid packing is not checked). False for anything else, unreadable
/// or over 1 GiB (not read).
bool is_packing_file(const std::filesystem::path& path);
/// The least solid fraction a packing file may have: the walls must rest on a packing, not on a
/// few grains in a cell far wider than its disks fill.
inline constexpr double kSmallestPackingSolidFraction = 0.1;

/// Throws ConfigError naming the file and the key for a missing file, a wrong format (not JSON, a
/// key given twice, an unknown key, another version, a disk that is not three numbers, a count
/// `n` that disagrees with the list) or inconsistent content (non-positive sizes or radii, a disk
/// crossing a horizontal wall by more than `overlap_tolerance`, a solid fraction outside
/// [kSmallestPackingSolidFraction, 1]). Overlaps between disks are checked when the shear world
/// is built.
Packing read_packing(const std::filesystem::path& path, double overlap_tolerance = 1e-3);

/// How far a disk may cross a wall in a packing read for case `c` (read_packing's
/// `overlap_tolerance`): a tenth of the overlap at which the case's steps abort.
inline double packing_wall_tolerance(const ShearCase& c) {
  return 0.1 * c.step.abort_overlap;
}

/// Throws ConfigError naming `file` and the key when the packing was made for another system than
/// the case's: another number of disks, height or diameter range.
void check_packing_fits_case(const ShearCase& c, const Packing& p, const std::string& file);

/// Cache name of a packing prepared with these options, for example
/// "n511_h20_d0.8-1_seed1_s0.25_1a2b3c4d.json" (the last part hashes every option of the
/// protocol): one packing serves every V of a system.
std::string packing_cache_name(const PreparationOptions& o);

}  // namespace cdshear
