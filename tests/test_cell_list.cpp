// The contact detector (ContactDetector: a neighbour list built with a cell list) against a
// brute-force all-pairs search over random configurations, periodic and not, for several
// margins, and a detector kept from step to step against a fresh one.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "contact_detection.hpp"
#include "scene.hpp"
#include "test_support.hpp"

namespace cdshear {
namespace {

using testing::disk;
using testing::fixed_wall;

struct Expected {
  ContactKey key;
  double gap;
};

/// Every disk pair (over the periodic images -1, 0, +1 of b) and disk-wall pair with gap below
/// the margin, in key order: the definition of the candidate set, without any cleverness.
std::vector<Expected> brute_force(const World& w, double margin) {
  std::vector<Expected> out;
  const std::size_t n = w.disks.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      for (int image = -1; image <= 1; ++image) {
        if (!w.domain.periodic_x && image != 0) continue;
        const Vec2 pj = w.disks.position[j] + Vec2{image * w.domain.length_x, 0.0};
        const double gap = length(pj - w.disks.position[i]) - w.disks.radius[i] - w.disks.radius[j];
        if (gap < margin)
          out.push_back({{static_cast<std::int32_t>(i), static_cast<std::int32_t>(j), image}, gap});
      }
    }
    for (std::size_t k = 0; k < w.walls.size(); ++k) {
      const double gap = wall_gap(w, i, w.walls[k]);
      if (gap < margin)
        out.push_back({{static_cast<std::int32_t>(i), static_cast<std::int32_t>(n + k), 0}, gap});
    }
  }
  std::sort(out.begin(), out.end(),
            [](const Expected& a, const Expected& b) { return a.key < b.key; });
  return out;
}

/// Random disks, overlaps allowed (detection must not care), radii in [0.35, 0.5].
SceneDefinition random_scene(std::mt19937_64& rng, bool periodic, double lx, double ly, int n) {
  std::uniform_real_distribution<double> ux(0.0, lx), uy(0.0, ly), ur(0.35, 0.5);
  SceneDefinition s;
  s.domain.periodic_x = periodic;
  s.domain.length_x = periodic ? lx : 0.0;
  s.overlap_tolerance = 1e9;  // a detection test: overlapping placements are fine
  for (int k = 0; k < n; ++k) {
    // Some disks exactly on or near the period edges, where images matter.
    double x = ux(rng);
    if (k % 17 == 0) x = 0.0;
    if (k % 19 == 0) x = std::nextafter(lx, 0.0);
    s.disks.push_back(disk({x, uy(rng)}, ur(rng)));
  }
  s.walls.push_back(fixed_wall("floor", {0.0, 0.3}, {0.0, 1.0}));
  // A tilted ceiling where x is not periodic (across a period a wall must lie along x).
  s.walls.push_back(fixed_wall("ceiling", {0.0, ly}, {periodic ? 0.0 : 0.3, -1.0}));
  return s;
}

void compare_with_brute_force(const World& world, double margin, const std::string& what) {
  ContactDetector detector;
  std::vector<Contact> found;
  detector.detect(world, margin, found);
  const std::vector<Expected> expected = brute_force(world, margin);
  ASSERT_EQ(found.size(), expected.size()) << what;
  for (std::size_t k = 0; k < found.size(); ++k) {
    ASSERT_EQ(found[k].key, expected[k].key) << what << " entry " << k;
    // Same geometry computed two ways (minimum image vs explicit image shift): a few ulps of
    // lengths of order 10 -> 1e-12 is ample and still far below any real gap difference.
    ASSERT_NEAR(found[k].gap, expected[k].gap, 1e-12) << what << " entry " << k;
  }
}

TEST(ContactDetection, MatchesBruteForceOnRandomConfigurations) {
  std::mt19937_64 rng(5);
  int total_pairs = 0, across_boundary = 0;
  // Periods from the smallest allowed (3 diameters: 1 or 2 cell columns, where neighbour columns
  // repeat) to many columns; margins from 0 to a third of a diameter.
  for (const bool periodic : {false, true}) {
    for (const double lx : {3.0, 4.1, 7.3, 15.0}) {
      for (const double margin : {0.0, 0.05, 0.3}) {
        for (int rep = 0; rep < 3; ++rep) {
          const int n = static_cast<int>(lx * 8.0 * 0.9);
          const World world = build_world(random_scene(rng, periodic, lx, 8.0, n));
          compare_with_brute_force(world, margin,
                                   "periodic " + std::to_string(periodic) + " lx " +
                                       std::to_string(lx) + " margin " + std::to_string(margin));
          for (const Expected& e : brute_force(world, margin)) {
            ++total_pairs;
            across_boundary += e.key.image_b != 0;
          }
        }
      }
    }
  }
  // The configurations must be dense enough to test something, including contacts across x = 0.
  EXPECT_GT(total_pairs, 5000);
  EXPECT_GT(across_boundary, 100);
}

/// 25 disks drifting along +x (so they cross x = L_x = 6) while they settle on a floor.
SceneDefinition drifting_scene() {
  SceneDefinition s;
  s.domain = {true, 6.0};
  s.gravity = {1.0, -0.2};
  s.walls.push_back(fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0}));
  RandomDisksSpec r;
  r.count = 25;
  r.region_min = {0.0, 0.0};
  r.region_max = {6.0, 6.0};
  r.seed = 4;
  s.random_disks.push_back(r);
  return s;
}

TEST(ContactDetection, MatchesBruteForceAfterWrapping) {
  // Disks that moved across the periodic boundary (positions wrapped by the step) keep being
  // found through the right image.
  testing::Simulation sim(drifting_scene(), StepOptions{});
  sim.options.dt = 0.005;
  std::int64_t crossings = 0;
  for (int k = 0; k < 20; ++k) {
    sim.run(5);
    compare_with_brute_force(sim.world, 0.05, "after step " + std::to_string(sim.world.step));
  }
  for (std::int64_t im : sim.world.disks.image) crossings += std::abs(im);
  EXPECT_GT(crossings, 0);
}

/// Two candidate lists, field by field and bit for bit, warm-start impulses included.
void expect_same_contacts(const std::vector<Contact>& got, const std::vector<Contact>& expected,
                          const std::string& what) {
  ASSERT_EQ(got.size(), expected.size()) << what;
  for (std::size_t k = 0; k < got.size(); ++k) {
    ASSERT_EQ(got[k].key, expected[k].key) << what << " entry " << k;
    ASSERT_EQ(got[k].gap, expected[k].gap) << what << " entry " << k;
    ASSERT_EQ(got[k].normal.x, expected[k].normal.x) << what << " entry " << k;
    ASSERT_EQ(got[k].normal.y, expected[k].normal.y) << what << " entry " << k;
    ASSERT_EQ(got[k].lever_a, expected[k].lever_a) << what << " entry " << k;
    ASSERT_EQ(got[k].lever_b, expected[k].lever_b) << what << " entry " << k;
    ASSERT_EQ(got[k].impulse_n, expected[k].impulse_n) << what << " entry " << k;
    ASSERT_EQ(got[k].impulse_t, expected[k].impulse_t) << what << " entry " << k;
  }
}

/// Candidates of `kept` (a detector that has seen earlier configurations, so may reuse its
/// neighbour list) against a fresh detector's, field by field and bit for bit, and against the
/// brute-force search.
void compare_kept_with_fresh(ContactDetector& kept, const World& world, double margin,
                             const std::string& what) {
  std::vector<Contact> reused, fresh;
  kept.detect(world, margin, reused);
  ContactDetector().detect(world, margin, fresh);
  expect_same_contacts(reused, fresh, what);
  compare_with_brute_force(world, margin, what);
}

TEST(ContactDetection, NeighbourListGivesTheCandidatesOfAFreshSearchAtEveryStep) {
  // Disks drifting along +x across the periodic boundary and falling onto the floor: one
  // detector kept from step to step (as in ContactDynamics) must find exactly what a fresh search
  // finds, whether it reuses its neighbour list or builds it again.
  testing::Simulation sim(drifting_scene(), StepOptions{});
  sim.options.dt = 0.005;
  ContactDetector kept;
  constexpr int kSteps = 300;
  for (int k = 0; k < kSteps; ++k) {
    sim.run(1);
    compare_kept_with_fresh(kept, sim.world, 0.05, "step " + std::to_string(sim.world.step));
  }
  // The disks moved by more than the skin (the list was built again) but most steps reused it.
  EXPECT_GT(kept.neighbour_builds(), 2u);
  EXPECT_LT(kept.neighbour_builds(), static_cast<std::uint64_t>(kSteps / 3));
}

TEST(ContactDetection, NeighbourListFindsEveryPairThatClosesIn) {
  // Each disk moves at its own velocity (random directions, up to 0.01 per step), so pairs keep
  // closing in and separating, across the periodic boundary too: the kept detector must find
  // each pair in the step where it comes within the margin.
  std::mt19937_64 rng(12);
  World world = build_world(random_scene(rng, true, 7.3, 8.0, 40));
  std::uniform_real_distribution<double> u(-0.007, 0.007);
  std::vector<Vec2> velocity(world.disks.size());
  for (Vec2& v : velocity) v = {u(rng), u(rng)};
  const double lx = world.domain.length_x;
  ContactDetector kept;
  constexpr int kSteps = 300;
  for (int k = 0; k < kSteps; ++k) {
    for (std::size_t i = 0; i < world.disks.size(); ++i) {
      Vec2& p = world.disks.position[i];
      p = p + velocity[i];
      p.x -= lx * std::floor(p.x / lx);
    }
    compare_kept_with_fresh(kept, world, 0.05, "step " + std::to_string(k));
  }
  EXPECT_GT(kept.neighbour_builds(), 10u);
  EXPECT_LT(kept.neighbour_builds(), static_cast<std::uint64_t>(kSteps / 2));
}

TEST(ContactDetection, GivesTheSameCandidatesAndWarmStartOnAnyNumberOfThreads) {
  // 2600 disks, so that two and three threads each get at least kMinDisksPerThread of them. The
  // previous step's contacts carry impulses made from their keys; after the disks move, every
  // thread count must give the one-thread list bit for bit, warm start included (each thread's
  // run of disks is warm-started from the middle of the previous list).
  std::mt19937_64 rng(21);
  World world = build_world(random_scene(rng, true, 40.0, 60.0, 2600));
  ASSERT_GE(world.disks.size(), 2 * ContactDetector::kMinDisksPerThread);
  std::vector<Contact> previous;
  ContactDetector().detect(world, 0.05, previous);
  for (Contact& c : previous) {
    c.impulse_n = 1.0 + c.key.body_a + 1e-4 * c.key.body_b;
    c.impulse_t = 0.5 * c.key.image_b - 1e-3 * c.key.body_a;
  }
  std::uniform_real_distribution<double> u(-0.01, 0.01);
  for (Vec2& p : world.disks.position) p = p + Vec2{u(rng), u(rng)};
  const double lx = world.domain.length_x;
  for (Vec2& p : world.disks.position) p.x -= lx * std::floor(p.x / lx);

  std::vector<Contact> one = previous;
  ContactDetector().detect(world, 0.05, one, 1);
  std::size_t carried = 0;
  for (const Contact& c : one) carried += c.impulse_n != 0.0;
  EXPECT_GT(carried, one.size() / 2);  // most contacts persist and are warm-started
  for (const int threads : {2, 3}) {
    std::vector<Contact> many = previous;
    ContactDetector().detect(world, 0.05, many, threads);
    expect_same_contacts(many, one, std::to_string(threads) + " threads");
  }
  compare_with_brute_force(world, 0.05, "2600 disks");
}

TEST(ContactDetection, NeighbourListIsBuiltAgainForAJumpAWiderMarginOrANewRadius) {
  std::mt19937_64 rng(11);
  World world = build_world(random_scene(rng, true, 7.3, 8.0, 40));
  ContactDetector kept;
  compare_kept_with_fresh(kept, world, 0.05, "first");
  compare_kept_with_fresh(kept, world, 0.05, "same configuration");
  EXPECT_EQ(kept.neighbour_builds(), 1u);
  compare_kept_with_fresh(kept, world, 0.0, "narrower margin");  // covered by the list
  EXPECT_EQ(kept.neighbour_builds(), 1u);
  compare_kept_with_fresh(kept, world, 0.3, "wider margin");
  EXPECT_EQ(kept.neighbour_builds(), 2u);
  world.disks.position[0] = world.disks.position[7] + Vec2{0.9, 0.0};  // a jump next to disk 7
  compare_kept_with_fresh(kept, world, 0.3, "after a jump");
  EXPECT_EQ(kept.neighbour_builds(), 3u);
  world.disks.radius[3] *= 1.5;
  compare_kept_with_fresh(kept, world, 0.3, "after a radius change");
  EXPECT_EQ(kept.neighbour_builds(), 4u);
}

TEST(ContactDetection, WarmStartKeepsImpulsesOfPersistingContacts) {
  SceneDefinition s;
  s.disks = {disk({1.0, 1.0}, 0.5), disk({2.0, 1.0}, 0.5), disk({5.0, 1.0}, 0.5)};
  const World world = build_world(s);
  std::vector<Contact> contacts(2);
  contacts[0].key = {0, 1, 0};  // persists
  contacts[0].impulse_n = 0.25;
  contacts[0].impulse_t = -0.125;
  contacts[1].key = {1, 2, 0};  // no longer a candidate
  contacts[1].impulse_n = 1.0;
  ContactDetector detector;
  detector.detect(world, 0.05, contacts);
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_EQ(contacts[0].key, (ContactKey{0, 1, 0}));
  EXPECT_EQ(contacts[0].impulse_n, 0.25);
  EXPECT_EQ(contacts[0].impulse_t, -0.125);
}

}  // namespace
}  // namespace cdshear
