#include "scene_presets.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace cdshear {

double expected_disk_area(std::size_t count, double diameter_min, double diameter_max) {
  const double mean_d2 = diameter_max > diameter_min
                             ? (diameter_max * diameter_max * diameter_max -
                                diameter_min * diameter_min * diameter_min) /
                                   (3.0 * (diameter_max - diameter_min))
                             : diameter_min * diameter_min;
  return static_cast<double>(count) * std::numbers::pi / 4.0 * mean_d2;
}

SceneDefinition compressed_box_scene(const CompressedBoxParams& p) {
  if (!(p.width > 0.0)) throw SceneError("width", "must be > 0");
  if (!(p.initial_solid_fraction > 0.0 && p.initial_solid_fraction < 1.0))
    throw SceneError("initial_solid_fraction", "must be in (0, 1)");
  const double area = expected_disk_area(p.count, p.diameter_min, p.diameter_max);
  // At least two largest diameters high, so that an empty or tiny box is still a box.
  const double height = std::max(area / (p.width * p.initial_solid_fraction), 2.0 * p.diameter_max);

  SceneDefinition s;
  s.domain.periodic_x = p.periodic_x;
  s.domain.length_x = p.periodic_x ? p.width : 0.0;
  s.gravity = {};
  s.friction_disk_disk = p.friction_disk_disk;
  s.density = p.density;

  Wall bottom;
  bottom.name = "bottom";
  bottom.point = {0.0, 0.0};
  bottom.normal = {0.0, 1.0};
  bottom.friction = p.friction_wall;
  s.walls.push_back(bottom);

  Wall top;
  top.name = "top";
  top.point = {0.0, height};
  top.normal = {0.0, -1.0};
  top.mode_y = AxisMode::kFree;
  top.mass = p.top_wall_mass;
  top.applied_force = {0.0, -p.pressure * p.width};
  top.friction = p.friction_wall;
  s.walls.push_back(top);

  if (!p.periodic_x) {
    Wall left;
    left.name = "left";
    left.point = {0.0, 0.0};
    left.normal = {1.0, 0.0};
    left.friction = p.friction_wall;
    s.walls.push_back(left);
    Wall right = left;
    right.name = "right";
    right.point = {p.width, 0.0};
    right.normal = {-1.0, 0.0};
    s.walls.push_back(right);
  }

  RandomDisksSpec r;
  r.count = p.count;
  r.region_min = {0.0, 0.0};
  r.region_max = {p.width, height};
  r.diameter_min = p.diameter_min;
  r.diameter_max = p.diameter_max;
  r.seed = p.seed;
  s.random_disks.push_back(r);
  return s;
}

void start_compaction(World& world, double speed) {
  if (world.walls.size() <= kBoxTopWall)
    throw std::invalid_argument("start_compaction: the world is not a compressed box");
  const double y0 = world.walls[kBoxBottomWall].point.y;
  const double h = world.walls[kBoxTopWall].point.y - y0;
  world.walls[kBoxTopWall].velocity.y = -speed;
  for (std::size_t i = 0; i < world.disks.size(); ++i)
    world.disks.velocity[i] = {0.0, h > 0.0 ? -speed * (world.disks.position[i].y - y0) / h : 0.0};
}

StepOptions densify_step_options() {
  StepOptions s;
  s.dt = 4e-3;
  s.displacement_bound = 0.02;
  s.solver.alpha = 1e-4;
  s.solver.max_sweeps = 20;
  return s;
}

namespace {

DensifyReport measure_box(const World& world, const ContactDynamics& dynamics) {
  DensifyReport r;
  const std::size_t n = world.disks.size();
  r.kinetic_energy_per_disk = n > 0 ? kinetic_energy(world) / static_cast<double>(n) : 0.0;
  const Wall& top = world.walls[kBoxTopWall];
  const Wall& bottom = world.walls[kBoxBottomWall];
  r.top_wall_speed = std::abs(top.velocity.y);
  const double applied = std::abs(top.applied_force.y);
  r.top_wall_support = applied > 0.0 ? top.contact_force.y / applied : 0.0;
  r.height = top.point.y - bottom.point.y;
  double disk_area = 0.0;
  for (const double radius : world.disks.radius) disk_area += std::numbers::pi * radius * radius;
  // Width: the period, or the distance between the side walls.
  double width = 0.0;
  if (world.domain.periodic_x)
    width = world.domain.length_x;
  else if (world.walls.size() >= 4)
    width = std::abs(world.walls[3].point.x - world.walls[2].point.x);
  r.solid_fraction = r.height > 0.0 && width > 0.0 ? disk_area / (width * r.height) : 0.0;
  r.contacts = dynamics.contacts().size();
  return r;
}

}  // namespace

DensifyReport densify(World& world, ContactDynamics& dynamics, const DensifyOptions& options) {
  if (world.walls.size() <= kBoxTopWall)
    throw std::invalid_argument("densify: the world is not a compressed box");
  const std::uint64_t check_every = std::max<std::uint64_t>(1, options.check_every);
  std::uint64_t steps = 0, capped = 0;
  bool dense = false;
  while (steps < options.max_steps) {
    const StepReport s = dynamics.step(world, options.step);
    ++steps;
    capped += s.solver.hit_cap;
    if (s.blown_up)
      throw std::runtime_error("densify: step " + std::to_string(s.step) +
                               " blew up: " + s.problem);
    if (steps >= options.min_steps && steps % check_every == 0) {
      const DensifyReport now = measure_box(world, dynamics);
      if (now.kinetic_energy_per_disk <= options.max_kinetic_energy_per_disk &&
          now.top_wall_speed <= options.max_top_wall_speed &&
          now.top_wall_support >= options.min_top_wall_support) {
        dense = true;
        break;
      }
    }
  }
  DensifyReport r = measure_box(world, dynamics);
  r.dense = dense;
  r.steps = steps;
  r.capped_steps = capped;
  return r;
}

DenseBox make_dense_box(const CompressedBoxParams& p, const DensifyOptions& options) {
  DenseBox box{build_world(compressed_box_scene(p)), ContactDynamics{}, DensifyReport{}};
  start_compaction(box.world, p.compaction_speed);
  box.report = densify(box.world, box.dynamics, options);
  box.world.time = 0.0;
  box.world.step = 0;
  return box;
}

}  // namespace cdshear
