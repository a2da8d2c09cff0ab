// The slab correction (slab_correction.hpp): its Petrov-Galerkin condition holds after it, the
// bodies follow the scaled impulses, a solved step is left as it is, and a tall column reaches
// its statics in far fewer sweeps with it than without.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "nlgs_solver.hpp"
#include "random.hpp"
#include "slab_correction.hpp"
#include "test_support.hpp"

namespace cdshear {
namespace {

/// A zig-zag chain of `count` disks, two per band, each touching the next: rows with random
/// impulses inside their cones, bodies with random velocities, one row per group, all groups in
/// one phase (one thread: a phase's groups need not be independent here).
struct Chain {
  std::vector<SolverBody> bodies;
  std::vector<SolverRow> rows;
  std::vector<std::size_t> group_start;
  std::vector<std::vector<std::uint32_t>> awake;
  std::vector<SolverPhase> phases;
  std::vector<std::uint32_t> node_of_body;
  std::size_t bands = 0;

  explicit Chain(std::size_t count) {
    CounterRandom rng(7, RandomStream::kPlacement, 0);
    const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * rng.uniform(); };
    std::vector<Vec2> position(count);
    for (std::size_t k = 0; k < count; ++k) {
      position[k] = {k % 2 == 0 ? 0.0 : 0.3, 0.95 * static_cast<double>(k)};
      SolverBody b;
      b.velocity = {uniform(-0.1, 0.1), uniform(-0.1, 0.1)};
      b.omega = uniform(-0.1, 0.1);
      const double inv_mass = uniform(0.8, 1.2);
      b.inv_mass = {inv_mass, inv_mass};
      b.inv_inertia = 8.0 * inv_mass;
      b.band = static_cast<std::uint32_t>(k / 2);
      bodies.push_back(b);
      node_of_body.push_back(b.band);
    }
    bands = (count + 1) / 2;
    for (std::size_t k = 0; k + 1 < count; ++k) {
      SolverRow r;
      r.body_a = static_cast<std::uint32_t>(k + 1);  // the upper disk; normal from b to a
      r.body_b = static_cast<std::uint32_t>(k);
      const Vec2 d = position[k + 1] - position[k];
      r.normal = d * (1.0 / length(d));
      r.lever_a = -0.5;
      r.lever_b = -0.5;
      r.bias_n = uniform(-0.01, 0.01);
      r.friction = 0.5;
      // Every third row open: the correction must leave it so.
      r.impulse_n = k % 3 == 2 ? 0.0 : uniform(0.5, 1.5);
      r.impulse_t = uniform(-0.4, 0.4) * r.impulse_n;
      rows.push_back(r);
      group_start.push_back(k);
      awake.push_back({static_cast<std::uint32_t>(k)});
    }
    group_start.push_back(rows.size());
    group_start.push_back(rows.size());  // an empty serial group
    awake.emplace_back();
    phases.push_back({0, rows.size()});
  }

  SlabLayout layout() const { return {&group_start, &awake, &phases, bands, &node_of_body}; }

  /// r_j = sum over the rows of band j (weight 1/2 to each body's band) of R_n (u_n + bias),
  /// R_n from `weights` (the impulses before a correction), u_n from the current velocities.
  std::vector<double> band_residuals(const std::vector<SolverRow>& weights) const {
    std::vector<double> r(bands, 0.0);
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const SolverRow& row = rows[k];
      const SolverBody& a = bodies[row.body_a];
      const SolverBody& b = bodies[row.body_b];
      const double u_n = dot(a.velocity - b.velocity, row.normal) + row.bias_n;
      r[a.band] += 0.5 * weights[k].impulse_n * u_n;
      r[b.band] += 0.5 * weights[k].impulse_n * u_n;
    }
    return r;
  }
};

/// Expects two chains' bodies (velocities) and rows (impulses) to be equal, bit for bit.
void expect_same_state(const Chain& a, const Chain& b) {
  for (std::size_t k = 0; k < a.bodies.size(); ++k) {
    EXPECT_EQ(a.bodies[k].velocity, b.bodies[k].velocity) << "body " << k;
    EXPECT_EQ(a.bodies[k].omega, b.bodies[k].omega) << "body " << k;
  }
  for (std::size_t k = 0; k < a.rows.size(); ++k) {
    EXPECT_EQ(a.rows[k].impulse_n, b.rows[k].impulse_n) << "row " << k;
    EXPECT_EQ(a.rows[k].impulse_t, b.rows[k].impulse_t) << "row " << k;
  }
}

/// The solver keeps one SlabCorrection for a whole run: after `first_use` on another state of
/// the chain (which may leave marks and sums behind), a reset and a correction must give bit for
/// bit what a new object gives.
void expect_reused_gives_what_new_gives(
    const std::function<void(SlabCorrection&, Chain&)>& first_use) {
  const Chain original(40);
  Chain other(40);
  for (SolverRow& r : other.rows) r.impulse_n *= 1.7;  // another state of the same chain
  SlabCorrection reused, fresh;
  reused.reset(other.bodies.size(), other.layout());
  first_use(reused, other);

  Chain a = original, b = original;
  reused.reset(a.bodies.size(), a.layout());
  fresh.reset(b.bodies.size(), b.layout());
  ASSERT_TRUE(reused.apply(a.rows, a.bodies));
  ASSERT_TRUE(fresh.apply(b.rows, b.bodies));
  EXPECT_EQ(reused.scales(), fresh.scales());
  expect_same_state(a, b);
}

TEST(SlabCorrection, CancelsEveryBandsMeanNormalVelocityError) {
  Chain chain(40);
  const std::vector<SolverRow> before = chain.rows;
  const std::vector<SolverBody> bodies_before = chain.bodies;
  const std::vector<double> r0 = chain.band_residuals(before);
  SlabCorrection correction;
  correction.reset(chain.bodies.size(), chain.layout());
  ASSERT_TRUE(correction.apply(chain.rows, chain.bodies));

  // The scales stay inside their bounds here (no clamping), so the condition holds exactly: every
  // band's residual, weighted by the impulses before the correction, vanishes to round-off.
  double largest_r0 = 0.0, largest_scale = 0.0;
  for (const double v : r0) largest_r0 = std::max(largest_r0, std::abs(v));
  for (const double s : correction.scales()) {
    largest_scale = std::max(largest_scale, std::abs(s));
    EXPECT_GT(s, SlabCorrection::kLowestScale);
    EXPECT_LT(s, SlabCorrection::kHighestScale);
  }
  EXPECT_GT(largest_scale, 1e-3);  // it did correct something
  const std::vector<double> r1 = chain.band_residuals(before);
  for (std::size_t j = 0; j < chain.bands; ++j) EXPECT_LT(std::abs(r1[j]), 1e-12 * largest_r0);

  // Each row is scaled by 1 + (s_a + s_b) / 2 (open rows stay open), and the bodies moved as if
  // each row's change had been applied to them.
  std::vector<SolverBody> expected = bodies_before;
  for (std::size_t k = 0; k < chain.rows.size(); ++k) {
    const SolverRow& r = before[k];
    const double s = 0.5 * (correction.scales()[chain.node_of_body[r.body_a]] +
                            correction.scales()[chain.node_of_body[r.body_b]]);
    EXPECT_NEAR(chain.rows[k].impulse_n, (1.0 + s) * r.impulse_n, 1e-14);
    EXPECT_NEAR(chain.rows[k].impulse_t, (1.0 + s) * r.impulse_t, 1e-14);
    apply_row_impulse(r, expected[r.body_a], expected[r.body_b], s * r.impulse_n, s * r.impulse_t);
  }
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_NEAR(chain.bodies[k].velocity.x, expected[k].velocity.x, 1e-13);
    EXPECT_NEAR(chain.bodies[k].velocity.y, expected[k].velocity.y, 1e-13);
    EXPECT_NEAR(chain.bodies[k].omega, expected[k].omega, 1e-13);
  }
}

TEST(SlabCorrection, ReusedGivesTheSameAsNew) {
  // Each apply() must leave its scratch as it found it (the slots' marks cleared).
  expect_reused_gives_what_new_gives(
      [](SlabCorrection& c, Chain& other) { ASSERT_TRUE(c.apply(other.rows, other.bodies)); });
}

TEST(SlabCorrection, ChangesNothingWithoutForce) {
  Chain chain(12);
  for (SolverRow& r : chain.rows) r.impulse_n = r.impulse_t = 0.0;
  const std::vector<SolverBody> before = chain.bodies;
  SlabCorrection correction;
  correction.reset(chain.bodies.size(), chain.layout());
  correction.apply(chain.rows, chain.bodies);
  for (const double s : correction.scales()) EXPECT_EQ(s, 0.0);
  for (std::size_t k = 0; k < before.size(); ++k) {
    EXPECT_EQ(chain.bodies[k].velocity, before[k].velocity);
    EXPECT_EQ(chain.bodies[k].omega, before[k].omega);
  }
  for (const SolverRow& r : chain.rows) EXPECT_EQ(r.impulse_n, 0.0);
}

// A column of equal disks stacked on a floor under gravity (as in test_column.cpp): the contact
// below disk k carries the weight of disks k..N-1, and the step from rest has that solution
// only.
constexpr double kR = 0.5, kG = 1.0, kDt = 1e-3;

testing::Simulation column(int n, const SolverOptions& solver) {
  SceneDefinition s;
  s.gravity = {0.0, -kG};
  s.walls.push_back(testing::fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0}));
  for (int k = 0; k < n; ++k) s.disks.push_back(testing::disk({0.0, kR + 2.0 * kR * k}, kR));
  StepOptions o;
  o.dt = kDt;
  o.solver = solver;
  return testing::Simulation(s, o);
}

/// Worst relative error of the disk-disk contact forces against the statics under gravity g.
double worst_force_error(const testing::Simulation& sim, int n, double g = kG) {
  const double m = testing::disk_mass(kR);
  double worst = 0.0;
  for (int k = 0; k + 1 < n; ++k) {
    const auto c = sim.contact(k, k + 1);
    if (!c) return INFINITY;
    const double expected = (n - 1 - k) * m * g;
    worst = std::max(worst, std::abs(c->impulse_n / kDt - expected) / expected);
  }
  return worst;
}

SolverOptions fixed_sweeps(int sweeps, int slab_period) {
  SolverOptions o;
  o.order = ContactOrder::kColoured;
  o.alpha = 0.0;  // never met: exactly `sweeps` sweeps
  o.max_sweeps = sweeps;
  o.slab_correction_period = slab_period;
  return o;
}

/// A column of n solved to round-off under gravity g, then one step solved with `second`
/// under gravity 1.5 g, warm-started from the first step's forces, which are now two thirds of
/// the statics all along the column: the worst relative force error of that step (and, if
/// asked, how many corrections it applied).
double error_after_load_change(int n, const SolverOptions& second, int* corrections = nullptr) {
  SolverOptions tight = fixed_sweeps(200000, 0);
  tight.alpha = 1e-30;
  tight.converged_fraction = 1.0;
  testing::Simulation sim = column(n, tight);
  sim.run(1);
  sim.world.body_force = {0.0, -1.5 * kG};
  sim.options.solver = second;
  sim.run(1);
  if (corrections != nullptr) *corrections = sim.last().solver.slab_corrections;
  return worst_force_error(sim, n, 1.5 * kG);
}

/// The same with `sweeps` sweeps and the slab correction every `slab_period` (0: none).
double error_after_load_change(int n, int sweeps, int slab_period, int* corrections = nullptr) {
  return error_after_load_change(n, fixed_sweeps(sweeps, slab_period), corrections);
}

TEST(SlabCorrection, TallColumnReachesItsStaticsInFarFewerSweeps) {
  // 200 disks, 50 bands of four. Gauss-Seidel carries a change of load along the chain by about
  // one contact per sweep; a correction every 8 sweeps rescales each band's forces at once.
  const int n = 200;
  const double plain = error_after_load_change(n, 100, 0);
  int corrections = 0;
  const double corrected = error_after_load_change(n, 100, 8, &corrections);
  std::printf(
      "column of %d, load x 1.5, one step of 100 sweeps: worst force error %.3g plain, "
      "%.3g with the slab correction every 8 sweeps\n",
      n, plain, corrected);
  EXPECT_GT(plain, 0.1);
  // The correction gives about 7e-6; a correction whose scratch leaks from one correction into the
  // next of the same step gave 5e-3, and one that corrects nothing gives the plain error.
  EXPECT_LT(corrected, 1e-4);
  // After sweeps 8, 16, ..., 96: never after the last one (the step ends on a sweep's result).
  EXPECT_EQ(corrections, 12);
}

TEST(SlabCorrection, RunsInPackingsOfTwentyBandsOrMoreOnly) {
  // A column of n disks has (n - 1) / 4 + 1 bands of four diameters (whole division). One band
  // short of kSlabCorrectionMinBands, the solve stays plain, bit for bit; at the threshold it is
  // corrected.
  const int below = 4 * static_cast<int>(kSlabCorrectionMinBands - 1);  // 19 bands
  const int at = below + 4;                                             // 20 bands
  int none = -1, some = -1;
  EXPECT_EQ(error_after_load_change(below, 100, 8, &none), error_after_load_change(below, 100, 0));
  EXPECT_EQ(none, 0);
  const double corrected = error_after_load_change(at, 100, 8, &some);
  EXPECT_EQ(some, 12);
  EXPECT_LT(corrected, error_after_load_change(at, 100, 0));
}

TEST(SlabCorrection, MixRunsHalfAsOftenWhereTheCorrectionRuns) {
  // In the steps where the correction runs, the mix runs every 2 anderson_period sweeps
  // (kMixPeriodFactorWithSlabCorrection), and only there: 60 sweeps, anderson_period 4, never
  // after the last sweep.
  const auto mixes = [](int n, int slab_period) {
    SolverOptions o = fixed_sweeps(60, slab_period);
    o.relaxation = 1.6;
    o.anderson_depth = 5;
    o.anderson_period = 4;
    testing::Simulation sim = column(n, o);
    sim.run(1);
    return sim.last().solver.anderson_mixes;
  };
  EXPECT_EQ(mixes(200, 8), 7);   // after sweeps 8, 16, ..., 56
  EXPECT_EQ(mixes(200, 0), 14);  // after sweeps 4, 8, ..., 56
  EXPECT_EQ(mixes(76, 8), 14);   // 19 bands: no correction, the plain period
}

TEST(SlabCorrection, ScalingLeftToTheCallerGivesTheSameAsApply) {
  // The solver gathers the rows in its sweep and leaves pass 5 to the gather of the Anderson mix
  // that follows (apply_gathered(..., false), then scale_row on every awake row): bit for bit
  // what apply() gives.
  const Chain original(40);
  Chain whole = original, split = original;
  SlabCorrection a, b;
  a.reset(whole.bodies.size(), whole.layout());
  b.reset(split.bodies.size(), split.layout());
  ASSERT_TRUE(a.apply(whole.rows, whole.bodies));
  b.gather_rows(split.rows);
  ASSERT_TRUE(b.apply_gathered(split.rows, split.bodies, false));
  for (std::size_t k = 0; k < split.rows.size(); ++k) {
    EXPECT_EQ(split.rows[k].impulse_n, original.rows[k].impulse_n);  // not scaled yet
    b.scale_row(split.rows[k]);
  }
  EXPECT_EQ(a.scales(), b.scales());
  expect_same_state(split, whole);
}

TEST(SlabCorrection, GatheringThatNoCorrectionFollowsLeavesNothingBehind) {
  // The sweep before a correction gathers; when that sweep ends the step, nothing applies the
  // gathering, and the next step's reset must drop it.
  expect_reused_gives_what_new_gives(
      [](SlabCorrection& c, Chain& other) { c.gather_rows(other.rows); });  // no apply_gathered
}

TEST(SlabCorrection, LeavesASolvedStepUnchanged) {
  // Step 1 solved to round-off; step 2 starts from that solution (warm start) in the same state,
  // and a correction after every sweep must keep it: at a solution r = 0, so s = 0. 80 disks:
  // kSlabCorrectionMinBands bands of four, the fewest where the correction runs.
  const int n = 4 * static_cast<int>(kSlabCorrectionMinBands);
  SolverOptions tight = fixed_sweeps(200000, 0);
  tight.alpha = 1e-30;
  tight.converged_fraction = 1.0;
  testing::Simulation sim = column(n, tight);
  sim.run(1);
  ASSERT_LT(worst_force_error(sim, n), 1e-10);
  sim.options.solver = fixed_sweeps(12, 1);
  sim.run(1);
  EXPECT_EQ(sim.last().solver.slab_corrections, 11);  // after sweeps 1 to 11, not the last
  EXPECT_LT(worst_force_error(sim, n), 1e-10);
}

}  // namespace
}  // namespace cdshear
