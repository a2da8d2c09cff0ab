// What build of cdshear is running: version, git commit of its source tree (and whether the tree
// differed from it), build type and instruction set. Printed by `cdshear --version`, written to
// run_info.json and run.h5, so that a result names the code that made it.
#pragma once

#include <string>

namespace cdshear {

struct BuildInfo {
  std::string version;          ///< the program's version (CMake PROJECT_VERSION)
  std::string commit;           ///< 12 hex digits, or "unknown" outside a git tree
  std::string modified;         ///< "yes", "no": tracked files differing from the commit; "unknown"
  std::string build_type;       ///< CMAKE_BUILD_TYPE (Release, Debug...)
  std::string instruction_set;  ///< CDSHEAR_ARCH's instruction set (changes the rounding)
};

BuildInfo build_info();

/// One line: "cdshear 0.1.0 (commit 4707e7d1a2b3, tree modified; Release build, instruction set
/// x86-64-v3-solver)".
std::string build_description();

}  // namespace cdshear
