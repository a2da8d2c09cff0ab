// A prepared packing (docs/model.md section 5, step 2): the reusable artefact from which every
// shear run of a system starts. One packing serves every wall velocity V.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vec2.hpp"

namespace cdshear {

struct PackingDisk {
  Vec2 position;  ///< centre; 0 <= x <= length_x (vertical wall at x = 0), 0 <= y <= height
  double radius = 0.5;
};

struct Packing {
  std::size_t n() const { return disks.size(); }
  double height = 0.0;    ///< L_y: distance between the horizontal walls [d]
  double length_x = 0.0;  ///< L_x: vertical wall (x = 0) to piston, at equilibrium [d]
  double diameter_min = 0.8, diameter_max = 1.0;
  std::uint64_t seed = 1;         ///< placement seed
  double solid_fraction = 0.0;    ///< sum of disk areas / (L_x L_y)
  double piston_stress = 0.25;    ///< sigma_xx it was compressed with [force/length]
  double preparation_time = 0.0;  ///< simulated time the protocol took
  // How the protocol's numerics behaved (model.md section 3 asks every run to report them).
  std::uint64_t preparation_steps = 0;
  std::uint64_t capped_steps = 0;           ///< steps whose solver hit the sweep cap
  std::uint64_t displacement_warnings = 0;  ///< steps moving a disk beyond displacement_bound
  double largest_overlap = 0.0;             ///< over the whole protocol [d]
  /// The cdshear build that prepared it (build_description()); "" for one prepared now, or read
  /// from a file that does not say.
  std::string build;
  std::vector<PackingDisk> disks;
};

/// Sum of disk areas / (L_x L_y).
double solid_fraction(const std::vector<PackingDisk>& disks, double length_x, double height);

}  // namespace cdshear
