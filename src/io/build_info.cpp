#include "build_info.hpp"

#include "cdshear_git.hpp"

#ifndef CDSHEAR_BUILD_TYPE_NAME
#define CDSHEAR_BUILD_TYPE_NAME "unknown"
#endif

namespace cdshear {

BuildInfo build_info() {
  return {CDSHEAR_VERSION, CDSHEAR_GIT_COMMIT, CDSHEAR_GIT_MODIFIED, CDSHEAR_BUILD_TYPE_NAME,
          CDSHEAR_INSTRUCTION_SET};
}

std::string build_description() {
  const BuildInfo b = build_info();
  std::string tree = b.modified == "yes"  ? ", tree modified"
                     : b.modified == "no" ? ""
                                          : ", tree state unknown";
  return "cdshear " + b.version + " (commit " + b.commit + tree + "; " +
         (b.build_type.empty() ? std::string("unknown") : b.build_type) +
         " build, instruction set " + b.instruction_set + ")";
}

}  // namespace cdshear
