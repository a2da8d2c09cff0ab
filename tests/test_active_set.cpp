// The active-set Newton refinement (active_set_solve.hpp): a column's statics exactly after one
// sweep, a sheared dense packing's step solved to round-off (the solution that Gauss-Seidel
// reaches after thousands of sweeps) with one factorisation and GMRES on it for the later
// iterations, a residual that never grows, and the same result twice; the sweeps' result kept
// where the refined one breaks the step's contact-law bound; the tally of a run's refinement.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "active_set_solve.hpp"
#include "scene_presets.hpp"
#include "test_support.hpp"

namespace cdshear {
namespace {

constexpr double kR = 0.5, kG = 1.0, kDt = 1e-3;

TEST(ActiveSet, ColumnCarriesItsWeightAfterOneSweep) {
  // n disks stacked on a floor under gravity, touching, at rest: the contact below disk k
  // carries the weight of disks k..n-1 over the step, m g dt (n - k). One sweep of Gauss-Seidel
  // carries a disk's weight down only as far as the shuffled order happens to visit the contacts
  // below it in turn.
  constexpr int n = 12;
  const SceneDefinition s = testing::disk_column(n, kR, kG);
  StepOptions o;
  o.dt = kDt;
  o.solver.max_sweeps = 1;
  o.solver.newton_iterations = 4;
  testing::Simulation sim(s, o);
  sim.run(1);
  const double m = testing::disk_mass(kR);
  const double floor_impulse = -sim.world.walls[0].contact_force.y * kDt;
  EXPECT_NEAR(floor_impulse, n * m * kG * kDt, 1e-12 * n * m * kG * kDt);
  for (int k = 1; k < n; ++k) {
    const auto c = sim.contact(k - 1, k);
    ASSERT_TRUE(c.has_value()) << "no contact between disks " << k << " and " << k - 1;
    EXPECT_NEAR(c->impulse_n, (n - k) * m * kG * kDt, 1e-12 * n * m * kG * kDt) << "disk " << k;
    EXPECT_EQ(c->impulse_t, 0.0);
  }
  EXPECT_LT(sim.last().active_set.residual, 1e-12);
  for (int k = 0; k < n; ++k) EXPECT_NEAR(sim.world.disks.velocity[k].y, 0.0, 1e-12);
  // Without the refinement the same sweep is far off.
  o.solver.newton_iterations = 0;
  testing::Simulation plain(s, o);
  plain.run(1);
  EXPECT_GT(std::abs(-plain.world.walls[0].contact_force.y * kDt - n * m * kG * kDt),
            0.5 * n * m * kG * kDt);
}

/// A dense box periodic in x, its walls driven at -V and +V along x and free along y under
/// their pressure, as the shear cell: `steps` steps with the shear phase's sweeps.
struct ShearedBox {
  World world;
  ContactDynamics dynamics;
  StepOptions options;

  ShearedBox(double velocity, int steps) {
    CompressedBoxParams p;
    p.count = 300;
    p.width = 12.0;
    p.periodic_x = true;
    DenseBox box = make_dense_box(p);
    EXPECT_TRUE(box.report.dense);
    world = box.world;
    dynamics = box.dynamics;
    Wall& bottom = world.walls[kBoxBottomWall];
    Wall& top = world.walls[kBoxTopWall];
    bottom.mode_x = top.mode_x = AxisMode::kImposed;
    bottom.velocity.x = -velocity;
    top.velocity.x = velocity;
    bottom.mode_y = AxisMode::kFree;
    bottom.mass = top.mass;
    bottom.applied_force = {0.0, -top.applied_force.y};
    options.dt = std::min(5e-3, 2e-3 / velocity);  // the shear default rule
    options.solver.order = ContactOrder::kColoured;
    options.solver.relaxation = 1.6;
    options.solver.anderson_depth = 5;
    options.solver.anderson_period = 4;
    options.solver.alpha = 1e-5;
    for (int k = 0; k < steps; ++k) EXPECT_FALSE(dynamics.step(world, options).blown_up);
  }

  /// The impulses of one more step with `solver`, from the same state.
  std::vector<double> impulses(const SolverOptions& solver, StepReport* report = nullptr) const {
    World w = world;
    ContactDynamics d = dynamics;
    StepOptions o = options;
    o.solver = solver;
    const StepReport r = d.step(w, o);
    if (report != nullptr) *report = r;
    std::vector<double> out;
    for (const Contact& c : d.contacts()) {
      out.push_back(c.impulse_n);
      out.push_back(c.impulse_t);
    }
    for (std::size_t i = 0; i < w.disks.size(); ++i) {
      out.push_back(w.disks.velocity[i].x);
      out.push_back(w.disks.velocity[i].y);
      out.push_back(w.disks.omega[i] * 0.5);
    }
    return out;
  }
};

double relative_difference(const std::vector<double>& a, const std::vector<double>& b,
                           std::size_t first = 0, std::size_t last = 0) {
  double d2 = 0.0, b2 = 0.0;
  for (std::size_t i = first; i < (last ? last : a.size()); ++i) {
    d2 += (a[i] - b[i]) * (a[i] - b[i]);
    b2 += b[i] * b[i];
  }
  return std::sqrt(d2 / b2);
}

TEST(ActiveSet, SolvesASlowShearStepToRoundOff) {
  const ShearedBox box(0.05, 150);
  // Reference: Gauss-Seidel run until no force changes any more.
  SolverOptions exact;
  exact.alpha = 1e-24;
  exact.converged_fraction = 1.0;
  exact.max_sweeps = 400000;
  StepReport reference_report;
  const std::vector<double> reference = box.impulses(exact, &reference_report);
  ASSERT_FALSE(reference_report.solver.hit_cap);
  StepReport plain_report, refined_report;
  const std::vector<double> plain = box.impulses(box.options.solver, &plain_report);
  SolverOptions refined = box.options.solver;
  refined.newton_iterations = 12;
  const std::vector<double> newton = box.impulses(refined, &refined_report);
  ASSERT_EQ(newton.size(), reference.size());
  const std::size_t nv = 3 * box.world.disks.size(), ni = reference.size() - nv;
  const double plain_error = relative_difference(plain, reference, 0, ni);
  const double newton_error = relative_difference(newton, reference, 0, ni);
  EXPECT_LT(refined_report.active_set.residual, 1e-12)
      << refined_report.active_set.iterations << " iterations";
  // The later iterations reuse the first one's factorisation (GMRES): the comparison with the
  // reference covers them.
  EXPECT_EQ(refined_report.active_set.factorisations, 1);
  EXPECT_GE(refined_report.active_set.krylov_solves, 1);
  EXPECT_LT(newton_error, 1e-7) << "the sweeps alone: " << plain_error;
  EXPECT_GT(plain_error, 1e3 * newton_error);
  // The velocities, which the step's physics is, agree as closely.
  EXPECT_LT(relative_difference(newton, reference, ni, ni + nv), 1e-7);
}

TEST(ActiveSet, SolvesACompliantShearStepToRoundOff) {
  // The same with a normal compliance: the refinement must reach the compliant step's solution
  // (Gauss-Seidel run to its end on the compliant law), not the rigid one, which is far from it.
  ShearedBox box(0.05, 150);
  constexpr double kKappa = 0.01;
  box.options.solver.normal_compliance = kKappa;
  SolverOptions exact;
  exact.alpha = 1e-24;
  exact.converged_fraction = 1.0;
  exact.max_sweeps = 400000;
  exact.normal_compliance = kKappa;
  StepReport reference_report;
  const std::vector<double> reference = box.impulses(exact, &reference_report);
  ASSERT_FALSE(reference_report.solver.hit_cap);
  SolverOptions refined = box.options.solver;
  refined.newton_iterations = 12;
  StepReport refined_report;
  const std::vector<double> newton = box.impulses(refined, &refined_report);
  SolverOptions rigid = refined;
  rigid.normal_compliance = 0.0;
  const std::vector<double> rigid_newton = box.impulses(rigid);
  ASSERT_EQ(newton.size(), reference.size());
  const std::size_t nv = 3 * box.world.disks.size(), ni = reference.size() - nv;
  EXPECT_LT(refined_report.active_set.residual, 1e-12)
      << refined_report.active_set.iterations << " iterations";
  EXPECT_LT(refined_report.velocity_residual.largest, 1e-12);
  const double newton_error = relative_difference(newton, reference, 0, ni);
  EXPECT_LT(newton_error, 1e-7);
  EXPECT_LT(relative_difference(newton, reference, ni, ni + nv), 1e-7);
  EXPECT_GT(relative_difference(rigid_newton, reference, 0, ni), 1e3 * newton_error);
}

TEST(ActiveSet, SolvesMostStepsOfAShearAndRepeatsOnAnyNumberOfThreads) {
  // The sweeps run on one thread in one copy and on two in the other (the coloured order's
  // result does not depend on it); the refinement then starts from the same impulses and must
  // end on the same ones.
  ShearedBox box(0.5, 30);
  box.options.solver.newton_iterations = 4;
  ShearedBox twin = box;
  twin.options.solver.threads = 2;
  twin.options.solver.min_rows_per_thread = 1;
  int solved = 0;
  for (int k = 0; k < 40; ++k) {
    const StepReport r = box.dynamics.step(box.world, box.options);
    const StepReport t = twin.dynamics.step(twin.world, twin.options);
    ASSERT_FALSE(r.blown_up);
    EXPECT_LE(r.active_set.residual, r.active_set.initial_residual);
    EXPECT_GE(r.active_set.iterations, 1);
    EXPECT_EQ(r.active_set.residual, t.active_set.residual);
    EXPECT_EQ(t.solver.threads, std::min(2, processors_available()));  // two where there are two
    solved += r.active_set.residual < 1e-12;  // the refinement's tolerance: round-off
    EXPECT_EQ(r.active_set.krylov_solves, t.active_set.krylov_solves);
  }
  EXPECT_GE(solved, 30) << "steps solved to round-off, of 40";
  for (std::size_t i = 0; i < box.world.disks.size(); ++i) {
    EXPECT_EQ(box.world.disks.position[i].x, twin.world.disks.position[i].x);
    EXPECT_EQ(box.world.disks.position[i].y, twin.world.disks.position[i].y);
  }
}

// The refinement keeps its best iterate by the natural map, which can leave a larger root mean
// square contact-law violation than the sweeps' result. Where the sweeps' result met the bound
// (solver.residual_tolerance) and the refined one does not, the step keeps the sweeps' result
// exactly: every step that ends off the cap meets the bound, refined or not.
TEST(ActiveSet, KeepsTheSweepsResultWhereTheRefinedStepBreaksTheBound) {
  ShearedBox box(0.05, 150);
  box.options.solver.residual_tolerance = 1e-4 * 0.05 * box.options.dt;  // the "auto" rule
  box.options.solver.newton_iterations = 1;
  int undone = 0, refined_above_swept = 0;
  for (int k = 0; k < 300; ++k) {
    SolverOptions swept_only = box.options.solver;
    swept_only.newton_iterations = 0;
    StepReport swept;
    const std::vector<double> sweeps = box.impulses(swept_only, &swept);
    const StepReport r = box.dynamics.step(box.world, box.options);
    ASSERT_FALSE(r.blown_up);
    ASSERT_EQ(r.solver.hit_cap, swept.solver.hit_cap);  // the same sweeps
    if (!r.solver.hit_cap)
      EXPECT_LE(r.velocity_residual.rms_carrying * box.options.dt,
                box.options.solver.residual_tolerance * (1 + 1e-9))
          << "step " << k;
    refined_above_swept += r.velocity_residual.rms_carrying > swept.velocity_residual.rms_carrying;
    if (r.active_set.undone) {
      ++undone;
      EXPECT_FALSE(r.solver.hit_cap);
      EXPECT_EQ(r.velocity_residual.rms_carrying, swept.velocity_residual.rms_carrying);
      std::size_t i = 0;
      for (const Contact& c : box.dynamics.contacts()) {
        EXPECT_EQ(c.impulse_n, sweeps[i++]);
        EXPECT_EQ(c.impulse_t, sweeps[i++]);
      }
    }
  }
  EXPECT_GE(undone, 1) << "no refined step broke the bound here (" << refined_above_swept
                       << " raised the violation): the test shows nothing";
}

// The tally counts the steps the refinement ran on, those at its tolerance and their mean
// iterations, and keeps the largest residual, a NaN included (std::max would drop it).
TEST(RefinementTally, CountsTheRefinedStepsAndKeepsANaNResidual) {
  RefinementTally tally;
  tally.add(ActiveSetReport{});  // a step without contacts: not refined
  EXPECT_EQ(tally.steps, 0u);
  EXPECT_EQ(tally.mean_iterations(), 0.0);
  ActiveSetReport solved, stalled;
  solved.ran = stalled.ran = true;
  solved.converged = true;
  solved.iterations = 3;
  solved.residual = 1e-13;
  stalled.iterations = 6;
  stalled.residual = 2e-5;
  tally.add(solved);
  tally.add(stalled);
  EXPECT_EQ(tally.steps, 2u);
  EXPECT_EQ(tally.steps_to_tolerance, 1u);
  EXPECT_DOUBLE_EQ(tally.mean_iterations(), 4.5);
  EXPECT_EQ(tally.largest_residual, 2e-5);
  ActiveSetReport broken = stalled;
  broken.residual = std::numeric_limits<double>::quiet_NaN();
  tally.add(broken);
  tally.add(solved);
  EXPECT_TRUE(std::isnan(tally.largest_residual));
  EXPECT_EQ(tally.steps, 4u);
}

}  // namespace
}  // namespace cdshear
