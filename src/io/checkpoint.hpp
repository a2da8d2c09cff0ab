// Checkpoints: the complete dynamic state (world + contact memory for warm starts), written
// atomically as CBOR (nlohmann-json's binary format: doubles stored bit-exact), so that a run
// resumed from one continues exactly as if it had never stopped. A checkpoint starts with a seal
// line holding the CRC-32 and size of the CBOR after it (a changed or damaged file is refused
// before it is parsed) and, for shear runs, the identity of the
// case it belongs to (a checkpoint copied from another run is refused).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "contact.hpp"
#include "world.hpp"

namespace cdshear {

struct Checkpoint {
  World world;
  std::vector<Contact> contacts;  ///< keys and impulses (the rest is recomputed at detection)
  nlohmann::json observers;       ///< observers' running state (null when none was stored)
  nlohmann::json case_identity;   ///< the physics of the case it belongs to (null: not stored)
  /// The instruction set of the cdshear that wrote it (CMakeLists.txt, CDSHEAR_ARCH); empty when
  /// written before checkpoints named it.
  std::string instruction_set;
};

/// `instruction_set`: the writer's, this build's unless a test says otherwise.
void write_checkpoint(const std::filesystem::path& path, const World& world,
                      const std::vector<Contact>& contacts,
                      const nlohmann::json& observers = nullptr,
                      const nlohmann::json& case_identity = nullptr,
                      const std::string& instruction_set = CDSHEAR_INSTRUCTION_SET);

/// Throws ConfigError naming the file and the field when it is missing, not a cdshear
/// checkpoint, fails its checksum, or holds a value no run can have (NaN, radius <= 0, L_x <= 0,
/// an unknown wall mode, a contact index out of range).
Checkpoint read_checkpoint(const std::filesystem::path& path);

/// Whether builds for instruction sets `a` and `b` (CDSHEAR_INSTRUCTION_SET) give the same
/// results bit for bit: the same set, or two without fused multiply-adds (the baseline
/// "default", and "x86-64-v3-solver-nofma", whose every operation rounds as the source writes).
bool same_rounding(const std::string& a, const std::string& b);

/// A warning for a resume of `cp` by this build (empty when there is none to give): a build for
/// another instruction set may round differently (docs/performance.md, "Fused multiply-add"), so
/// the resumed run is another realisation of the flow from that point on, not the one the
/// first build would have continued bit for bit. Builds that round alike (same_rounding) are
/// not warned of.
std::string instruction_set_warning(const Checkpoint& cp, const std::string& file,
                                    const std::string& this_build = CDSHEAR_INSTRUCTION_SET);

}  // namespace cdshear
