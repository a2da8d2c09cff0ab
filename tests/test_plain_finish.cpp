// The plain finish (SolverOptions::plain_finish, nlgs_solver.hpp): an over-relaxed solve that
// reaches its cap goes on from the impulses it reached with relaxation 1, and ends most of the
// steps the over-relaxed sweeps left at the cap, closer to the contact laws; steps that met the
// criterion are untouched, and the result does not depend on the thread count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "test_support.hpp"

namespace cdshear {
namespace {

/// The shear phase's solver at a slow wall speed (coloured order, over-relaxation, the mix,
/// dormant contacts skipped, alpha 1e-7 as "auto" gives at V = 0.05).
StepOptions slow_shear_options() {
  StepOptions o;
  o.dt = 0.005;
  o.solver.order = ContactOrder::kColoured;
  o.solver.relaxation = 1.6;
  o.solver.anderson_depth = 5;
  o.solver.anderson_period = 4;
  o.solver.skip_dormant = true;
  o.solver.alpha = 1e-7;
  return o;
}

/// The median contact-law violation over a step, e dt [d], of `steps` steps from `box` (a copy)
/// that end off the cap: a tolerance that holds back about half of such steps.
double median_violation(testing::ShearedBox box, const StepOptions& o, int steps) {
  std::vector<double> violations;
  for (int k = 0; k < steps; ++k) {
    const StepReport r = box.dynamics.step(box.world, o);
    if (!r.solver.hit_cap) violations.push_back(r.velocity_residual.rms_carrying * o.dt);
  }
  std::sort(violations.begin(), violations.end());
  return violations.empty() ? 0.0 : violations[violations.size() / 2];
}

TEST(PlainFinish, EndsTheStepsOverRelaxationLeavesAtTheCapCloserToTheContactLaws) {
  testing::ShearedBox box = testing::sheared_dense_box(300, 12.0, 0.05);
  ASSERT_TRUE(box.dense);
  StepOptions stop_at_cap = slow_shear_options();
  stop_at_cap.solver.plain_finish = false;
  StepOptions finish = slow_shear_options();
  int capped = 0, ended = 0, closer = 0;
  for (int k = 0; k < 200; ++k) {
    // The same step from the same state, with the finish (a copy) and without (the trajectory).
    World w = box.world;
    ContactDynamics d = box.dynamics;
    const StepReport with = d.step(w, finish);
    const StepReport without = box.dynamics.step(box.world, stop_at_cap);
    ASSERT_FALSE(without.blown_up);
    if (!without.solver.hit_cap) {
      EXPECT_FALSE(with.solver.finished_plain) << "step " << k;
      EXPECT_EQ(with.solver.sweeps, without.solver.sweeps) << "step " << k;
      EXPECT_EQ(with.velocity_residual.rms_carrying, without.velocity_residual.rms_carrying);
      continue;
    }
    ++capped;
    EXPECT_TRUE(with.solver.finished_plain) << "step " << k;
    EXPECT_GT(with.solver.sweeps, without.solver.sweeps);
    EXPECT_LE(with.solver.sweeps, 2 * finish.solver.max_sweeps);
    ended += !with.solver.hit_cap;
    closer += with.velocity_residual.rms_carrying < without.velocity_residual.rms_carrying;
  }
  EXPECT_GE(capped, 5) << "steps at the cap without the finish, of 200";
  EXPECT_GE(4 * ended, 3 * capped) << ended << " of " << capped << " ended by the finish";
  EXPECT_GE(4 * closer, 3 * capped)
      << closer << " of " << capped << " closer to the contact laws with the finish";
}

TEST(PlainFinish, EndsTheStepsTheResidualTestHoldsBackSoonerThanOverRelaxation) {
  // A step whose changes meet alpha while its contact-law violation is above residual_tolerance
  // goes on with relaxation 1 (the finish) rather than over-relaxed. From the same states, with
  // the tolerance at the median violation of the steps without it: the held-back steps end
  // within it, and the finish takes fewer sweeps after the refusal than over-relaxation does.
  testing::ShearedBox box = testing::sheared_dense_box(300, 12.0, 0.05);
  ASSERT_TRUE(box.dense);
  StepOptions finish = slow_shear_options();
  finish.solver.residual_tolerance = median_violation(box, finish, 100);
  StepOptions over_relaxed = finish;
  over_relaxed.solver.plain_finish = false;
  over_relaxed.solver.max_sweeps = 2 * finish.solver.max_sweeps;  // the same sweeps at most
  int held = 0, finished = 0, ended = 0, paired = 0;
  long sweeps_finish = 0, sweeps_over_relaxed = 0;
  for (int k = 0; k < 200; ++k) {
    World w = box.world;
    ContactDynamics d = box.dynamics;
    const StepReport other = d.step(w, over_relaxed);
    const StepReport r = box.dynamics.step(box.world, finish);
    ASSERT_FALSE(r.blown_up);
    if (r.solver.residual_refusals == 0) continue;
    ++held;
    finished += r.solver.finished_plain;
    if (!r.solver.hit_cap) {
      ++ended;
      EXPECT_LE(r.velocity_residual.rms_carrying * finish.dt,
                finish.solver.residual_tolerance * (1.0 + 1e-9));
    }
    // Refused in the over-relaxed sweeps (not in a finish after the cap): the other solve did
    // the same sweeps up to there (their dormant looks differ from one before the cap on).
    if (r.solver.first_refusal_sweep >= finish.solver.max_sweeps - 1) continue;
    ++paired;
    EXPECT_EQ(other.solver.first_refusal_sweep, r.solver.first_refusal_sweep) << "step " << k;
    sweeps_finish += r.solver.sweeps - r.solver.first_refusal_sweep;
    sweeps_over_relaxed += other.solver.sweeps - other.solver.first_refusal_sweep;
  }
  std::printf(
      "held back %d of 200 steps (%d ended, %d refused over-relaxed); sweeps after the "
      "refusal: %ld finishing plain, %ld over-relaxed\n",
      held, ended, paired, sweeps_finish, sweeps_over_relaxed);
  EXPECT_GE(held, 10);
  EXPECT_GE(paired, 5);
  EXPECT_EQ(finished, held);
  EXPECT_GE(4 * ended, 3 * held);
  EXPECT_LT(sweeps_finish, sweeps_over_relaxed);
}

TEST(PlainFinish, GivesTheSameStateOnAnyNumberOfThreads) {
  // Both ways into the finish: the cap, and a contact-law bound that holds steps back.
  CDSHEAR_SKIP_IF_ONE_PROCESSOR();
  testing::ShearedBox one = testing::sheared_dense_box(300, 12.0, 0.05);
  ASSERT_TRUE(one.dense);
  testing::ShearedBox two = one;
  StepOptions o1 = slow_shear_options();
  o1.solver.residual_tolerance = median_violation(one, o1, 40);
  StepOptions o2 = o1;
  o2.solver.threads = 2;
  o2.solver.min_rows_per_thread = 1;
  int finished = 0, held = 0;
  for (int k = 0; k < 120; ++k) {
    const StepReport r1 = one.dynamics.step(one.world, o1);
    const StepReport r2 = two.dynamics.step(two.world, o2);
    ASSERT_EQ(r1.solver.sweeps, r2.solver.sweeps) << "step " << k;
    ASSERT_EQ(r1.solver.residual_refusals, r2.solver.residual_refusals) << "step " << k;
    finished += r1.solver.finished_plain;
    held += r1.solver.residual_refusals > 0;
  }
  EXPECT_GE(finished, 3) << "steps that went on with relaxation 1, of 120";
  EXPECT_GE(held, 1) << "steps the bound held back, of 120";
  for (std::size_t i = 0; i < one.world.disks.size(); ++i) {
    EXPECT_EQ(one.world.disks.position[i].x, two.world.disks.position[i].x);
    EXPECT_EQ(one.world.disks.position[i].y, two.world.disks.position[i].y);
    EXPECT_EQ(one.world.disks.omega[i], two.world.disks.omega[i]);
  }
}

}  // namespace
}  // namespace cdshear
