#include "preparation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "scene.hpp"
#include "scene_presets.hpp"

namespace cdshear {

double solid_fraction(const std::vector<PackingDisk>& disks, double length_x, double height) {
  double area = 0.0;
  for (const PackingDisk& d : disks) area += std::numbers::pi * d.radius * d.radius;
  return area / (length_x * height);
}

namespace {

Wall fixed_wall(const std::string& name, Vec2 point, Vec2 normal) {
  Wall w;
  w.name = name;
  w.point = point;
  w.normal = normal;
  w.friction = 0.0;
  return w;
}

/// Steps until the equilibrium criteria hold over the window; returns the simulated time spent.
double run_phase(int phase, World& world, ContactDynamics& dynamics, const PreparationOptions& o,
                 const StepOptions& step,
                 const std::function<void(const PreparationProgress&)>& progress,
                 double progress_interval, const std::atomic<bool>* cancel, Packing& stats) {
  const double dt = step.dt;
  const auto progress_every =
      std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(progress_interval / dt)));
  const auto window_steps = static_cast<std::uint64_t>(std::ceil(o.window_time / dt));
  const auto max_steps = static_cast<std::uint64_t>(std::ceil(o.max_time_per_phase / dt));
  const bool has_piston = phase == 2;
  const double applied = o.piston_stress * o.height;
  const double ek_limit = has_piston ? o.kinetic_energy_per_disk : o.settle_kinetic_energy_per_disk;
  const double n = static_cast<double>(std::max<std::size_t>(1, world.disks.size()));
  // Block averages over consecutive windows: robust to the isolated spikes of a rigid packing.
  std::uint64_t block_steps = 0;
  double ek_sum = 0.0, force_sum = 0.0;
  double block_start_x = has_piston ? world.walls.back().point.x : 0.0;
  for (std::uint64_t s = 1; s <= max_steps; ++s) {
    if (cancel != nullptr && cancel->load()) throw PreparationInterrupted(phase);
    const StepReport r = dynamics.step(world, step);
    ++stats.preparation_steps;
    stats.capped_steps += r.solver.hit_cap;
    stats.displacement_warnings += r.displacement_exceeded;
    stats.largest_overlap = std::max(stats.largest_overlap, r.max_overlap);
    if (r.blown_up)
      throw PreparationFailed("preparation phase " + std::to_string(phase) + " blew up at step " +
                              std::to_string(r.step) + ": " + r.problem);
    const double ek = kinetic_energy(world) / n;
    const Wall* piston = has_piston ? &world.walls.back() : nullptr;
    const double speed = piston ? std::abs(piston->velocity.x) : 0.0;
    ++block_steps;
    ek_sum += ek;
    force_sum += piston ? piston->contact_force.x : 0.0;
    if (block_steps == window_steps) {
      const double span = static_cast<double>(block_steps) * dt;
      const double mean_ek = ek_sum / static_cast<double>(block_steps);
      const double drift = piston ? std::abs(piston->point.x - block_start_x) / span : 0.0;
      const double mean_force = force_sum / static_cast<double>(block_steps);
      const bool balanced =
          !has_piston || std::abs(mean_force - applied) <= o.force_balance * applied;
      if (mean_ek < ek_limit && drift < o.piston_speed && balanced)
        return static_cast<double>(s) * dt;
      block_steps = 0;
      ek_sum = force_sum = 0.0;
      block_start_x = piston ? piston->point.x : 0.0;
    }
    if (progress && s % progress_every == 0) {
      PreparationProgress p;
      p.phase = phase;
      p.time = world.time;
      p.kinetic_energy_per_disk = ek;
      p.piston_x = piston ? piston->point.x : 0.0;
      p.piston_speed = speed;
      p.report = r;
      progress(p);
    }
  }
  char limit[32];
  std::snprintf(limit, sizeof limit, "%g", o.max_time_per_phase);
  throw PreparationFailed(
      "preparation phase " + std::to_string(phase) + " (" +
      (phase == 1 ? "settling" : "compression") +
      ") did not reach equilibrium within preparation.max_time_per_phase = " + limit +
      " time units; nothing was written (give a longer preparation.max_time_per_phase, or looser "
      "equilibrium thresholds: docs/shear-cell.md, \"Preparation\")");
}

}  // namespace

Packing prepare_packing(const PreparationOptions& o,
                        const std::function<void(const PreparationProgress&)>& progress,
                        double progress_interval, const std::atomic<bool>* cancel) {
  const double a = o.diameter_min, b = o.diameter_max;
  const double total_area = expected_disk_area(o.n, a, b);
  const double loose_length = total_area / (o.initial_solid_fraction * o.height);

  SceneDefinition scene;
  scene.friction_disk_disk = 0.0;
  scene.gravity = {-o.gravity, 0.0};
  scene.walls = {fixed_wall("bottom", {0.0, 0.0}, {0.0, 1.0}),
                 fixed_wall("top", {0.0, o.height}, {0.0, -1.0}),
                 fixed_wall("left", {0.0, 0.0}, {1.0, 0.0})};
  RandomDisksSpec loose;
  loose.count = o.n;
  loose.region_min = {0.0, 0.0};
  loose.region_max = {loose_length, o.height};
  loose.diameter_min = a;
  loose.diameter_max = b;
  loose.seed = o.seed;
  scene.random_disks.push_back(loose);
  World world;
  try {
    world = build_world(scene, cancel);
  } catch (const PlacementCancelled&) {
    throw PreparationInterrupted(0);
  }
  ContactDynamics dynamics;
  Packing packing;

  double elapsed =
      run_phase(1, world, dynamics, o, o.step, progress, progress_interval, cancel, packing);

  // Phase 2: gravity off, piston on the free surface.
  world.body_force = {};
  double surface = 0.0;
  for (std::size_t i = 0; i < world.disks.size(); ++i)
    surface = std::max(surface, world.disks.position[i].x + world.disks.radius[i]);
  Wall piston = fixed_wall("piston", {surface, 0.0}, {-1.0, 0.0});
  piston.mode_x = AxisMode::kFree;
  piston.mass = o.piston_mass;
  piston.applied_force = {-o.piston_stress * o.height, 0.0};
  world.walls.push_back(piston);
  StepOptions compression = o.step;
  compression.dt = o.compression_dt;
  elapsed +=
      run_phase(2, world, dynamics, o, compression, progress, progress_interval, cancel, packing);

  packing.height = o.height;
  packing.length_x = world.walls.back().point.x;
  packing.diameter_min = a;
  packing.diameter_max = b;
  packing.seed = o.seed;
  packing.piston_stress = o.piston_stress;
  packing.preparation_time = elapsed;
  for (std::size_t i = 0; i < world.disks.size(); ++i)
    packing.disks.push_back({world.disks.position[i], world.disks.radius[i]});
  // Numbered by height (y, then x): the solver's threads own bands of height, and contacts are
  // listed by the number of their lower disk, so numbers that follow the height keep a thread's
  // disks and contacts together in memory (docs/performance.md, "Disk numbers").
  std::stable_sort(packing.disks.begin(), packing.disks.end(),
                   [](const PackingDisk& a, const PackingDisk& b) {
                     return a.position.y != b.position.y ? a.position.y < b.position.y
                                                         : a.position.x < b.position.x;
                   });
  packing.solid_fraction = solid_fraction(packing.disks, packing.length_x, packing.height);
  return packing;
}

}  // namespace cdshear
