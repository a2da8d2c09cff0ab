// Binary collisions of frictional disks in free space (no walls, no gravity): perfectly
// inelastic in the normal direction, Coulomb friction tangentially, and exact conservation of
// linear and angular momentum (about the origin, spin included).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <ostream>
#include <random>
#include <string>

#include "test_support.hpp"

namespace cdshear {
namespace {

using testing::disk;
using testing::disk_mass;

/// Sum of |m v| and of |m x cross v| + |J w|: the scales against which round-off in the momenta
/// is measured.
struct Scales {
  double p = 0.0, l = 0.0;
};
Scales momentum_scales(const World& w) {
  Scales s;
  for (std::size_t i = 0; i < w.disks.size(); ++i) {
    s.p += w.disks.mass[i] * length(w.disks.velocity[i]);
    s.l += w.disks.mass[i] * length(w.unwrapped_position(i)) * length(w.disks.velocity[i]) +
           w.disks.inertia[i] * std::abs(w.disks.omega[i]);
  }
  return s;
}

struct Conservation {
  double dp = 0.0, dl = 0.0;  // worst relative change over the run
  int active_steps = 0;       // steps with a force-carrying contact
};

/// Steps `sim` n times and records the worst change of linear and angular momentum. Round-off
/// only: each step adds and subtracts O(1) impulses and moves O(1) positions, so after a few
/// thousand steps the relative error is ~1e-13. The checks use 1e-12.
Conservation run_and_track(testing::Simulation& sim, int n) {
  const Vec2 p0 = linear_momentum(sim.world);
  const double l0 = angular_momentum(sim.world);
  const Scales sc = momentum_scales(sim.world);
  Conservation c;
  sim.run(n, [&](const testing::Simulation& s, const StepReport& r) {
    c.dp = std::max(c.dp, length(linear_momentum(s.world) - p0) / sc.p);
    c.dl = std::max(c.dl, std::abs(angular_momentum(s.world) - l0) / sc.l);
    c.active_steps += r.solver.active_contacts > 0;
  });
  return c;
}

TEST(Collisions, HeadOnIsPerfectlyInelastic) {
  // Unequal disks on the x axis, closing at speed 2 from a gap that does not close at a step
  // boundary (the impact straddles two steps).
  const double ra = 0.5, rb = 0.4, va = 1.0, vb = -1.0;
  SceneDefinition s;
  s.disks = {disk({-1.0, 0.0}, ra, {va, 0.0}), disk({1.0123, 0.0}, rb, {vb, 0.0})};
  testing::Simulation sim(s, StepOptions{});
  const Conservation c = run_and_track(sim, 1000);
  ASSERT_GT(c.active_steps, 0);  // they did collide
  const Vec2 v1 = sim.world.disks.velocity[0], v2 = sim.world.disks.velocity[1];
  // Perfectly inelastic: no normal relative velocity afterwards; both move with the centre of
  // mass. Round-off of O(1) velocities: 1e-12.
  EXPECT_NEAR(v1.x - v2.x, 0.0, 1e-12);
  const double ma = disk_mass(ra), mb = disk_mass(rb);
  const double v_cm = (ma * va + mb * vb) / (ma + mb);
  EXPECT_NEAR(v1.x, v_cm, 1e-12);
  EXPECT_NEAR(v2.x, v_cm, 1e-12);
  EXPECT_EQ(v1.y, 0.0);
  EXPECT_EQ(sim.world.disks.omega[0], 0.0);  // central impact: no friction mobilised
  EXPECT_LT(c.dp, 1e-12);
  EXPECT_LT(c.dl, 1e-12);
  // They end touching, neither overlapping (beyond round-off) nor apart.
  const double gap = length(sim.world.disks.position[1] - sim.world.disks.position[0]) - ra - rb;
  EXPECT_NEAR(gap, 0.0, 1e-12);
  // Kinetic energy lost: exactly the relative-motion part, m_eff (va - vb)^2 / 2.
  const double e_lost = 0.5 * ma * mb / (ma + mb) * (va - vb) * (va - vb);
  EXPECT_NEAR(kinetic_energy(sim.world), 0.5 * ma * va * va + 0.5 * mb * vb * vb - e_lost, 1e-12);
}

TEST(Collisions, HeadOnWithSpinsConservesMomentum) {
  // Spinning disks: friction acts during the impact, the disks gain transverse velocities.
  SceneDefinition s;
  s.friction_disk_disk = 0.5;
  s.disks = {disk({-1.0, 0.0}, 0.5, {1.0, 0.0}, 2.0), disk({1.0123, 0.0}, 0.4, {-1.0, 0.0}, -1.0)};
  testing::Simulation sim(s, StepOptions{});
  const Conservation c = run_and_track(sim, 1000);
  ASSERT_GT(c.active_steps, 0);
  EXPECT_LT(c.dp, 1e-12);
  EXPECT_LT(c.dl, 1e-12);
  EXPECT_NE(sim.world.disks.velocity[0].y, 0.0);  // friction did act
}

TEST(Collisions, ObliqueWithFrictionConservesMomentum) {
  const double ra = 0.5, rb = 0.4, u0 = 2.0;
  for (const double offset : {0.1, 0.3, 0.42}) {
    SceneDefinition s;
    s.friction_disk_disk = 0.5;
    s.disks = {disk({-1.0, offset}, ra, {1.0, 0.0}, 2.0),
               disk({1.0123, -offset}, rb, {-1.0, 0.0}, -1.0)};
    testing::Simulation sim(s, StepOptions{});
    const double e0 = kinetic_energy(sim.world);
    Vec2 last_normal;
    double largest_friction_ratio = 0.0;
    const Conservation c = [&] {
      Conservation out;
      const Vec2 p0 = linear_momentum(sim.world);
      const double l0 = angular_momentum(sim.world);
      const Scales sc = momentum_scales(sim.world);
      sim.run(1500, [&](const testing::Simulation& sm, const StepReport& r) {
        out.dp = std::max(out.dp, length(linear_momentum(sm.world) - p0) / sc.p);
        out.dl = std::max(out.dl, std::abs(angular_momentum(sm.world) - l0) / sc.l);
        out.active_steps += r.solver.active_contacts > 0;
        for (const Contact& k : sm.dynamics.contacts()) {
          if (k.impulse_n <= 0.0) continue;
          last_normal = k.normal;
          largest_friction_ratio =
              std::max(largest_friction_ratio, std::abs(k.impulse_t) / k.impulse_n);
        }
      });
      return out;
    }();
    SCOPED_TRACE("offset " + std::to_string(offset));
    ASSERT_GT(c.active_steps, 0);
    // Linear and angular momentum (about the origin, spins included): round-off only.
    EXPECT_LT(c.dp, 1e-12);
    EXPECT_LT(c.dl, 1e-12);
    // Friction was mobilised and stayed in the Coulomb cone.
    EXPECT_GT(largest_friction_ratio, 0.1);
    EXPECT_LE(largest_friction_ratio, 0.5 * (1.0 + 1e-12));
    EXPECT_LT(kinetic_energy(sim.world), e0);
    // After the impact the normal relative velocity along the last contact normal is what
    // closes that step's remaining gap, -g/dt, where g is opened by the tangential sliding of
    // the previous step: g <= (u dt)^2 / (2 D) with D = ra + rb and u <= u0 the relative speed.
    // So |u_n| <= dt u0^2 / (2 D); we allow twice that (measured: up to 1.6e-3 for 2.2e-3).
    const double dt = sim.options.dt;
    const Vec2 du = sim.world.disks.velocity[0] - sim.world.disks.velocity[1];
    EXPECT_LE(std::abs(dot(du, last_normal)), dt * u0 * u0 / (ra + rb));
    // And the disks separated without overlap.
    EXPECT_LT(sim.largest_overlap(), 1e-9);
  }
}

struct Touching {
  double phi_deg, omega_a;
  bool sticks;
};

void PrintTo(const Touching& c, std::ostream* os) {
  *os << "phi " << c.phi_deg << " deg, omega_a " << c.omega_a
      << (c.sticks ? ", sticks" : ", slides");
}

class TouchingImpact : public ::testing::TestWithParam<Touching> {};

TEST_P(TouchingImpact, MatchesTheImpulseSolution) {
  // Disks touching (gap 0) and approaching: the whole impact happens in one step with gap 0 and
  // a single contact with w_nt = 0, so the result is the exact impulse solution:
  //   P_n = -u_n0 / w_nn, w_nn = 1/ma + 1/mb;
  //   R_t = -u_t0 / w_tt if that is within mu P_n (stick), else -sign(u_t0) mu P_n (slide),
  //   w_tt = w_nn + ra^2/Ja + rb^2/Jb.
  const Touching c = GetParam();
  const double ra = 0.5, rb = 0.4, mu = 0.5;
  const double phi = c.phi_deg * std::numbers::pi / 180.0;
  const Vec2 e{std::cos(phi), std::sin(phi)};  // from a to b
  const Vec2 va{1.0, 0.2}, vb{-1.0, -0.1};
  const double wa = c.omega_a, wb = -1.0;
  SceneDefinition s;
  s.friction_disk_disk = mu;
  s.disks = {disk({0.3, -0.2}, ra, va, wa), disk(Vec2{0.3, -0.2} + (ra + rb) * e, rb, vb, wb)};
  testing::Simulation sim(s, StepOptions{});

  const double ma = disk_mass(ra), mb = disk_mass(rb);
  const double ja = ma * ra * ra / 2, jb = mb * rb * rb / 2;
  const Vec2 n = -e, t = perp(n);  // contact.hpp: n from b to a
  const double un0 = dot(va - vb, n), ut0 = dot(va - vb, t) - ra * wa - rb * wb;
  ASSERT_LT(un0, 0.0);  // approaching
  const double wnn = 1 / ma + 1 / mb, wtt = wnn + ra * ra / ja + rb * rb / jb;
  const double pn = -un0 / wnn;
  double rt = -ut0 / wtt;
  const bool sticks = std::abs(rt) <= mu * pn;
  ASSERT_EQ(sticks, c.sticks) << "the case does not exercise the intended regime";
  if (!sticks) rt = -std::copysign(mu * pn, ut0);
  const Vec2 impulse = pn * n + rt * t;

  const Conservation cons = run_and_track(sim, 20);
  // Exact up to round-off of a few O(1) operations: 1e-12.
  const Disks& d = sim.world.disks;
  EXPECT_NEAR(d.velocity[0].x, va.x + impulse.x / ma, 1e-12);
  EXPECT_NEAR(d.velocity[0].y, va.y + impulse.y / ma, 1e-12);
  EXPECT_NEAR(d.velocity[1].x, vb.x - impulse.x / mb, 1e-12);
  EXPECT_NEAR(d.velocity[1].y, vb.y - impulse.y / mb, 1e-12);
  EXPECT_NEAR(d.omega[0], wa - ra * rt / ja, 1e-12);
  EXPECT_NEAR(d.omega[1], wb - rb * rt / jb, 1e-12);
  // Post-impact relative velocity at the contact: u_n = 0; u_t = 0 if sticking, else reduced.
  const double un1 = dot(d.velocity[0] - d.velocity[1], n);
  const double ut1 = dot(d.velocity[0] - d.velocity[1], t) - ra * d.omega[0] - rb * d.omega[1];
  EXPECT_NEAR(un1, 0.0, 1e-12);
  if (sticks) {
    EXPECT_NEAR(ut1, 0.0, 1e-12);
  } else {
    EXPECT_NEAR(ut1, ut0 - std::copysign(mu * pn * wtt, ut0), 1e-12);
    EXPECT_GT(ut1 * ut0, 0.0);  // still sliding the same way
  }
  EXPECT_LT(cons.dp, 1e-12);
  EXPECT_LT(cons.dl, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Collisions, TouchingImpact,
                         ::testing::Values(Touching{20.0, 0.0, true}, Touching{20.0, 10.0, false},
                                           Touching{-35.0, -12.0, false},
                                           Touching{60.0, 0.5, true}),
                         [](const ::testing::TestParamInfo<Touching>& info) {
                           const Touching& c = info.param;
                           return std::string("phi") + (c.phi_deg < 0 ? "minus" : "") +
                                  std::to_string(static_cast<int>(std::abs(c.phi_deg))) +
                                  (c.sticks ? "_sticks" : "_slides");
                         });

TEST(Collisions, ManyDiskClusterConservesMomentum) {
  // 36 disks converging on the origin: many simultaneous contacts solved by Gauss-Seidel, which
  // conserves momentum sweep by sweep (every update applies +R and -R at one point), whether or
  // not it has converged.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-0.3, 0.3), ur(0.4, 0.5);
  SceneDefinition s;
  s.friction_disk_disk = 0.5;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      const Vec2 p{1.1 * (i - 2.5), 1.1 * (j - 2.5) + 0.3};
      s.disks.push_back(disk(p, ur(rng), Vec2{u(rng), u(rng)} - 0.3 * p, 3.0 * u(rng)));
    }
  StepOptions o;
  o.dt = 2e-3;
  testing::Simulation sim(s, o);
  const Conservation c = run_and_track(sim, 2000);
  EXPECT_GT(c.active_steps, 100);
  EXPECT_LT(c.dp, 1e-12);
  EXPECT_LT(c.dl, 1e-12);
}

}  // namespace
}  // namespace cdshear
