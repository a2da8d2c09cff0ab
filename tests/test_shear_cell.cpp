// The shear cell (docs/model.md sections 4 to 6): the prepared packing of system 1, momentum
// balance of a short shear run, and bad case values. The packing comes from the ctest fixture
// `system1_packing` (`cdshear prepare`), whose path is CDSHEAR_SYSTEM1_PACKING.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>

#include "case_file.hpp"
#include "config_error.hpp"
#include "contact_dynamics.hpp"
#include "packing_file.hpp"
#include "scene.hpp"
#include "shear_case.hpp"
#include "test_support.hpp"

namespace cdshear {
namespace {

const Packing& system1_packing() {
  static const Packing p = read_packing(CDSHEAR_SYSTEM1_PACKING);
  return p;
}

TEST(Preparation, System1HasNominalSizeAndDenseRandomSolidFraction) {
  const Packing& p = system1_packing();
  ASSERT_EQ(p.n(), 511u);
  EXPECT_DOUBLE_EQ(p.height, 20.0);
  // Nominal L_x = 20 (model.md section 6) corresponds to a solid fraction of 0.816 for these 511
  // disks. Frictionless polydisperse disks jam between about 0.80 and 0.85 depending on protocol
  // (random close packing of bidisperse/polydisperse disks: 0.82-0.84), i.e. L_x within 4% of
  // 20: [19.2, 20.4] covers that range with margin and would catch a loose or crystallised
  // packing, or a piston that never reached the surface.
  EXPECT_NEAR(p.length_x, 20.0, 0.04 * 20.0);
  EXPECT_GT(p.solid_fraction, 0.80);
  EXPECT_LT(p.solid_fraction, 0.86);
  // The solid fraction is consistent with the disks actually stored.
  double area = 0.0;
  for (const PackingDisk& d : p.disks) area += std::numbers::pi * d.radius * d.radius;
  EXPECT_NEAR(p.solid_fraction, area / (p.length_x * p.height), 1e-12);
  // Diameters in [0.8, 1.0] and every disk inside the cell.
  for (const PackingDisk& d : p.disks) {
    EXPECT_GE(2 * d.radius, 0.8);
    EXPECT_LE(2 * d.radius, 1.0);
    EXPECT_GE(d.position.x, d.radius - 1e-3);
    EXPECT_LE(d.position.x, p.length_x - d.radius + 1e-3);
  }
}

TEST(Preparation, NumbersTheDisksByHeight) {
  // The packing lists its disks by height (y, then x): the solver's threads own bands of height
  // and detection lists contacts by disk number (docs/performance.md, "Disk numbers"). The
  // random placement numbers them in no spatial order, so this fails unless the preparation
  // sorts them.
  const Packing& p = system1_packing();
  for (std::size_t i = 1; i < p.n(); ++i) {
    const Vec2 a = p.disks[i - 1].position, b = p.disks[i].position;
    ASSERT_TRUE(a.y < b.y || (a.y == b.y && a.x <= b.x)) << "disks " << i - 1 << " and " << i;
  }
}

TEST(Preparation, System1HasNoOverlapAboveTolerance) {
  // In the periodic shear cell built from the packing (which also checks pairs across x = 0),
  // the largest overlap is that of a converged rigid packing: the solver removes overlaps each
  // step (gap + dt u_n = 0), leaving only what unconverged steps (alpha = 1e-6) let through.
  // 1e-4 d is 100 times above what we measured (~1e-6 d) and 1000 times below a visible overlap.
  ShearCase c;
  const World world = build_shear_world(c, system1_packing());
  const OverlapReport o = largest_overlap(world);
  EXPECT_LT(o.overlap, 1e-4) << "bodies " << o.body_a << " and " << o.body_b;
}

TEST(Preparation, ThePackingMeetsTheEquilibriumCriteriaWhenCheckedAgain) {
  // docs/shear-cell.md: phase 2 ends with a block of window_time whose mean kinetic energy per
  // disk is below kinetic_energy_per_disk, whose piston drift is below piston_speed, and whose
  // mean piston force equals sigma_xx L_y within force_balance. Rebuilt from the packing file
  // (at rest, frictionless, no gravity, the piston at L_x under its force) and run for one more
  // block, the packing must pass the same three tests: it is an equilibrium, not a snapshot of a
  // packing still moving.
  const Packing& p = system1_packing();
  const PreparationOptions o = ShearCase{}.preparation;
  SceneDefinition s;
  s.friction_disk_disk = 0.0;
  Wall bottom, top, left, piston;
  bottom.name = "bottom", bottom.normal = {0.0, 1.0};
  top.name = "top", top.point = {0.0, p.height}, top.normal = {0.0, -1.0};
  left.name = "left", left.normal = {1.0, 0.0};
  piston.name = "piston", piston.point = {p.length_x, 0.0}, piston.normal = {-1.0, 0.0};
  piston.mode_x = AxisMode::kFree;
  piston.mass = o.piston_mass;
  piston.applied_force = {-o.piston_stress * p.height, 0.0};
  for (Wall* w : {&bottom, &top, &left, &piston}) w->friction = 0.0;
  s.walls = {bottom, top, left, piston};
  s.overlap_tolerance = 1e-3;
  for (const PackingDisk& d : p.disks) {
    DiskSpec spec;
    spec.position = d.position;
    spec.radius = d.radius;
    s.disks.push_back(spec);
  }
  World world = build_world(s);
  ContactDynamics dynamics;
  StepOptions step = o.step;
  step.dt = o.compression_dt;
  const auto steps = static_cast<int>(std::lround(o.window_time / step.dt));
  double ek = 0.0, force = 0.0;
  for (int k = 0; k < steps; ++k) {
    ASSERT_FALSE(dynamics.step(world, step).blown_up);
    ek += kinetic_energy(world) / static_cast<double>(p.n());
    force += world.walls[3].contact_force.x;
  }
  const double applied = o.piston_stress * p.height;
  EXPECT_LT(ek / steps, o.kinetic_energy_per_disk);
  EXPECT_LT(std::abs(world.walls[3].point.x - p.length_x) / o.window_time, o.piston_speed);
  EXPECT_NEAR(force / steps, applied, o.force_balance * applied);
}

TEST(ShearWorld, StartsWithTheLinearProfileAndSeparateFrictions) {
  // model.md section 5, step 3: v_x = -V + 2V y / L_y, v_y = 0, w = 0; mu_p between grains and mu_w
  // with the walls, set apart here so that swapping them is caught.
  ShearCase c;
  c.velocity = 0.7;
  c.friction_grain = 0.6;
  c.friction_wall = 0.3;
  resolve_step_rules(c);
  const World w = build_shear_world(c, system1_packing());
  EXPECT_EQ(w.friction_disk_disk, 0.6);
  for (const Wall& wall : w.walls) EXPECT_EQ(wall.friction, 0.3);
  EXPECT_EQ(w.walls[kBottomWall].velocity.x, -0.7);
  EXPECT_EQ(w.walls[kTopWall].velocity.x, 0.7);
  EXPECT_EQ(w.walls[kTopWall].applied_force.y, -c.normal_stress * w.domain.length_x);
  for (std::size_t i = 0; i < w.disks.size(); ++i) {
    EXPECT_NEAR(w.disks.velocity[i].x, -0.7 + 1.4 * w.disks.position[i].y / c.height, 1e-12);
    EXPECT_EQ(w.disks.velocity[i].y, 0.0);
    EXPECT_EQ(w.disks.omega[i], 0.0);
  }
  // The documented time step at V = 0.5: min(0.005, 0.002 / 0.5) = 0.004.
  ShearCase d;
  resolve_step_rules(d);
  EXPECT_DOUBLE_EQ(d.step.dt, 0.004);
}

// A case at wall speed V with its step rules resolved, and its world on the system-1 packing.
struct System1Shear {
  ShearCase c;
  World world;
};
System1Shear system1_shear(double velocity, std::string initial_velocity = kInitialLinear) {
  ShearCase c;
  c.velocity = velocity;
  c.initial_velocity = std::move(initial_velocity);
  resolve_step_rules(c);
  World world = build_shear_world(c, system1_packing());
  return {std::move(c), std::move(world)};
}

// What a run never changes holds after steps of a run (the test a resume makes of its
// checkpoint), and each field changed is named.
TEST(ShearWorld, WhatARunNeverChangesHoldsAfterItsStepsAndEachChangeIsNamed) {
  auto [c, w] = system1_shear(0.5);
  ContactDynamics dynamics;
  for (int s = 0; s < 25; ++s) ASSERT_FALSE(dynamics.step(w, c.step).blown_up);
  ASSERT_EQ(shear_world_problem(w, c).key, "") << shear_world_problem(w, c).problem;
  const std::pair<std::function<void(World&)>, std::string> changes[] = {
      {[](World& x) { x.domain.periodic_x = false; }, "periodic_x"},
      {[](World& x) { x.body_force.y = -1.0; }, "body_force"},
      {[](World& x) { x.friction_disk_disk = 0.3; }, "friction_disk_disk"},
      {[](World& x) { x.walls.pop_back(); }, "walls"},
      {[](World& x) { x.walls[1].mass = 5.0; }, "walls[1].mass"},
      {[](World& x) { x.walls[0].friction = 0.9; }, "walls[0].friction"},
      {[](World& x) { x.walls[1].velocity.x = 0.25; }, "walls[1].velocity"},
      {[](World& x) { x.walls[0].applied_force.y *= 2; }, "walls[0].applied_force"},
      {[](World& x) { x.walls[0].mode_y = AxisMode::kFixed; }, "walls[0].mode_x"},
      {[](World& x) { x.disks.mass[7] *= 1.5; }, "disks[7]"},
      {[](World& x) { x.time += 1.0; }, "time"},
  };
  for (const auto& [change, key] : changes) {
    World changed = w;
    change(changed);
    EXPECT_EQ(shear_world_problem(changed, c).key, key);
  }
  ShearCase other = c;
  other.friction_wall = 0.1;  // the case, not the world, differs: the same key
  EXPECT_EQ(shear_world_problem(w, other).key, "walls[0].friction");
}

TEST(ShearWorld, StartsAtRestWhenAskedAndTheWallsDragTheLayersNextToThem) {
  // shear.initial_velocity = "rest": every disk at rest, the walls at -V and +V. Momentum enters
  // from the walls only, so after a few time units the disks in the lowest fifth move with the
  // bottom wall (against +x) and those in the highest fifth with the top wall (along +x): 0.16 V
  // both at 5 t on this packing, the walls slipping over them.
  auto [c, w] = system1_shear(0.5, kInitialRest);
  EXPECT_EQ(w.walls[kBottomWall].velocity.x, -0.5);
  EXPECT_EQ(w.walls[kTopWall].velocity.x, 0.5);
  for (std::size_t i = 0; i < w.disks.size(); ++i) {
    EXPECT_EQ(w.disks.velocity[i].x, 0.0);
    EXPECT_EQ(w.disks.velocity[i].y, 0.0);
  }
  ContactDynamics dynamics;
  const auto steps = static_cast<int>(std::lround(5.0 / c.step.dt));
  for (int s = 0; s < steps; ++s) ASSERT_FALSE(dynamics.step(w, c.step).blown_up);
  double low = 0.0, high = 0.0;
  int n_low = 0, n_high = 0;
  const double height = w.walls[kTopWall].point.y - w.walls[kBottomWall].point.y;
  for (std::size_t i = 0; i < w.disks.size(); ++i) {
    const double y = (w.disks.position[i].y - w.walls[kBottomWall].point.y) / height;
    if (y < 0.2) low += w.disks.velocity[i].x, ++n_low;
    if (y > 0.8) high += w.disks.velocity[i].x, ++n_high;
  }
  EXPECT_LT(low / n_low, -0.1 * c.velocity);
  EXPECT_GT(high / n_high, 0.1 * c.velocity);

  c.initial_velocity = "still";
  EXPECT_THROW(build_shear_world(c, system1_packing()), std::invalid_argument);
}

struct ShearWindow {
  double time = 0.0;
  Vec2 impulse_bottom, impulse_top;  // integral of the contact force on each wall
  double min_height = 1e9, max_height = 0.0;
  bool walls_exact = true;
};

TEST(ShearRun, WallsDrivenExactlyAndForcesBalanceOnAverage) {
  auto [c, world] = system1_shear(0.5);
  ContactDynamics dynamics;
  const double dt = c.step.dt;
  const double force_y = c.normal_stress * world.domain.length_x;

  // Transient: 5 time units; then measure over 15.
  const auto transient = static_cast<int>(std::lround(5.0 / dt));
  const auto window = static_cast<int>(std::lround(15.0 / dt));
  for (int s = 0; s < transient; ++s) ASSERT_FALSE(dynamics.step(world, c.step).blown_up);

  const Vec2 p0 = linear_momentum(world);
  const Vec2 j_bottom0 = world.walls[kBottomWall].contact_impulse;
  const Vec2 v_bottom0 = world.walls[kBottomWall].velocity, v_top0 = world.walls[kTopWall].velocity;
  const double x_bottom0 = world.walls[kBottomWall].point.x, x_top0 = world.walls[kTopWall].point.x;
  ShearWindow w;
  for (int s = 0; s < window; ++s) {
    const StepReport r = dynamics.step(world, c.step);
    ASSERT_FALSE(r.blown_up) << r.problem;
    const Wall& b = world.walls[kBottomWall];
    const Wall& t = world.walls[kTopWall];
    w.walls_exact = w.walls_exact && b.velocity.x == -c.velocity && t.velocity.x == c.velocity;
    w.impulse_bottom += dt * b.contact_force;
    w.impulse_top += dt * t.contact_force;
    const double h = t.point.y - b.point.y;
    w.min_height = std::min(w.min_height, h);
    w.max_height = std::max(w.max_height, h);
  }
  const double T = window * dt;
  const Wall& b = world.walls[kBottomWall];
  const Wall& t = world.walls[kTopWall];

  // The running contact impulse of a wall (written to the time series) is the time integral of
  // its per-step contact force.
  EXPECT_NEAR(b.contact_impulse.y - j_bottom0.y, w.impulse_bottom.y,
              1e-9 * std::abs(w.impulse_bottom.y));

  // Walls move at exactly -V and +V along x.
  EXPECT_TRUE(w.walls_exact);
  EXPECT_NEAR(b.point.x - x_bottom0, -c.velocity * T, 1e-9 * c.velocity * T);
  EXPECT_NEAR(t.point.x - x_top0, c.velocity * T, 1e-9 * c.velocity * T);

  // Newton's law of each free wall along y, exactly (bookkeeping of the contact forces):
  // M (v_end - v_start) = (F_applied + <F_contact>) T.
  EXPECT_NEAR(c.wall_mass * (b.velocity.y - v_bottom0.y), force_y * T + w.impulse_bottom.y,
              1e-8 * force_y * T);
  EXPECT_NEAR(c.wall_mass * (t.velocity.y - v_top0.y), -force_y * T + w.impulse_top.y,
              1e-8 * force_y * T);
  // Physically: averaged over time the grains push each wall with F_y. The residual is
  // M dv_y / T, bounded by the wall's velocity fluctuations (|v_y| < ~0.05 here) over 15 time
  // units: 50 * 0.1 / 15 = 0.33 at most, against F_y ~ 5: 10% covers it.
  EXPECT_NEAR(-w.impulse_bottom.y / T, force_y, 0.10 * force_y);
  EXPECT_NEAR(w.impulse_top.y / T, force_y, 0.10 * force_y);

  // Momentum balance along x: only the walls act on the grains along x, so the tangential
  // forces on the two walls are opposite up to the change of the grains' momentum, exactly...
  const Vec2 p1 = linear_momentum(world);
  EXPECT_NEAR(-(w.impulse_bottom.x + w.impulse_top.x), p1.x - p0.x,
              1e-8 * std::abs(w.impulse_top.x));
  // ...and opposite on average. At V = 0.5 (regime A) the centre of mass stays near rest, so the
  // grains' momentum change over the window is a small fraction of the traction impulse
  // (mu_eff F_y T ~ 15-35): we require the net impulse below half the shear impulse, and the
  // signs of the tractions.
  EXPECT_LT(w.impulse_top.x, 0.0);     // grains resist the top wall moving to +x
  EXPECT_GT(w.impulse_bottom.x, 0.0);  // and the bottom wall moving to -x
  EXPECT_LT(std::abs(w.impulse_bottom.x + w.impulse_top.x),
            0.5 * std::abs(w.impulse_top.x - w.impulse_bottom.x));

  // L_y stays bounded: within 10% of its initial 20 (dilatancy in shear is a few percent).
  EXPECT_GT(w.min_height, 0.9 * c.height);
  EXPECT_LT(w.max_height, 1.1 * c.height);
}

TEST(ShearRun, AWallGapIsABlowUpOnlyOutsideItsRangeOrNotANumber) {
  const double nominal = 20.0;
  for (const double ok :
       {nominal, 0.51 * nominal, 5.0 * nominal, 0.999 * kHeightRange[1] * nominal})
    EXPECT_EQ(wall_gap_problem(ok, nominal), "") << ok;
  const std::string apart = wall_gap_problem(1.001 * kHeightRange[1] * nominal, nominal);
  EXPECT_NE(apart.find("flew apart"), std::string::npos) << apart;
  EXPECT_NE(apart.find("L_y = 20020, outside 0.5 to 1000 times the nominal 20"), std::string::npos)
      << apart;
  EXPECT_NE(wall_gap_problem(0.49 * nominal, nominal), "");
  EXPECT_NE(wall_gap_problem(std::nan(""), nominal), "");
}

CaseSource with(std::vector<std::string> overrides) {
  CaseSource s;
  s.overrides = std::move(overrides);
  return s;
}

void expect_case_error(const CaseSource& src, const std::string& key, const std::string& words) {
  try {
    load_case(src);
    FAIL() << "no error for " << key;
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), key) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(ShearCaseErrors, BadValuesNameTheKey) {
  expect_case_error(with({"shear.velocity=-1"}), "shear.velocity", "must be > 0");
  expect_case_error(with({"system.n=0"}), "system.n", "must be between 1 and");
  expect_case_error(with({"system.height=0.5"}), "system.height", "largest grain diameter");
  expect_case_error(with({"shear.velocty=1"}), "shear.velocty", "unknown key");
  expect_case_error(with({"step.dt=fast"}), "step.dt", "\"auto\"");
  // Keys that are not case keys: none is taken for another (".=1" named no key, and a key with
  // a space or a quote would be a TOML quoted key).
  expect_case_error(with({".=1"}), "", "empty part");
  expect_case_error(with({"shear..velocity=1"}), "", "empty part");
  expect_case_error(with({"shear velocity=1"}), "", "not a case key");
  // Degenerate values: a speed that underflows, a boundary layer as thick as the cell.
  expect_case_error(with({"shear.velocity=1e-320"}), "shear.velocity", "less than one grain");
  expect_case_error(with({"measure.boundary_thickness=[5, 100]"}), "measure.boundary_thickness",
                    "at most half of L_y");
  // A run that would end before its first sample; loads whose sums would overflow.
  expect_case_error(with({"shear.duration=2", "measure.sample_interval=3"}),
                    "measure.sample_interval", "no sample");
  EXPECT_EQ(load_case(with({"shear.duration=2", "measure.window=2", "measure.sample_interval=2"}))
                .measure.sample_interval,
            2.0);
  expect_case_error(with({"shear.normal_stress=1e308"}), "shear.normal_stress", "<= 1e+100");
  expect_case_error(with({"shear.wall_mass=1e-300"}), "shear.wall_mass", ">= 1e-100");
  // Preparation limits counted in steps: a limit beyond the step count a run may take is blamed
  // on the time step when that was given, and a window longer than the limit is refused.
  expect_case_error(with({"preparation.max_time_per_phase=1e300"}),
                    "preparation.max_time_per_phase", "more than the limit");
  expect_case_error(with({"preparation.dt=1e-90"}), "preparation.dt", "more than the limit");
  expect_case_error(with({"preparation.compression_dt=1e-90"}), "preparation.compression_dt",
                    "more than the limit");
  // Shorter still, a step overflows the solver's sums.
  expect_case_error(with({"preparation.dt=1e-300"}), "preparation.dt", "must be >= 1e-100");
  expect_case_error(with({"step.dt_max=1e-300"}), "step.dt_max", "must be >= 1e-100");
  expect_case_error(with({"preparation.window_time=3000"}), "preparation.window_time",
                    "at most preparation.max_time_per_phase");
  EXPECT_EQ(load_case(with({"preparation.window_time=2000"})).preparation.window_time, 2000.0);
  EXPECT_EQ(load_case(with({"measure.boundary_thickness=[10]"})).measure.boundary_thickness,
            std::vector<double>{10.0});  // system 1: the layers meet in the middle
  // The slowest V of model.md section 6.
  EXPECT_EQ(load_case(with({"shear.velocity=0.005"})).velocity, 0.005);
  EXPECT_EQ(load_case(with({"shear.velocity = 0.25"})).velocity, 0.25);
  expect_case_error(with({"shear.\"velocity\"=1"}), "", "not a case key");
  CaseSource v;
  v.velocity = -2.0;
  expect_case_error(v, "shear.velocity", "must be > 0");
}

TEST(ShearCaseErrors, CaseFileErrorsNameTheFile) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "cdshear_bad_case.toml";
  std::ofstream(file) << "[system]\nn = 511\nheight = -20.0\n";
  CaseSource s;
  s.file = file.string();
  try {
    load_case(s);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), file.string());
    EXPECT_EQ(e.key(), "system.height");
  }
  s.file = "/nonexistent/case.toml";
  EXPECT_THROW(load_case(s), ConfigError);
}

TEST(ShearCaseErrors, MissingPackingFile) {
  try {
    read_packing("/nonexistent/packing.json");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "/nonexistent/packing.json");
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos);
  }
}

// A packing's metadata are checked against its disks and each other, each error by its key; an
// unedited copy reads back the preparation's numerics as written.
TEST(ShearCaseErrors, PackingMetadataAreCheckedByKey) {
  nlohmann::json original;
  std::ifstream(CDSHEAR_SYSTEM1_PACKING) >> original;
  testing::TempDir dir("packing_metadata");
  auto read_edited = [&](const std::string& key, const nlohmann::json& value) {
    nlohmann::json j = original;
    j[key] = value;
    const std::filesystem::path path = dir.path() / "edited.json";
    std::ofstream(path) << j.dump();
    return read_packing(path);
  };
  const Packing same = read_edited("n", original.at("n"));
  EXPECT_EQ(same.preparation_steps, original.at("preparation_steps").get<std::uint64_t>());
  EXPECT_EQ(same.capped_steps, original.at("capped_steps").get<std::uint64_t>());
  EXPECT_EQ(same.largest_overlap, original.at("largest_overlap").get<double>());
  EXPECT_GT(same.preparation_steps, 0u);
  const std::uint64_t steps = same.preparation_steps;
  const double fraction = original.at("solid_fraction").get<double>();
  const std::pair<std::string, nlohmann::json> bad[] = {
      {"solid_fraction", "x"},
      {"solid_fraction", fraction * 1.01},
      {"capped_steps", -5},
      {"capped_steps", steps + 1},
      {"displacement_warnings", 1.5},
      {"preparation_steps", "many"},
      {"largest_overlap", -1.0},
      {"program_version", 5},
      {"build", nullptr},
      {"height", -20.0},
      {"length_x", 0.0},
  };
  for (const auto& [key, value] : bad) {
    try {
      read_edited(key, value);
      ADD_FAILURE() << key << " = " << value.dump() << " was accepted";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), key) << value.dump() << ": " << e.what();
    }
  }
}

TEST(ShearCaseErrors, ADeeplyNestedPackingValueIsShownShortened) {
  // `n` as 100 000 nested arrays: the parser takes it, and the error shows it cut short instead of
  // printing it whole (which recursed once per level and overflowed the stack).
  std::string text = testing::read_text(CDSHEAR_SYSTEM1_PACKING);
  const std::size_t at = text.find("\"n\": ");
  ASSERT_NE(at, std::string::npos);
  const std::size_t value = at + 5, end = text.find_first_not_of("0123456789", value);
  text.replace(value, end - value, std::string(100000, '[') + std::string(100000, ']'));
  testing::TempDir dir("deep_packing");
  try {
    read_packing(dir.write("deep.json", text));
    ADD_FAILURE() << "a nested n was accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "n") << e.what();
    EXPECT_NE(std::string(e.what()).find("is [[[[[...]]]]], but disks_xyr lists"),
              std::string::npos)
        << e.what();
  }
}

TEST(ShearCase, DefaultTimeStepBoundsTheWallDisplacement) {
  for (const double v : {0.005, 0.05, 0.5, 5.0, 35.0}) {
    ShearCase c;
    c.velocity = v;
    EXPECT_TRUE(resolve_step_rules(c).empty()) << "V = " << v;
    EXPECT_LE(v * c.step.dt, c.displacement_per_step * (1 + 1e-12));
    EXPECT_LE(c.step.dt, c.dt_max);
  }
  ShearCase fast;
  fast.velocity = 30.0;
  fast.dt = 1e-3;  // moves the walls by 0.03 per step
  EXPECT_FALSE(resolve_step_rules(fast).empty());
}

// The preparation's solver keys (order, alpha, max_sweeps) change the packing, so they enter the
// cache name; a packing prepared in the random order (the default before the coloured
// one) keeps the name it had before the keys existed (older caches stay valid for that order).
TEST(ShearCase, PreparationSolverKeysEnterThePackingCacheName) {
  const ShearCase base = load_case(with({}));
  EXPECT_EQ(base.preparation.step.solver.order, ContactOrder::kColoured);
  const std::string name = packing_cache_name(base.preparation);
  EXPECT_EQ(packing_cache_name(load_case(with({"preparation.order=coloured"})).preparation), name);
  const ShearCase random = load_case(with({"preparation.order=random"}));
  EXPECT_EQ(random.preparation.step.solver.order, ContactOrder::kRandom);
  const ShearCase tighter = load_case(with({"preparation.alpha=1e-5"}));
  EXPECT_EQ(tighter.preparation.step.solver.alpha, 1e-5);
  const std::string a = packing_cache_name(random.preparation);
  const std::string b = packing_cache_name(tighter.preparation);
  EXPECT_NE(a, name);
  EXPECT_NE(b, name);
  EXPECT_NE(a, b);
  // Fixed, not keys: every contact swept, plain Gauss-Seidel, no slab correction.
  EXPECT_FALSE(base.preparation.step.solver.skip_dormant);
  EXPECT_EQ(base.preparation.step.solver.relaxation, 1.0);
  EXPECT_EQ(base.preparation.step.solver.slab_correction_period, 0);
  expect_case_error(with({"preparation.slab_correction_period=8"}),
                    "preparation.slab_correction_period", "no longer a setting");
  // The random order's name is the one of the packing committed before the change.
  EXPECT_EQ(a, "n511_h20_d0.8-1_seed1_s0.25_ecd48f39.json");
  expect_case_error(with({"preparation.order=diagonal"}), "preparation.order", "coloured");
}

TEST(ShearCase, PresetsFollowTheReferenceTable) {
  ShearCase c;
  apply_system_preset(c, 7);
  EXPECT_EQ(c.n, 5119u);
  EXPECT_EQ(c.height, 200.0);
  EXPECT_EQ(c.preparation.n, 5119u);
  apply_system_preset(c, 3);
  EXPECT_EQ(c.normal_stress, 0.0625);
  EXPECT_THROW(apply_system_preset(c, 8), std::invalid_argument);
}

}  // namespace
}  // namespace cdshear

namespace cdshear {
namespace {

TEST(ShearCase, ExampleFileSpellsOutTheBuiltInDefault) {
  // examples/shear_system1.toml documents every key with its default: reading it must give
  // exactly the built-in case (catches a key renamed in the code but not in the example).
  CaseSource example;
  example.file = CDSHEAR_SOURCE_DIR "/examples/shear_system1.toml";
  std::ostringstream from_file, built_in;
  from_file << case_to_toml(load_case(example));
  built_in << case_to_toml(load_case(CaseSource{}));
  EXPECT_EQ(from_file.str(), built_in.str());
}

}  // namespace
}  // namespace cdshear
