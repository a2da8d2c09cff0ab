#include "shear_case.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "scene.hpp"

namespace cdshear {

double default_time_step(const ShearCase& c) {
  return std::min(c.dt_max, c.displacement_per_step / c.velocity);
}

double default_alpha(double velocity) {
  const double v = std::clamp(velocity, kAlphaSlowSpeed, kAlphaFullSpeed) / kAlphaFullSpeed;
  return shear_step_defaults().solver.alpha * v * v;
}

double default_residual_tolerance(double velocity, double dt) {
  return kResidualPerSpeed * std::max(velocity, kAlphaSlowSpeed) * dt;
}

std::string resolve_step_rules(ShearCase& c) {
  c.step.solver.alpha = c.alpha ? *c.alpha : default_alpha(c.velocity);
  c.step.dt = c.dt ? *c.dt : default_time_step(c);
  c.step.solver.residual_tolerance = c.residual_tolerance
                                         ? *c.residual_tolerance
                                         : default_residual_tolerance(c.velocity, c.step.dt);
  const double per_step = c.velocity * c.step.dt;
  if (per_step > c.step.displacement_bound) {
    char text[256];  // %g: a bound of 1e-300 is not "0.000000"
    std::snprintf(text, sizeof text,
                  "step.dt = %.6g moves the walls by V dt = %.6g per step, above "
                  "step.displacement_bound = %.6g; the default rule would give dt = %.6g",
                  c.step.dt, per_step, c.step.displacement_bound, default_time_step(c));
    return text;
  }
  return {};
}

std::vector<double> default_boundary_thickness(double height) {
  return {height >= 40.0 ? 10.0 : height / 4.0};
}

void apply_system_preset(ShearCase& c, int system) {
  struct Row {
    std::size_t n;
    double height, stress, duration;
  };
  // docs/model.md section 6. Durations: the reference simulated time (system 5: the upper value).
  static constexpr Row rows[] = {{511, 20, 0.25, 20000},    {1023, 40, 0.25, 10000},
                                 {1023, 40, 0.0625, 10000}, {3199, 50, 0.25, 8000},
                                 {2047, 80, 0.25, 12000},   {3071, 120, 0.25, 6000},
                                 {5119, 200, 0.25, 13000}};
  if (system < 1 || system > 7)
    throw std::invalid_argument("system must be 1..7, got " + std::to_string(system));
  const Row& r = rows[system - 1];
  c.n = r.n;
  c.height = r.height;
  c.normal_stress = r.stress;
  c.duration = r.duration;
  c.measure.window = 80.0;  // the windows of model.md section 7
  // System 4 is 50 wide: its packing is prepared to that width by the same protocol.
  sync_preparation(c);
}

void sync_preparation(ShearCase& c) {
  c.preparation.n = c.n;
  c.preparation.height = c.height;
  c.preparation.diameter_min = c.diameter_min;
  c.preparation.diameter_max = c.diameter_max;
  c.preparation.seed = c.seed;
}

namespace {

/// The bottom and top walls of the shear cell (indices kBottomWall, kTopWall) at y = 0 and
/// `height`, loaded by sigma_yy `length_x`.
std::vector<Wall> shear_walls(const ShearCase& c, double length_x, double height) {
  const double force_y = c.normal_stress * length_x;
  std::vector<Wall> walls;
  for (const bool top : {false, true}) {
    Wall w;
    w.name = top ? "top" : "bottom";
    w.point = {0.0, top ? height : 0.0};
    w.normal = {0.0, top ? -1.0 : 1.0};
    w.mode_x = AxisMode::kImposed;
    w.mode_y = AxisMode::kFree;
    w.velocity = {top ? c.velocity : -c.velocity, 0.0};
    w.mass = c.wall_mass;
    w.applied_force = {0.0, top ? -force_y : force_y};
    w.friction = c.friction_wall;
    walls.push_back(w);
  }
  return walls;
}

}  // namespace

World build_shear_world(const ShearCase& c, const Packing& p) {
  SceneDefinition scene;
  scene.domain.periodic_x = true;
  scene.domain.length_x = p.length_x;
  scene.friction_disk_disk = c.friction_grain;
  scene.walls = shear_walls(c, p.length_x, p.height);
  const bool at_rest = c.initial_velocity == kInitialRest;
  if (!at_rest && c.initial_velocity != kInitialLinear)
    throw std::invalid_argument("initial_velocity must be \"" + std::string(kInitialLinear) +
                                "\" or \"" + kInitialRest + "\", not \"" + c.initial_velocity +
                                "\"");
  for (const PackingDisk& d : p.disks) {
    DiskSpec s;
    s.position = d.position;
    s.radius = d.radius;
    s.velocity = {at_rest ? 0.0 : -c.velocity + 2.0 * c.velocity * d.position.y / p.height, 0.0};
    scene.disks.push_back(s);
  }
  // The packing was in equilibrium with overlaps at the solver's tolerance; accept those.
  scene.overlap_tolerance = std::max(1e-9, c.step.abort_overlap * 0.1);
  return build_world(scene);
}

std::string wall_gap_problem(double height, double nominal_height) {
  if (height > kHeightRange[0] * nominal_height && height < kHeightRange[1] * nominal_height)
    return {};
  char text[160];
  std::snprintf(text, sizeof text,
                "the walls flew apart or collapsed: L_y = %.6g, outside %g to %g times the "
                "nominal %g",
                height, kHeightRange[0], kHeightRange[1], nominal_height);
  return text;
}

ShearWorldProblem shear_world_problem(const World& w, const ShearCase& c) {
  const auto number = [](double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.17g", v);
    return std::string(text);
  };
  const auto differs = [&](const std::string& what, double have, double want) {
    return what + " is " + number(have) + ", the case's run has " + number(want);
  };
  if (!w.domain.periodic_x) return {"periodic_x", "is false: the shear cell is periodic in x"};
  if (w.body_force.x != 0.0 || w.body_force.y != 0.0)
    return {"body_force", "is not zero: the shear cell has no gravity"};
  if (w.friction_disk_disk != c.friction_grain)
    return {"friction_disk_disk",
            differs("the grain friction", w.friction_disk_disk, c.friction_grain)};
  if (w.walls.size() != 2)
    return {"walls", "holds " + std::to_string(w.walls.size()) + " walls, the shear cell 2"};
  // The walls as build_shear_world makes them; of theirs, what a run never changes.
  const std::vector<Wall> made = shear_walls(c, w.domain.length_x, 0.0);
  for (const std::size_t k : {kBottomWall, kTopWall}) {
    const Wall& wall = w.walls[k];
    const Wall& want = made[k];
    const std::string at = "walls[" + std::to_string(k) + "].";
    if (wall.name != want.name)
      return {at + "name", "is '" + wall.name + "', not '" + want.name + "'"};
    if (wall.normal.x != want.normal.x || wall.normal.y != want.normal.y)
      return {at + "normal",
              "must be [" + number(want.normal.x) + ", " + number(want.normal.y) + "]"};
    if (wall.mode_x != want.mode_x || wall.mode_y != want.mode_y)
      return {at + "mode_x", "the walls are driven along x and free along y"};
    if (wall.velocity.x != want.velocity.x)
      return {at + "velocity", differs("its velocity along x", wall.velocity.x, want.velocity.x)};
    if (wall.mass != want.mass) return {at + "mass", differs("its mass", wall.mass, want.mass)};
    if (wall.friction != want.friction)
      return {at + "friction", differs("its friction", wall.friction, want.friction)};
    if (wall.applied_force.x != want.applied_force.x ||
        wall.applied_force.y != want.applied_force.y)
      return {at + "applied_force",
              differs("its load along y", wall.applied_force.y, want.applied_force.y) +
                  " (sigma_yy L_x)"};
  }
  Disks unit;  // a disk of each radius, as build_shear_world adds it (unit density)
  for (std::size_t i = 0; i < w.disks.size(); ++i) {
    unit.clear();
    unit.add({}, w.disks.radius[i]);
    if (w.disks.mass[i] != unit.mass[0] || w.disks.inertia[i] != unit.inertia[0])
      return {"disks[" + std::to_string(i) + "]",
              "its mass and moment of inertia are not those of its radius " +
                  number(w.disks.radius[i]) + " at unit density"};
  }
  // The time is summed step by step (ContactDynamics::step): after n steps it is n dt within
  // n rounding errors of at most eps t each, 2.2e-7 t at the 2e9 steps a run may take; 1e-6
  // leaves that room and finds a time step changed in case.toml by more than a millionth (half
  // a step would let a change of 0.1% go through on a run of a thousand steps).
  const double dt = c.step.dt;
  const double expected = static_cast<double>(w.step) * dt;
  if (!(std::abs(w.time - expected) <= 1e-6 * expected + 1e-12 * dt))
    return {"time", "is " + number(w.time) + ", not step x dt = " + std::to_string(w.step) + " x " +
                        number(dt) + " (was the time step changed?)"};
  return {};
}

}  // namespace cdshear
