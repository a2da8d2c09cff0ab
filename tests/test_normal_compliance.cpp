// Normal compliance (SolverOptions::normal_compliance): a column of disks on a floor under
// gravity, where the compliant step's solution is known in closed form. The statics of a chain
// do not depend on the compliance (each contact carries the weight above it), and a contact
// carrying R_n ends each step overlapping by kappa w_nn R_n dt, so each disk settles lower than
// its rigid place by the sum of the overlaps below it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "test_support.hpp"

namespace cdshear {
namespace {

constexpr double kR = 0.5, kG = 1.0, kDt = 1e-3;
constexpr int kDisks = 10;

struct CompliantColumn {
  double force_error = 0.0;   ///< worst relative error of a contact force, last step
  double sink_error = 0.0;    ///< worst |sink - predicted| / predicted over the disks, last step
  double largest_sink = 0.0;  ///< largest |sink| of a disk (the top one's) [length]
  double residual = 0.0;      ///< largest velocity residual of the compliant law, last step
  int capped = 0;
};

/// kDisks disks of radius kR stacked on a floor, stepped `steps` times with `solver`.
CompliantColumn run_compliant_column(const SolverOptions& solver, int steps) {
  const SceneDefinition s = testing::disk_column(kDisks, kR, kG);
  StepOptions o;
  o.dt = kDt;
  o.solver = solver;
  testing::Simulation sim(s, o);
  sim.run(steps);
  const double m = testing::disk_mass(kR), kappa = solver.normal_compliance;
  CompliantColumn out;
  out.capped = sim.hit_cap_steps();
  out.residual = sim.last().velocity_residual.largest;
  // Predicted overlaps, kappa w_nn R_n dt with R_n = (weight above) dt: the floor's contact
  // (w_nn = 1/m) carries all kDisks weights, the one above disk j (w_nn = 2/m) kDisks - 1 - j.
  double sink = kappa * (1.0 / m) * (kDisks * m * kG * kDt) * kDt;
  for (int k = 0; k < kDisks; ++k) {
    if (k > 0) sink += kappa * (2.0 / m) * ((kDisks - k) * m * kG * kDt) * kDt;
    const double y = sim.world.disks.position[k].y;
    const double measured = (kR + 2.0 * kR * k) - y;
    out.sink_error = std::max(out.sink_error, std::abs(measured - sink) / sink);
    out.largest_sink = std::max(out.largest_sink, std::abs(measured));  // a rise counts too
  }
  const double floor_force = -sim.world.walls[0].contact_force.y;
  out.force_error = std::abs(floor_force - kDisks * m * kG) / (kDisks * m * kG);
  for (int k = 0; k + 1 < kDisks; ++k) {
    const auto c = sim.contact(k, k + 1);
    if (!c) return {1.0, 1.0, 0.0, 1.0, out.capped};
    const double expected = (kDisks - 1 - k) * m * kG;
    out.force_error = std::max(out.force_error, std::abs(c->impulse_n / kDt - expected) / expected);
  }
  return out;
}

SolverOptions tight_solver(double kappa, double relaxation) {
  SolverOptions o;
  o.alpha = 1e-24;
  o.converged_fraction = 1.0;
  o.max_sweeps = 5000;
  o.relaxation = relaxation;
  o.normal_compliance = kappa;
  return o;
}

TEST(NormalCompliance, ColumnSettlesByThePredictedOverlapsWithItsStatics) {
  // kappa 0.01: the top disk settles kappa g dt^2 kDisks^2 = 1e-6 below its rigid place.
  // Tolerances: positions of order 10 carry round-off of about 2e-15, a sink of 1e-8 or more
  // is then known to 1e-6 of itself; a contact turns a gap error delta into a force error
  // delta / (kappa w_nn dt^2), about 1e-7 of the lightest load (m g) here.
  const CompliantColumn c = run_compliant_column(tight_solver(0.01, 1.0), 1000);
  EXPECT_NEAR(c.largest_sink, 0.01 * kG * kDt * kDt * kDisks * kDisks, 1e-12);
  EXPECT_LT(c.sink_error, 1e-6);
  EXPECT_LT(c.force_error, 1e-6);  // the chain's statics, as for rigid disks
  EXPECT_LT(c.residual, 1e-12);    // the compliant law is met, not the rigid one
  EXPECT_EQ(c.capped, 0);
}

TEST(NormalCompliance, OverRelaxedUpdatesReachTheSameCompliantSolution) {
  // The one-stage over-relaxed update scales the old R_n by 1 - omega kappa / (1 + kappa)
  // (nlgs_solver.cpp, update_row): a wrong factor moves the fixed point, and the sinks with it.
  const CompliantColumn c = run_compliant_column(tight_solver(0.05, 1.6), 1000);
  EXPECT_LT(c.sink_error, 1e-6);
  EXPECT_LT(c.force_error, 1e-6);
  EXPECT_LT(c.residual, 1e-12);
  EXPECT_EQ(c.capped, 0);
}

TEST(NormalCompliance, ActiveSetRefinementReachesTheCompliantSolution) {
  // One sweep a step, then the active-set refinement, which must solve the compliant law: a
  // refinement of the rigid laws would hold the disks at their rigid places (no sink at all).
  SolverOptions o;
  o.max_sweeps = 1;
  o.newton_iterations = 4;
  o.normal_compliance = 0.01;
  const CompliantColumn c = run_compliant_column(o, 1000);
  EXPECT_NEAR(c.largest_sink, 0.01 * kG * kDt * kDt * kDisks * kDisks, 1e-12);
  EXPECT_LT(c.sink_error, 1e-6);
  EXPECT_LT(c.force_error, 1e-6);
  EXPECT_LT(c.residual, 1e-12);
}

TEST(NormalCompliance, RigidColumnDoesNotSink) {
  // The same column at kappa 0: the rigid statics, no sink at all (the check that the sinks
  // above come from the compliance, not from the solve).
  const CompliantColumn c = run_compliant_column(tight_solver(0.0, 1.6), 300);
  EXPECT_LT(c.largest_sink, 1e-12);
  EXPECT_LT(c.force_error, 1e-10);
}

}  // namespace
}  // namespace cdshear
