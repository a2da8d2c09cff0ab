// A column of equal disks stacked vertically, touching, on a fixed wall under gravity: the
// statics of a chain. The floor carries the whole weight, the contact below disk k carries the
// weight of disks k..N-1, and nothing moves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include "shear_case.hpp"
#include "test_support.hpp"

namespace cdshear {
namespace {

using testing::disk;
using testing::fixed_wall;

constexpr double kR = 0.5, kG = 1.0, kDt = 1e-3;

struct ColumnRun {
  // Over the last `checked_steps` steps:
  double wall_force_error = 0.0;     // worst |F_wall,y + N m g| / (N m g), instantaneous
  double contact_force_error = 0.0;  // worst relative error of a disk-disk contact force
  double mean_wall_error = 0.0;      // same, for the time averages over those steps
  double mean_contact_error = 0.0;
  double largest_friction = 0.0;  // largest |R_t| / R_n
  // Over the whole run:
  double drift = 0.0;  // largest |position - initial position|
  double largest_overlap = 0.0;
  int capped = 0;
};

/// n disks of radius kR stacked on a floor under gravity, touching.
SceneDefinition column_scene(int n) {
  return testing::disk_column(n, kR, kG);
}

ColumnRun run_column(int n, const SolverOptions& solver, int steps, int checked_steps) {
  const SceneDefinition s = column_scene(n);
  StepOptions o;
  o.dt = kDt;
  o.solver = solver;
  testing::Simulation sim(s, o);
  const double m = testing::disk_mass(kR), weight = n * m * kG;
  ColumnRun out;
  double wall_sum = 0.0;
  std::vector<double> contact_sum(n - 1, 0.0);
  sim.run(steps, [&](const testing::Simulation& sm, const StepReport& r) {
    for (int k = 0; k < n; ++k) {
      const Vec2 d = sm.world.disks.position[k] - Vec2{0.0, kR + 2.0 * kR * k};
      out.drift = std::max(out.drift, length(d));
    }
    out.largest_overlap = std::max(out.largest_overlap, r.max_overlap);
    out.capped += r.solver.hit_cap;
    if (sm.world.step + checked_steps <= static_cast<std::uint64_t>(steps)) return;
    // Force the disks exert on the floor: the total weight, downwards.
    const Vec2 f = sm.world.walls[0].contact_force;
    out.wall_force_error = std::max(out.wall_force_error, std::abs(f.y + weight) / weight);
    out.largest_friction = std::max(out.largest_friction, std::abs(f.x) / weight);
    wall_sum += f.y;
    // Contact between disk k and disk k+1 (a = k below, normal from k+1 to k, i.e. downwards):
    // it carries the weight of disks k+1..n-1.
    for (int k = 0; k + 1 < n; ++k) {
      const auto c = sm.contact(k, k + 1);
      ASSERT_TRUE(c.has_value()) << "contact " << k;
      const double expected = (n - 1 - k) * m * kG;
      const double force = c->impulse_n / kDt;
      out.contact_force_error =
          std::max(out.contact_force_error, std::abs(force - expected) / expected);
      out.largest_friction = std::max(out.largest_friction, std::abs(c->impulse_t) / c->impulse_n);
      contact_sum[k] += force;
    }
  });
  out.mean_wall_error = std::abs(wall_sum / checked_steps + weight) / weight;
  for (int k = 0; k + 1 < n; ++k) {
    const double expected = (n - 1 - k) * m * kG;
    out.mean_contact_error = std::max(
        out.mean_contact_error, std::abs(contact_sum[k] / checked_steps - expected) / expected);
  }
  std::printf(
      "column of %d: instantaneous force error wall %.2g contacts %.2g; mean wall %.2g "
      "contacts %.2g; drift %.2g; overlap %.2g; capped steps %d\n",
      n, out.wall_force_error, out.contact_force_error, out.mean_wall_error, out.mean_contact_error,
      out.drift, out.largest_overlap, out.capped);
  return out;
}

/// A column of 10 stepped with the solver driven to round-off (alpha 1e-24, every contact, cap
/// 5000) and the given relaxation and Anderson mixing (depth, every `anderson_period` sweeps;
/// depth 0: none): the forces must be the exact statics at every step within `tolerance`, and
/// nothing may move, overlap, mobilise friction or hit the cap.
void expect_exact_statics(double relaxation, double tolerance, int anderson_depth = 0,
                          int anderson_period = 1) {
  SolverOptions tight;
  tight.anderson_depth = anderson_depth;
  tight.anderson_period = anderson_period;
  tight.alpha = 1e-24;
  tight.converged_fraction = 1.0;
  tight.max_sweeps = 5000;
  tight.relaxation = relaxation;
  const ColumnRun r = run_column(10, tight, 1000, 500);
  EXPECT_LT(r.wall_force_error, tolerance);
  EXPECT_LT(r.contact_force_error, tolerance);
  EXPECT_LT(r.largest_friction, 1e-12);  // an aligned column mobilises no friction
  EXPECT_LT(r.drift, 1e-12);             // and does not move at all
  EXPECT_LT(r.largest_overlap, 1e-12);
  EXPECT_EQ(r.capped, 0);
}

TEST(Column, ForcesCarryTheWeightAboveWithTightSolver) {
  // Tolerance 1e-12: round-off of sums of ten O(1) weights, with a wide margin.
  expect_exact_statics(1.0, 1e-12);
}

TEST(Column, ForcesCarryTheWeightAboveWithDefaultSolver) {
  // Default settings (alpha = 1e-6 on the squared relative change per sweep, 90% of contacts,
  // random order). The sweep stops when forces change by ~sqrt(alpha) = 1e-3 per sweep, but on a
  // chain of N contacts Gauss-Seidel contracts the error only by ~1 - pi^2 / N^2 per sweep, so
  // a single step's forces may be off by several percent (measured: up to ~6% at the floor, ~8%
  // in the chain). The error does not accumulate: the next step sees the resulting velocity and
  // gap and corrects it. Hence two checks:
  //  - time averages over 1000 steps are exact up to the momentum change of the column over the
  //    window divided by the weight times the window (a balance of impulses): measured ~5e-6,
  //    required 1e-4;
  //  - instantaneous forces within 15%, a bound on the stopping criterion above, not physics.
  const int n = 10;
  const ColumnRun r = run_column(n, SolverOptions{}, 2000, 1000);
  EXPECT_LT(r.mean_wall_error, 1e-4);
  EXPECT_LT(r.mean_contact_error, 1e-4);
  EXPECT_LT(r.wall_force_error, 0.15);
  EXPECT_LT(r.contact_force_error, 0.15);
  EXPECT_LT(r.largest_friction, 1e-12);
  // Nothing drifts: the inelastic Signorini condition removes any gap error in the next step, so
  // centres wobble by dt^2 times force errors over masses, ~1e-7; required 1e-6 of a diameter.
  EXPECT_LT(r.drift, 1e-6);
  EXPECT_LT(r.largest_overlap, 1e-6);
  EXPECT_EQ(r.capped, 0);
}

/// Largest relative error, summed over the contacts (sum |R - R_exact| / sum |R_exact|), of a
/// step solved with `solver` against the same step (same state and warm start) solved to
/// round-off, over `samples` steps of a column of n disks stepped with `solver`.
double step_error_against_round_off(int n, const SolverOptions& solver, int samples) {
  const SceneDefinition s = column_scene(n);
  StepOptions o;
  o.dt = kDt;
  o.solver = solver;
  StepOptions tight = o;
  tight.solver.alpha = 1e-24;
  tight.solver.converged_fraction = 1.0;
  tight.solver.max_sweeps = 100000;
  testing::Simulation sim(s, o);
  double worst = 0.0;
  for (int k = 0; k < samples; ++k) {
    sim.run(37);  // an odd spacing, so that samples fall on steps of every kind
    World w_a = sim.world, w_b = sim.world;
    ContactDynamics d_a = sim.dynamics, d_b = sim.dynamics;
    d_a.step(w_a, o);
    d_b.step(w_b, tight);
    double error = 0.0, total = 0.0;
    for (std::size_t c = 0; c < d_b.contacts().size(); ++c) {
      const Contact& a = d_a.contacts()[c];
      const Contact& b = d_b.contacts()[c];
      error += std::hypot(a.impulse_n - b.impulse_n, a.impulse_t - b.impulse_t);
      total += std::hypot(b.impulse_n, b.impulse_t);
    }
    worst = std::max(worst, error / total);
  }
  return worst;
}

TEST(Column, OverRelaxedSolverReachesTheSameStatics) {
  // Projected over-relaxation (solver.relaxation = 1.6) driven to round-off: the same exact
  // statics as Gauss-Seidel (the fixed point of a relaxed update is the local solution).
  // Round-off: 3e-12 measured (the relaxed sums cancel a little more); required 1e-11.
  expect_exact_statics(1.6, 1e-11);
}

TEST(Column, OverRelaxationShrinksTheErrorAtEqualSweeps) {
  // Every step a fixed number of sweeps (alpha = 0), the error left against round-off, on a
  // chain of 20 where Gauss-Seidel contracts the error by only about 1 - pi^2 / N^2 per sweep.
  // Measured: Gauss-Seidel 2.7e-4 after 200 sweeps; relaxation 1.6: 2.4e-4 after 50 sweeps and
  // 4e-15 (round-off) after 200. Required: 1.6 with 50 sweeps within twice Gauss-Seidel's error
  // with 200, and 1.6 with 200 sweeps a thousand times below it. (With too few sweeps, 20,
  // both leave the chain bouncing and the comparison means nothing.)
  SolverOptions plain;
  plain.alpha = 0.0;
  plain.max_sweeps = 200;
  SolverOptions relaxed = plain;
  relaxed.relaxation = 1.6;
  SolverOptions relaxed_50 = relaxed;
  relaxed_50.max_sweeps = 50;
  const double e_plain = step_error_against_round_off(20, plain, 10);
  const double e_relaxed = step_error_against_round_off(20, relaxed, 10);
  const double e_relaxed_50 = step_error_against_round_off(20, relaxed_50, 10);
  std::printf(
      "error on a chain of 20: relaxation 1, 200 sweeps %.2g; 1.6, 200 sweeps %.2g; "
      "1.6, 50 sweeps %.2g\n",
      e_plain, e_relaxed, e_relaxed_50);
  EXPECT_LT(e_relaxed_50, 2.0 * e_plain);
  EXPECT_LT(1000.0 * e_relaxed, e_plain);
}

TEST(Column, AndersonAcceleratedSolverReachesTheSameStatics) {
  // Anderson mixing of the impulses (depth 5, every second sweep) on top of over-relaxation,
  // driven to round-off: the mix is projected on the Signorini-Coulomb set and its fixed points
  // are those of the sweeps, so the statics are exact as before.
  expect_exact_statics(1.6, 1e-11, 5, 2);
}

TEST(Column, AndersonAccelerationShrinksTheErrorAtEqualSweeps) {
  // Same measure as above (chain of 20, fixed sweeps, error against round-off). Measured:
  // over-relaxation alone 2.4e-4 after 50 sweeps; with Anderson mixing (depth 5, every second
  // sweep) 4e-15, round-off. Required: a hundred times below over-relaxation alone at the same
  // 50 sweeps.
  SolverOptions relaxed;
  relaxed.alpha = 0.0;
  relaxed.max_sweeps = 50;
  relaxed.relaxation = 1.6;
  SolverOptions mixed = relaxed;
  mixed.anderson_depth = 5;
  mixed.anderson_period = 2;
  const double e_relaxed = step_error_against_round_off(20, relaxed, 10);
  const double e_mixed = step_error_against_round_off(20, mixed, 10);
  std::printf("error on a chain of 20 after 50 sweeps: relaxation 1.6 %.2g; with Anderson %.2g\n",
              e_relaxed, e_mixed);
  EXPECT_LT(100.0 * e_mixed, e_relaxed);
}

TEST(Column, ColouredOrderOnTwoThreadsGivesTheSameStatics) {
  // The coloured order cuts the column into bands (slabs of four diameters): contacts inside
  // each slab, then across slab boundaries, then the floor contact, slabs on two threads.
  SolverOptions coloured;
  coloured.order = ContactOrder::kColoured;
  coloured.threads = 2;
  coloured.min_rows_per_thread = 1;  // share even these 10 contacts
  const ColumnRun r = run_column(10, coloured, 2000, 1000);
  EXPECT_LT(r.mean_wall_error, 1e-4);
  EXPECT_LT(r.mean_contact_error, 1e-4);
  EXPECT_LT(r.contact_force_error, 0.15);
  EXPECT_LT(r.drift, 1e-6);
  EXPECT_LT(r.largest_overlap, 1e-6);
}

/// The relative change of the last sweep of a step, (sum |dR| / sum |R|)^2 over the contacts,
/// from the same step stopped one sweep earlier (`before`) and at `sweeps` (`after`): what
/// SolverReport::residual must say. The solver adds the square roots of the rows' squared
/// lengths only in the sweeps whose decision needs them (nlgs_solver.cpp, sum_group_lengths).
double last_sweep_change(const std::vector<Contact>& before, const std::vector<Contact>& after) {
  double change = 0.0, force = 0.0;
  for (std::size_t k = 0; k < after.size(); ++k) {
    change += std::hypot(after[k].impulse_n - before[k].impulse_n,
                         after[k].impulse_t - before[k].impulse_t);
    force += std::hypot(after[k].impulse_n, after[k].impulse_t);
  }
  return (change / force) * (change / force);
}

/// Solves the first step of a column of 10 (from no impulse: many sweeps) with a cap of `sweeps`
/// and of `sweeps - 1`, and returns (the report at `sweeps`, the change of its last
/// sweep measured from the two).
std::pair<SolverReport, double> report_and_last_change(const SolverOptions& solver, int sweeps) {
  StepOptions o;
  o.dt = kDt;
  o.solver = solver;
  testing::Simulation before(column_scene(10), o), after(column_scene(10), o);
  before.options.solver.max_sweeps = sweeps - 1;
  after.options.solver.max_sweeps = sweeps;
  before.run(1);
  after.run(1);
  EXPECT_EQ(before.last().solver.sweeps, sweeps - 1);
  return {after.last().solver,
          last_sweep_change(before.dynamics.contacts(), after.dynamics.contacts())};
}

TEST(ConvergenceCriterion, ReportsTheLastSweepsChange) {
  // Plain Gauss-Seidel (no mix, every contact swept), so that the state before a sweep is the
  // step stopped one sweep earlier. Random order on one thread, and coloured on two.
  for (const bool coloured : {false, true}) {
    SolverOptions solver;
    solver.skip_dormant = false;
    if (coloured) {
      solver.order = ContactOrder::kColoured;
      solver.threads = 2;
      solver.min_rows_per_thread = 1;
    }
    // Stopped by the cap after 4 sweeps, short of the criterion: the sums are taken in the last
    // sweep allowed.
    const auto [capped, capped_change] = report_and_last_change(solver, 4);
    EXPECT_TRUE(capped.hit_cap);
    EXPECT_GT(capped_change, solver.alpha);
    EXPECT_NEAR(capped.residual, capped_change, 1e-12 * capped_change);
    // Stopped by the criterion: the sums are taken once 90% of the contacts meet it.
    StepOptions o;
    o.dt = kDt;
    o.solver = solver;
    testing::Simulation probe(column_scene(10), o);
    probe.run(1);
    const int sweeps = probe.last().solver.sweeps;
    ASSERT_FALSE(probe.last().solver.hit_cap);
    ASSERT_GT(sweeps, 2);
    const auto [stopped, stopped_change] = report_and_last_change(solver, sweeps);
    EXPECT_FALSE(stopped.hit_cap);
    EXPECT_GT(stopped_change, 0.0);
    EXPECT_LE(stopped_change, solver.alpha);
    EXPECT_NEAR(stopped.residual, stopped_change, 1e-12 * stopped_change);
  }
}

TEST(ConvergenceCriterion, CountsOnlyForceCarryingContacts) {
  // A row of 20 disks resting on the floor, 0.02 apart: 20 floor contacts carry the weight and
  // 19 side-by-side candidates stay idle (R = 0). After one sweep (cap 1) every floor contact
  // went from 0 to m g dt: none meets the tolerance. The documented share counts only contacts
  // that carry force, so it is 0; counting the idle ones would report 19 / 39 converged.
  SceneDefinition s;
  s.gravity = {0.0, -kG};
  s.walls.push_back(fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0}));
  for (int k = 0; k < 20; ++k) s.disks.push_back(disk({1.02 * k, kR}, kR));
  StepOptions o;
  o.dt = kDt;
  o.solver.max_sweeps = 1;
  testing::Simulation sim(s, o);
  sim.run(1);
  EXPECT_EQ(sim.last().contacts, 39u);
  EXPECT_TRUE(sim.last().solver.hit_cap);
  EXPECT_EQ(sim.last().solver.converged_fraction, 0.0);
  // With the cap lifted, the step converges (each floor contact is exact after one sweep).
  o.solver.max_sweeps = 200;
  testing::Simulation again(s, o);
  again.run(1);
  EXPECT_FALSE(again.last().solver.hit_cap);
  EXPECT_EQ(again.last().solver.converged_fraction, 1.0);
}

TEST(VelocityResidual, VanishesAtTheSolutionOfAStepAndNotBefore) {
  // A column of 10 disks on the floor, one step from rest: solved to round-off, every contact is
  // closed and carries force and every end-of-step velocity is 0; after one sweep, disks whose
  // support the shuffled order has not yet carried down still fall at up to g dt.
  StepOptions o;
  o.dt = kDt;
  o.solver.alpha = 1e-24;
  o.solver.converged_fraction = 1.0;
  o.solver.max_sweeps = 100000;
  testing::Simulation exact(column_scene(10), o);
  exact.run(1);
  const VelocityResidual solved = exact.last().velocity_residual;
  EXPECT_EQ(solved.carrying, 10u);
  EXPECT_LT(solved.largest, 1e-9 * kG * kDt);
  o.solver.max_sweeps = 1;
  testing::Simulation rough(column_scene(10), o);
  rough.run(1);
  const VelocityResidual one_sweep = rough.last().velocity_residual;
  std::printf("velocity residual of a column's step: %.3g solved, %.3g (rms %.3g) after a sweep\n",
              solved.largest, one_sweep.largest, one_sweep.rms_carrying);
  EXPECT_GT(one_sweep.largest, 0.1 * kG * kDt);
  EXPECT_GT(one_sweep.rms_carrying, 0.0);
  EXPECT_LE(one_sweep.rms_carrying, one_sweep.largest);
}

TEST(VelocityResidual, ReadsEachContactLaw) {
  // One contact between a disk (body 0) and a fixed body (body 1) along the normal y, impulse
  // R_n > 0, the disk moving at (vx, vy): u_n = vy (plus gap/dt = 0) and u_t = -vx.
  const auto residual = [](double friction, double r_t, Vec2 velocity) {
    std::vector<SolverBody> bodies(2);
    bodies[0].velocity = velocity;
    Contact c;
    c.key.body_a = 0;
    c.key.body_b = 1;
    c.normal = {0.0, 1.0};
    c.friction = friction;
    c.impulse_n = 1.0;
    c.impulse_t = r_t;
    return velocity_residual({c}, bodies, 1e-3).largest;
  };
  EXPECT_EQ(residual(0.5, 0.0, {0.0, 0.0}), 0.0);         // closed, at rest: the laws hold
  EXPECT_DOUBLE_EQ(residual(0.5, 0.0, {0.0, 0.3}), 0.3);  // closed but opening
  EXPECT_DOUBLE_EQ(residual(0.5, 0.2, {0.4, 0.0}), 0.4);  // sticking (|R_t| < mu R_n) but sliding
  EXPECT_EQ(residual(0.5, 0.5, {0.4, 0.0}), 0.0);  // sliding against its friction (u_t R_t < 0)
  EXPECT_DOUBLE_EQ(residual(0.5, -0.5, {0.4, 0.0}), 0.4);  // sliding with its friction
  EXPECT_EQ(residual(0.0, 0.0, {0.4, 0.0}), 0.0);          // frictionless: free to slide
}

TEST(VelocityResidual, ToleranceHoldsTheSweepsUntilEachStepMeetsIt) {
  // A dense periodic box sheared by its top wall with the shear phase's solver: first without
  // the residual test, whose steps' contact-law violations over a step (e dt, the check's root
  // mean square) set the tolerance at their median; then with it, where every step that ends
  // before the cap meets it, the sweeps having gone on where it did not hold yet.
  const testing::ShearedBox box = testing::sheared_dense_box(300, 10.0, 0.1);
  ASSERT_TRUE(box.dense);
  struct Steps {
    std::vector<double> violation;  // e dt [d] of each step not at the cap
    int sweeps = 0, refusals = 0;
  };
  const auto shear = [&](double tolerance) {
    World world = box.world;
    ContactDynamics dynamics = box.dynamics;
    StepOptions o = shear_step_defaults();
    o.dt = 5e-3;
    o.solver.residual_tolerance = tolerance;
    Steps steps;
    for (int k = 0; k < 150; ++k) {
      const StepReport r = dynamics.step(world, o);
      EXPECT_FALSE(r.blown_up);
      steps.sweeps += r.solver.sweeps;
      steps.refusals += r.solver.residual_refusals;
      if (!r.solver.hit_cap) steps.violation.push_back(r.velocity_residual.rms_carrying * o.dt);
    }
    return steps;
  };
  const Steps free_steps = shear(0.0);
  EXPECT_EQ(free_steps.refusals, 0);
  std::vector<double> sorted = free_steps.violation;
  std::sort(sorted.begin(), sorted.end());
  const double tolerance = sorted[sorted.size() / 2];
  ASSERT_GT(tolerance, 0.0);
  const Steps held = shear(tolerance);
  std::printf("residual tolerance %.3g d: %d refusals, %d sweeps against %d\n", tolerance,
              held.refusals, held.sweeps, free_steps.sweeps);
  EXPECT_GT(held.refusals, 0);  // (the runs part ways at the first: no sweep totals compared)
  // The check adds the same squares over the contacts, the test over the rows group by group:
  // the same sum but for rounding.
  for (const double v : held.violation) EXPECT_LE(v, tolerance * (1.0 + 1e-9));
}

}  // namespace
}  // namespace cdshear
