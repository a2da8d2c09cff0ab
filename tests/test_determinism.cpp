// Determinism: a run is a pure function of its scene and seeds (bitwise, through state_hash),
// and the hash is sensitive enough to tell runs apart.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "nlgs_solver.hpp"
#include "scene_presets.hpp"
#include "test_support.hpp"
#include "threads.hpp"

namespace cdshear {
namespace {

using testing::fixed_wall;

/// 80 disks falling into a box under gravity: many collisions and multi-contact steps. (Wider
/// boxes, with more disks in the same density: `width` 8 by default.)
SceneDefinition falling_box(double width = 8.0) {
  SceneDefinition s;
  s.gravity = {0.0, -1.0};
  s.walls = {fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0}),
             fixed_wall("left", {0.0, 0.0}, {1.0, 0.0}),
             fixed_wall("right", {width, 0.0}, {-1.0, 0.0})};
  RandomDisksSpec r;
  r.count = static_cast<int>(std::lround(10.0 * width));
  r.region_min = {0.0, 0.0};
  r.region_max = {width, 14.0};
  r.seed = 5;
  s.random_disks.push_back(r);
  return s;
}

StepOptions options(std::uint64_t seed, ContactOrder order = ContactOrder::kRandom) {
  StepOptions o;
  o.dt = 4e-3;
  o.solver.seed = seed;
  o.solver.order = order;
  return o;
}

constexpr int kSteps = 500;

std::uint64_t run_hash(std::uint64_t seed, ContactOrder order = ContactOrder::kRandom) {
  testing::Simulation sim(falling_box(), options(seed, order));
  sim.run(kSteps);
  EXPECT_FALSE(sim.last().blown_up);
  return state_hash(sim.world);
}

TEST(Determinism, SameSeedGivesTheSameStateHash) {
  const std::uint64_t first = run_hash(1);
  EXPECT_EQ(run_hash(1), first);
  EXPECT_EQ(run_hash(1), first);
  // Coloured order too.
  EXPECT_EQ(run_hash(1, ContactOrder::kColoured), run_hash(1, ContactOrder::kColoured));
}

TEST(Determinism, ColouredOrderGivesTheSameStateOnAnyNumberOfThreads) {
  // Bitwise the same trajectory on 1, 2 and 3 threads (docs/performance.md): the groups of the
  // coloured order are fixed by the geometry, not by the threads, and the convergence sums are
  // added in group order. The runs must really use the threads asked for.
  CDSHEAR_SKIP_IF_ONE_PROCESSOR();
  const auto coloured_hash = [](int threads) {
    StepOptions o = options(1, ContactOrder::kColoured);
    o.solver.threads = threads;
    o.solver.min_rows_per_thread = 1;  // share even the few contacts of this box
    testing::Simulation sim(falling_box(), o);
    sim.run(kSteps);
    EXPECT_FALSE(sim.last().blown_up);
    int most_threads = 0, most_phases = 0;
    for (const StepReport& r : sim.reports) {
      most_threads = std::max(most_threads, r.solver.threads);
      most_phases = std::max(most_phases, static_cast<int>(r.solver.colours));
    }
    EXPECT_GE(most_phases, 2);  // slabs and slab boundaries, not one serial group
#if defined(_OPENMP)
    EXPECT_EQ(most_threads, std::min(threads, processors_available()));
#endif
    return state_hash(sim.world);
  };
  const std::uint64_t one = coloured_hash(1);
  EXPECT_EQ(coloured_hash(2), one);
  EXPECT_EQ(coloured_hash(3), one);  // 3 where the machine has 3 processors or more
  EXPECT_NE(one, run_hash(1));       // and it is another order than the random one
}

/// One coloured-order step of a zig-zag column of 48 unit disks on a floor, falling at 1e-3 (a
/// step of gravity), disk k in band band_of(k); fixed sweeps, with the slab correction and the
/// mix. The impulses and the disks' velocities after it, in order.
template <class BandOf>
std::vector<double> coloured_column_step(const BandOf& band_of, int threads) {
  constexpr std::size_t kDisks = 48;
  std::vector<SolverBody> bodies(kDisks + 1);  // the floor last
  std::vector<Contact> contacts;
  for (std::size_t k = 0; k < kDisks; ++k) {
    bodies[k].velocity = {0.0, -1e-3};
    bodies[k].inv_mass = {1.0, 1.0};
    bodies[k].inv_inertia = 8.0;
    bodies[k].band = static_cast<std::uint32_t>(band_of(k));
    Contact c;  // on the disk below (on the floor for the first)
    c.key.body_a = static_cast<std::int32_t>(k);
    c.key.body_b = static_cast<std::int32_t>(k == 0 ? kDisks : k - 1);
    const double dx = k == 0 ? 0.0 : (k % 2 == 0 ? -0.3 : 0.3);
    c.normal = Vec2{dx, std::sqrt(1.0 - dx * dx)};
    c.lever_a = -0.5;
    c.lever_b = k == 0 ? 0.0 : -0.5;
    c.friction = 0.5;
    contacts.push_back(c);
  }
  SolverOptions o;
  o.order = ContactOrder::kColoured;
  o.alpha = 0.0;  // never met: exactly max_sweeps sweeps
  o.max_sweeps = 40;
  o.relaxation = 1.6;
  o.anderson_depth = 5;
  o.slab_correction_period = 8;
  o.threads = threads;
  o.min_rows_per_thread = 1;
  SolverWorkspace ws;
  solve_contacts(contacts, bodies, kDisks, 1e-3, o, 0, ws);
  std::vector<double> out;
  for (const Contact& c : contacts) out.insert(out.end(), {c.impulse_n, c.impulse_t});
  for (const SolverBody& b : bodies) out.insert(out.end(), {b.velocity.x, b.velocity.y, b.omega});
  return out;
}

TEST(Determinism, ColouredOrderLeavesOutTheBandsNoContactReaches) {
  // The groups are made of the bands the contacts reach, numbered from the bottom: bands with
  // no contact between them (a cell dilated by fast walls) change nothing, bit for bit, on any
  // number of threads. Were the empty bands given groups of their own, a contact across two
  // reached bands would go to the serial group and the shuffles would be keyed on other group
  // numbers: another result.
  const auto packed = [](std::size_t k) { return k / 2; };                      // 24 bands
  const auto spread = [](std::size_t k) { return 3 * (k / 2); };                // two empty between
  const auto split = [](std::size_t k) { return k / 2 + (k < 24 ? 0 : 900); };  // one gap
  const std::vector<double> reference = coloured_column_step(packed, 1);
  EXPECT_EQ(coloured_column_step(spread, 1), reference);
  EXPECT_EQ(coloured_column_step(split, 1), reference);
  EXPECT_EQ(coloured_column_step(spread, 2), reference);
  EXPECT_EQ(coloured_column_step(split, 3), reference);
  // The step did something: the column carries its weight.
  EXPECT_GT(reference[0], 0.0);
}

TEST(Determinism, AndersonMixingGivesTheSameStateOnAnyNumberOfThreads) {
  // The Anderson mix shares its passes among the threads in chunks fixed by the vector's length,
  // and adds its sums chunk by chunk in order; the mixed impulses are applied phase by phase.
  // 400 disks: the mixed vector spans several chunks (AndersonMixer::kChunk elements each).
  // Also the active contacts each step reports, which every thread counts over its own rows.
  CDSHEAR_SKIP_IF_ONE_PROCESSOR();
  std::vector<int> active;
  const auto hash = [&active](int threads) {
    StepOptions o = options(1, ContactOrder::kColoured);
    o.solver.threads = threads;
    o.solver.min_rows_per_thread = 1;
    o.solver.relaxation = 1.6;
    o.solver.anderson_depth = 5;
    o.solver.anderson_period = 2;
    testing::Simulation sim(falling_box(40.0), o);
    sim.run(4 * kSteps);  // settled: about 700 contacts carry a force
    EXPECT_FALSE(sim.last().blown_up);
    std::size_t most_contacts = 0;
    active.clear();
    for (const StepReport& r : sim.reports) {
      most_contacts = std::max<std::size_t>(most_contacts, r.solver.active_contacts);
      active.push_back(r.solver.active_contacts);
    }
    EXPECT_GT(2 * most_contacts, 2 * AndersonMixer::kChunk);  // measured: 630 contacts
    return state_hash(sim.world);
  };
  const std::uint64_t one = hash(1);
  const std::vector<int> active_one = active;
  EXPECT_EQ(hash(2), one);
  EXPECT_EQ(active, active_one);
  EXPECT_EQ(hash(1), one);
  EXPECT_NE(one, run_hash(1, ContactOrder::kColoured));  // the mix changes the trajectory
}

/// The shear phase's sweeps for testing::sheared_dense_box on `threads` (every row may go to any
/// thread): the coloured order, dormant rows left out, over-relaxation, Anderson mixing, alpha
/// 1e-5.
StepOptions sheared_box_options(int threads) {
  StepOptions o = options(3, ContactOrder::kColoured);
  o.solver.threads = threads;
  o.solver.min_rows_per_thread = 1;
  o.solver.skip_dormant = true;
  o.solver.relaxation = 1.6;
  o.solver.anderson_depth = 5;
  o.solver.anderson_period = 4;
  o.solver.alpha = 1e-5;
  return o;
}

TEST(Determinism, ShearedDenseBoxGivesTheSameStateOnAnyNumberOfThreads) {
  // A dense box periodic in x, sheared by its top wall, like the shear cell: each wall touches
  // one band only and goes with that slab, so the serial group is empty and no thread waits for
  // a single one to test convergence (every thread adds the tallies itself). The solver
  // settings are the shear phase's: dormant rows left out and woken group by group on the
  // team, over-relaxation, Anderson mixing, alpha 1e-5, and the slab correction (every 4
  // sweeps here, twice as often as in the shear phase, to exercise it more). 5 wide, the 600
  // disks stand about 95 high: about 24 bands, more than kSlabCorrectionMinBands.
  const testing::ShearedBox box = testing::sheared_dense_box(600, 5.0, 0.5);
  ASSERT_TRUE(box.dense);
  std::vector<std::size_t> woken;
  std::uint64_t corrections = 0;  // slab corrections of the last call
  std::vector<double> residuals;  // each step's check: RMS and largest e (shared by the threads)
  SolverProfile profile;          // of the last call, summed over its steps
  double solve_seconds = 0.0;     // its solve stages
  const auto hash = [&](int threads, bool profiled = false) {
    World world = box.world;
    ContactDynamics dynamics = box.dynamics;
    StepOptions o = sheared_box_options(threads);
    o.solver.slab_correction_period = 4;
    o.solver.profile = profiled;
    profile = {};
    solve_seconds = 0.0;
    int most_threads = 0, most_phases = 0;
    std::size_t most_contacts = 0;
    woken.clear();
    residuals.clear();
    corrections = 0;
    for (int k = 0; k < 200; ++k) {
      const StepReport r = dynamics.step(world, o);
      EXPECT_FALSE(r.blown_up);
      most_threads = std::max(most_threads, r.solver.threads);
      most_phases = std::max(most_phases, static_cast<int>(r.solver.colours));
      most_contacts = std::max<std::size_t>(most_contacts, r.solver.active_contacts);
      woken.push_back(r.solver.woken_contacts);
      residuals.push_back(r.velocity_residual.rms_carrying);
      residuals.push_back(r.velocity_residual.largest);
      profile += r.solver.profile;
      solve_seconds += r.seconds.solve;
      corrections += static_cast<std::uint64_t>(r.solver.slab_corrections);
    }
    EXPECT_GE(most_phases, 3);       // slabs, even and odd boundaries
    EXPECT_GT(most_contacts, 600u);  // dense: more force-carrying contacts than disks
#if defined(_OPENMP)
    EXPECT_EQ(most_threads, std::min(threads, processors_available()));
#endif
    return state_hash(world);
  };
  const std::uint64_t one = hash(1);
  const std::uint64_t corrections_one = corrections;
  EXPECT_GT(corrections_one, 0u);   // the slab correction ran
  EXPECT_EQ(profile.total(), 0.0);  // nothing timed unless asked
  const std::vector<std::size_t> woken_one = woken;
  EXPECT_GT(*std::max_element(woken_one.begin(), woken_one.end()), 0u);  // rows did wake
  const std::vector<double> residuals_one = residuals;
  EXPECT_GT(residuals_one.front(), 0.0);
  CDSHEAR_SKIP_IF_ONE_PROCESSOR();
  EXPECT_EQ(hash(2), one);
  EXPECT_EQ(corrections, corrections_one);
  EXPECT_EQ(woken, woken_one);
  EXPECT_EQ(residuals, residuals_one);  // bit for bit: the check adds its chunks in order
  EXPECT_EQ(hash(3), one);
  EXPECT_EQ(residuals, residuals_one);
  // Timing the solver's stages (cdshear_bench --profile) changes no result; the stages it
  // fills lie within the step's solve stage.
  EXPECT_EQ(hash(2, true), one);
  EXPECT_GT(profile.set_up, 0.0);
  EXPECT_GT(profile.sweeps, 0.0);
  EXPECT_GT(profile.convergence, 0.0);
  EXPECT_GT(profile.mix, 0.0);
  EXPECT_GT(profile.write_back, 0.0);
  EXPECT_LE(profile.total(), solve_seconds);
}

TEST(Determinism, CompliantShearedDenseBoxGivesTheSameStateOnAnyNumberOfThreads) {
  // The same box with a normal compliance (solver.normal_compliance): the compliant update
  // scales each row's old impulse and its w_nn (nlgs_solver.cpp, update_row), the velocity
  // residual adds kappa w_nn R_n, and the slab correction stands aside; none of it may depend on
  // how the rows are shared among the threads.
  CDSHEAR_SKIP_IF_ONE_PROCESSOR();
  const testing::ShearedBox box = testing::sheared_dense_box(600, 12.0, 0.5);
  ASSERT_TRUE(box.dense);
  std::vector<double> residuals;  // each step's RMS e of the force-carrying contacts
  const auto hash = [&](int threads, double compliance) {
    World world = box.world;
    ContactDynamics dynamics = box.dynamics;
    StepOptions o = sheared_box_options(threads);
    o.solver.normal_compliance = compliance;
    residuals.clear();
    double most_overlap = 0.0;
    for (int k = 0; k < 100; ++k) {
      const StepReport r = dynamics.step(world, o);
      EXPECT_FALSE(r.blown_up);
      residuals.push_back(r.velocity_residual.rms_carrying);
      most_overlap = std::max(most_overlap, r.max_overlap);
    }
    EXPECT_GT(most_overlap, 0.0);
    return state_hash(world);
  };
  const std::uint64_t one = hash(1, 0.01);
  const std::vector<double> residuals_one = residuals;
  EXPECT_EQ(hash(2, 0.01), one);
  EXPECT_EQ(residuals, residuals_one);
  EXPECT_EQ(hash(3, 0.01), one);
  EXPECT_NE(hash(1, 0.0), one);  // the compliance is another step
}

TEST(Determinism, InterleavedRunsDoNotInfluenceEachOther) {
  // Two simulations stepped alternately (no shared hidden state) end where a lone one does.
  testing::Simulation a(falling_box(), options(1)), b(falling_box(), options(1));
  for (int k = 0; k < kSteps; ++k) {
    a.run(1);
    b.run(1);
  }
  EXPECT_EQ(state_hash(a.world), state_hash(b.world));
  EXPECT_EQ(state_hash(a.world), run_hash(1));
}

TEST(Determinism, ContactOrderSeedChangesTheHash) {
  // Another seed gives another Gauss-Seidel order; the solver stops at a tolerance, not at the
  // exact solution, so the trajectories differ in the last digits and the hash must see it.
  // The run must have had multi-contact steps for the order to matter.
  testing::Simulation sim(falling_box(), options(1));
  sim.run(kSteps);
  int multi = 0;
  for (const StepReport& r : sim.reports) multi += r.solver.active_contacts > 1;
  ASSERT_GT(multi, 100);
  const std::uint64_t h1 = state_hash(sim.world);
  EXPECT_NE(run_hash(2), h1);
  EXPECT_NE(run_hash(3), h1);
  EXPECT_NE(run_hash(1, ContactOrder::kColoured), h1);
}

TEST(Determinism, StateHashSeesOneBitOfAnyField) {
  const World w = build_world(falling_box());
  const std::uint64_t h = state_hash(w);
  auto flipped = [](double x) { return std::nextafter(x, 1e300); };
  World v = w;
  v.disks.velocity[37].y = flipped(v.disks.velocity[37].y);
  EXPECT_NE(state_hash(v), h);
  World p = w;
  p.disks.position[79].x = flipped(p.disks.position[79].x);
  EXPECT_NE(state_hash(p), h);
  World o = w;
  o.disks.omega[0] = flipped(o.disks.omega[0]);
  EXPECT_NE(state_hash(o), h);
  World i = w;
  i.disks.image[3] += 1;
  EXPECT_NE(state_hash(i), h);
  World wall = w;
  wall.walls[2].point.x = flipped(wall.walls[2].point.x);
  EXPECT_NE(state_hash(wall), h);
  EXPECT_EQ(state_hash(World(w)), h);  // a copy hashes equal
}

TEST(Determinism, WeightedSharesCoverTheItemsInOrderAndBalanceTheWeight) {
  // weighted_share_of splits the passes over every group (groups_share) and detection's runs of
  // disks: the shares must be consecutive, cover every item once, and carry about equal weight.
  // Weights shaped like the coloured order's groups: heavy slabs first, light boundaries after,
  // and a few empty groups.
  std::vector<std::size_t> weights;
  for (std::size_t g = 0; g < 50; ++g) weights.push_back(140 + (g * 37) % 23);
  for (std::size_t g = 0; g < 49; ++g) weights.push_back(g % 7 == 0 ? 0 : 20 + g % 5);
  weights.push_back(0);  // an empty serial group
  std::vector<std::size_t> start{0};
  for (const std::size_t w : weights) start.push_back(start.back() + w);
  const std::size_t total = start.back();
  const std::size_t heaviest = *std::max_element(weights.begin(), weights.end());
  for (std::size_t size = 1; size <= 5; ++size) {
    std::size_t expected_first = 0;
    for (std::size_t t = 0; t < size; ++t) {
      const Share s = weighted_share_of(start, {t, size});
      EXPECT_EQ(s.first, expected_first) << size << " threads, thread " << t;
      EXPECT_LE(s.first, s.last);
      const std::size_t weight = start[s.last] - start[s.first];
      EXPECT_LE(weight, total / size + heaviest) << size << " threads, thread " << t;
      EXPECT_GE(weight + heaviest, total / size) << size << " threads, thread " << t;
      expected_first = s.last;
    }
    EXPECT_EQ(expected_first, weights.size()) << size << " threads";
  }
  // Splitting by count instead (share_of, as an omp for over the groups does) gives the first of
  // two threads nearly all the weight: the case this split exists for.
  const Share by_count = share_of(weights.size(), {0, 2});
  const Share by_weight = weighted_share_of(start, {0, 2});
  EXPECT_GT(start[by_count.last] - start[by_count.first], 0.8 * static_cast<double>(total));
  EXPECT_LT(start[by_weight.last] - start[by_weight.first], 0.6 * static_cast<double>(total));
}

}  // namespace
}  // namespace cdshear
