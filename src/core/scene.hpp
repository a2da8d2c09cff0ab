// The one scene builder: a plain description of a system (domain, walls, disks given one by one
// or generated) and the function that turns it into a World. The TOML reader (io/scene_file),
// the tests, the benchmarks and the shear-cell preparation all build their worlds through it.
#pragma once

#include <atomic>
#include <stdexcept>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "contact_dynamics.hpp"
#include "world.hpp"

namespace cdshear {

/// A scene that cannot be built (overlap, impossible placement, bad value). `key` names the
/// offending entry in scene terms (for example "disks.random[0].count") when known.
class SceneError : public std::runtime_error {
 public:
  /// `key`: where the problem is; `other_key`: a key whose value takes part in it (the density
  /// in a disk's mass), which a command line that gave it is blamed for.
  SceneError(std::string key, const std::string& what, std::string other_key = "")
      : std::runtime_error(what), key_(std::move(key)), other_key_(std::move(other_key)) {}
  const std::string& key() const { return key_; }
  const std::string& other_key() const { return other_key_; }

 private:
  std::string key_, other_key_;
};

struct DiskSpec {
  Vec2 position;
  double radius = 0.5;
  Vec2 velocity;
  double omega = 0.0;
};

/// n disks with diameters uniform in [diameter_min, diameter_max], placed at random without
/// overlap, fully inside the box [region_min, region_max] (random sequential addition).
struct RandomDisksSpec {
  std::size_t count = 0;
  Vec2 region_min, region_max;
  double diameter_min = 0.8, diameter_max = 1.0;
  std::uint64_t seed = 1;
  int max_attempts_per_disk = 20000;
};

struct SceneDefinition {
  Domain domain;
  Vec2 gravity;  ///< body force per unit mass on every disk
  double friction_disk_disk = 0.5;
  double density = 1.0;  ///< 2D mass density of the disks
  std::vector<Wall> walls;
  std::vector<DiskSpec> disks;
  std::vector<RandomDisksSpec> random_disks;
  double overlap_tolerance = 1e-9;  ///< initial overlaps above this are an error [length]
};

/// Builds the world: explicit disks first, then each random group. Throws SceneError when the
/// definition is invalid, when disks overlap (or cross a wall) by more than the tolerance, or
/// when random placement cannot fit the disks.
/// `cancel` (optional, set by a signal handler at the edges) is checked between placed disks:
/// when it is set, PlacementCancelled is thrown, so that a long random placement stops at once.
World build_world(const SceneDefinition& scene, const std::atomic<bool>* cancel = nullptr);

/// Thrown by build_world when its cancel flag is set during random placement.
struct PlacementCancelled : std::runtime_error {
  PlacementCancelled() : std::runtime_error("random placement interrupted") {}
};

/// Why a disk of this radius cannot move (its mass or moment of inertia at `density` is no normal
/// floating-point number, so that its inverse overflows or loses its digits), or "" when it can.
std::string disk_mass_problem(double density, double radius);

/// Why a body of this mass cannot move (the mass or its inverse is no normal floating-point
/// number), or "" when it can.
std::string body_mass_problem(double mass);

/// Checks the definition's values (positive radii, masses of free walls, unit-able normals,
/// periodic length large enough). Throws SceneError naming the key.
void validate_scene(const SceneDefinition& scene);

/// Largest overlap between disks or between a disk and a wall in `world`, with the two bodies
/// (walls numbered after the disks). Uses the cell list.
struct OverlapReport {
  double overlap = 0.0;
  std::size_t body_a = 0, body_b = 0;
};
OverlapReport largest_overlap(const World& world);

}  // namespace cdshear
