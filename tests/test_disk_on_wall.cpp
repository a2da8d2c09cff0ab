// A disk on a flat wall under tilted gravity: rolling without slip when tan(theta) < 3 mu,
// sliding with kinetic friction when tan(theta) > 3 mu (uniform disk, J = m r^2 / 2).
//
// Geometry: a fixed wall along the x axis (normal +y), gravity g (sin theta, -cos theta). The
// contact tangent is t = perp(n) = (-1, 0), so the tangential relative velocity is
// u_t = -v_x - r w (contact.hpp): rolling without slip is v_x = -w r.
//
// Why the checks can be tight: the disk starts resting on the wall (gap 0) and the only contact
// has w_nt = 0, so every step's contact problem is solved exactly in one sweep (the second sweep
// changes nothing and stops the solver). The Moreau-Jean step then gives exactly
// v_k = a k dt (constant acceleration) and x_k = a dt^2 k (k+1) / 2 (semi-implicit Euler), so
// velocities match the analytic a t up to round-off, and positions match a t^2 / 2 up to the
// integrator's known first-order term a t dt / 2.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <ostream>
#include <string>

#include "test_support.hpp"

namespace cdshear {
namespace {

using testing::disk;
using testing::fixed_wall;

constexpr double kG = 1.0, kR = 0.5, kDt = 1e-3;
constexpr int kSteps = 1000;  // one time unit

struct Outcome {
  double accel_along, angular_accel, vx, omega, x, y;
  Vec2 wall_force;
  double max_gap_drift = 0.0;
};

/// Runs a disk resting on a wall of friction `mu` under gravity tilted by `theta`; if `tilt_wall`
/// the wall is tilted instead (gravity straight down) and the results are expressed in the
/// wall's frame. Returns accelerations measured as final velocity / time.
Outcome run_incline(double theta, double mu, bool tilt_wall) {
  SceneDefinition s;
  s.friction_disk_disk = 0.0;
  // Wall frame: down-slope direction e and wall normal n.
  Vec2 e{1.0, 0.0}, n{0.0, 1.0};
  if (tilt_wall) {
    // The wall descends towards +x: its normal is (sin theta, cos theta).
    e = {std::cos(theta), -std::sin(theta)};
    n = {std::sin(theta), std::cos(theta)};
    s.gravity = {0.0, -kG};
  } else {
    s.gravity = {kG * std::sin(theta), -kG * std::cos(theta)};
  }
  s.walls.push_back(fixed_wall("incline", {0.0, 0.0}, n, mu));
  s.disks.push_back(disk(kR * n, kR));  // touching, gap 0
  StepOptions o;
  o.dt = kDt;
  testing::Simulation sim(s, o);
  Outcome out{};
  sim.run(kSteps, [&](const testing::Simulation& sm, const StepReport& r) {
    EXPECT_FALSE(r.solver.hit_cap);
    const double height = dot(sm.world.disks.position[0], n) - kR;
    out.max_gap_drift = std::max(out.max_gap_drift, std::abs(height));
  });
  const double t = sim.world.time;
  const Vec2 v = sim.world.disks.velocity[0];
  const Vec2 p = sim.world.disks.position[0];
  out.vx = dot(v, e);
  out.omega = sim.world.disks.omega[0];
  out.accel_along = out.vx / t;
  out.angular_accel = out.omega / t;
  out.x = dot(p, e);
  out.y = dot(p, n);
  out.wall_force = sim.world.walls[0].contact_force;
  return out;
}

/// Position of semi-implicit Euler under constant acceleration a after k steps.
double euler_position(double a, int k) {
  return a * kDt * kDt * k * (k + 1) / 2.0;
}

struct Case {
  double theta_deg, mu;
  bool tilt_wall;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << "theta " << c.theta_deg << " deg, mu " << c.mu << (c.tilt_wall ? ", tilted wall" : "");
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  const Case& c = info.param;
  return std::string("theta") + (c.theta_deg < 0 ? "minus" : "") +
         std::to_string(static_cast<int>(std::abs(c.theta_deg))) + "_mu" +
         std::to_string(static_cast<int>(std::lround(c.mu * 100))) + "pct" +
         (c.tilt_wall ? "_tilted_wall" : "_tilted_gravity");
}

class Rolling : public ::testing::TestWithParam<Case> {};

TEST_P(Rolling, AccelerationIsTwoThirdsGSinThetaWithoutSlip) {
  const Case c = GetParam();
  const double theta = c.theta_deg * std::numbers::pi / 180.0;
  ASSERT_LT(std::abs(std::tan(theta)), 3.0 * c.mu);  // the rolling regime
  const Outcome o = run_incline(theta, c.mu, c.tilt_wall);
  const double a = 2.0 / 3.0 * kG * std::sin(theta);
  const double t = kSteps * kDt;
  // Round-off accumulated over 1000 steps of O(1) numbers: ~1e-13 relative; 1e-10 is a margin.
  EXPECT_NEAR(o.accel_along, a, 1e-10 * kG);
  // Rolling without slip: v = -w r exactly (the contact sticks: u_t = 0 to round-off).
  EXPECT_NEAR(o.vx, -o.omega * kR, 1e-10 * kG * t);
  EXPECT_NEAR(o.x, euler_position(a, kSteps), 1e-10);
  // Against the continuous solution a t^2 / 2 the only difference is the integrator's a t dt / 2.
  EXPECT_NEAR(o.x, 0.5 * a * t * t, 0.5 * std::abs(a) * t * kDt * (1.0 + 1e-6) + 1e-12);
  // The disk stays on the wall: Signorini with gap 0 keeps it exactly there up to round-off.
  EXPECT_LT(o.max_gap_drift, 1e-12);
  EXPECT_NEAR(o.y, kR, 1e-12);
  // Wall force (what the disk exerts on the wall) balances gravity and m a along the slope:
  // normal m g cos(theta) into the wall, tangential m g sin(theta) / 3 (static friction).
  const double m = testing::disk_mass(kR);
  if (!c.tilt_wall) {
    EXPECT_NEAR(o.wall_force.y, -m * kG * std::cos(theta), 1e-10);
    EXPECT_NEAR(o.wall_force.x, m * kG * std::sin(theta) / 3.0, 1e-10);
    EXPECT_LE(std::abs(o.wall_force.x), c.mu * std::abs(o.wall_force.y));
  }
}

INSTANTIATE_TEST_SUITE_P(DiskOnWall, Rolling,
                         ::testing::Values(Case{30.0, 0.5, false}, Case{-30.0, 0.5, false},
                                           Case{40.0, 0.3, false}, Case{25.0, 0.5, true},
                                           Case{56.0, 0.5, false}),
                         case_name);

class Sliding : public ::testing::TestWithParam<Case> {};

TEST_P(Sliding, AccelerationIsGSinThetaMinusMuGCosTheta) {
  const Case c = GetParam();
  const double theta = c.theta_deg * std::numbers::pi / 180.0;
  ASSERT_GT(std::abs(std::tan(theta)), 3.0 * c.mu);  // the sliding regime
  const Outcome o = run_incline(theta, c.mu, c.tilt_wall);
  const double sign = theta > 0 ? 1.0 : -1.0;
  const double a = kG * (std::sin(theta) - sign * c.mu * std::cos(theta));
  // Friction -sign mu m g cos(theta) acts at the contact point (0, -r) from the centre, so the
  // torque is -sign r mu m g cos(theta) and dw/dt = -sign 2 mu g cos(theta) / r (clockwise for a
  // disk sliding towards +x, the same sense as rolling).
  const double alpha = -sign * 2.0 * c.mu * kG * std::cos(theta) / kR;
  const double t = kSteps * kDt;
  // Same round-off argument as for rolling.
  EXPECT_NEAR(o.accel_along, a, 1e-10 * kG);
  EXPECT_NEAR(o.angular_accel, alpha, 1e-10 * kG / kR);
  EXPECT_NEAR(o.x, euler_position(a, kSteps), 1e-10);
  EXPECT_NEAR(o.x, 0.5 * a * t * t, 0.5 * std::abs(a) * t * kDt * (1.0 + 1e-6) + 1e-12);
  // It really slips: the slip velocity v + w r grows like (a + alpha r) t
  // = g (sin(theta) - 3 mu cos(theta)) t, with the sign of the motion, and is far above round-off
  // (1e-13) even at 57 degrees, just past the threshold (0.02 there).
  EXPECT_NEAR(o.vx + o.omega * kR, (a + alpha * kR) * t, 1e-10);
  EXPECT_GT(sign * (o.vx + o.omega * kR), 1e-6);
  EXPECT_LT(o.max_gap_drift, 1e-12);
  const double m = testing::disk_mass(kR);
  if (!c.tilt_wall) {
    // Kinetic friction on the wall: exactly on the Coulomb cone, along the motion.
    EXPECT_NEAR(o.wall_force.y, -m * kG * std::cos(theta), 1e-10);
    EXPECT_NEAR(o.wall_force.x, sign * c.mu * m * kG * std::cos(theta), 1e-10);
  }
}

INSTANTIATE_TEST_SUITE_P(DiskOnWall, Sliding,
                         ::testing::Values(Case{60.0, 0.5, false}, Case{-60.0, 0.5, false},
                                           Case{45.0, 0.3, false}, Case{35.0, 0.2, true},
                                           Case{57.0, 0.5, false}),
                         case_name);

TEST(DiskOnWall, FrictionlessWallGivesFreeSlidingWithoutSpin) {
  const double theta = 20.0 * std::numbers::pi / 180.0;
  const Outcome o = run_incline(theta, 0.0, false);
  EXPECT_NEAR(o.accel_along, kG * std::sin(theta), 1e-10);
  EXPECT_EQ(o.omega, 0.0);
}

TEST(MovableIncline, DiskRollsDownAWedgeThatSlidesAway) {
  // A disk (mass m, J = m r^2 / 2) rolling without slip on an incline of angle theta whose wall
  // is free along x (mass M, no applied force) and fixed along y: the classic cylinder on a
  // movable wedge. With s the distance rolled down the incline and X the wall's position,
  // Lagrange's equations give
  //   (M + m) X'' + m s'' cos(theta) = 0,   m X'' cos(theta) + (3/2) m s'' = m g sin(theta),
  // so s'' = g sin(theta) / (3/2 - m cos^2(theta) / (M + m)) and X'' = -m s'' cos(theta) / (M + m).
  // The wall's inverse mass is (1/M, 0) while the contact frame is tilted, so the contact's
  // Delassus matrix has W_nt = n_x t_x / M != 0: a stepper test of the off-diagonal term.
  const double theta = 30.0 * std::numbers::pi / 180.0, mu = 1.0;
  const Vec2 n{std::sin(theta), std::cos(theta)};
  SceneDefinition s;
  s.gravity = {0.0, -kG};
  Wall wedge = fixed_wall("wedge", {0.0, 0.0}, n, mu);
  wedge.mode_x = AxisMode::kFree;
  const double m = testing::disk_mass(kR), M = 2.0 * m;
  wedge.mass = M;
  s.walls.push_back(wedge);
  s.disks.push_back(disk(kR * n, kR));
  StepOptions o;
  o.dt = kDt;
  o.solver.alpha = 1e-14;
  o.solver.max_sweeps = 1000;
  testing::Simulation sim(s, o);
  int largest_sweeps = 0;
  sim.run(kSteps, [&](const testing::Simulation&, const StepReport& r) {
    largest_sweeps = std::max(largest_sweeps, r.solver.sweeps);
  });
  ASSERT_FALSE(sim.last().blown_up) << sim.last().problem;
  // One contact, solved exactly by the 2x2 local solve with the right W: the second sweep
  // changes nothing. (A wrong W_nt converges to the same answer, but slowly.)
  EXPECT_LE(largest_sweeps, 2);
  const double t = kSteps * kDt;
  const double s_dd =
      kG * std::sin(theta) / (1.5 - m * std::cos(theta) * std::cos(theta) / (M + m));
  const double x_dd = -m * s_dd * std::cos(theta) / (M + m);
  // Disk velocity (X' + s' cos, -s' sin): s' from its vertical part.
  const double s_d = -sim.world.disks.velocity[0].y / std::sin(theta);
  EXPECT_NEAR(s_d / t, s_dd, 1e-6 * s_dd);
  EXPECT_NEAR(sim.world.walls[0].velocity.x / t, x_dd, 1e-6 * std::abs(x_dd));
  EXPECT_EQ(sim.world.walls[0].velocity.y, 0.0);
  // Rolling: the contact point does not slide on the wall, w = -s' / r (clockwise going down).
  EXPECT_NEAR(sim.world.disks.omega[0], -s_d / kR, 1e-6 * s_d / kR);
}

/// A disk resting on a fixed floor after one step of gravity (its contact solved exactly), and
/// gravity then reversed: the next step pulls it away.
testing::Simulation disk_pulled_off_the_floor() {
  SceneDefinition s;
  s.gravity = {0.0, -kG};
  s.walls.push_back(fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0}, 0.5));
  s.disks.push_back(disk({0.0, kR}, kR));
  StepOptions o;
  o.dt = kDt;
  testing::Simulation sim(s, o);
  sim.run(1);
  sim.world.body_force = {0.0, kG};
  return sim;
}

// A disk resting on the wall (impulse R = m g dt from an exactly solved step) is pulled away by a
// reversed gravity, so the exact update opens the contact (R_exact = 0). The projected relaxed
// update max(0, R + omega (0 - R)) opens it too for every omega in [1, 2) the solver offers, and
// so does its one-stage form max(0, R - omega x) (local_solve.hpp): one sweep leaves R = 0
// exactly, where an update that relaxed the opening (a factor applied after the projection)
// would leave (1 - omega) R of the wrong sign or a remainder.
TEST(DiskOnWall, AnOpeningContactOpensInOneSweepAtEveryRelaxation) {
  const auto after_pull = [](double relaxation) {
    testing::Simulation sim = disk_pulled_off_the_floor();
    const auto resting = sim.contact(0, 1);
    EXPECT_TRUE(resting.has_value());
    const double r_rest = resting ? resting->impulse_n : 0.0;
    EXPECT_NEAR(r_rest, testing::disk_mass(kR) * kG * kDt, 1e-15);
    sim.options.solver.relaxation = relaxation;
    sim.options.solver.max_sweeps = 1;
    sim.options.solver.plain_finish = false;  // the over-relaxed sweep's own result
    sim.run(1);
    const auto pulled = sim.contact(0, 1);
    EXPECT_TRUE(pulled.has_value());
    return pulled ? pulled->impulse_n / r_rest : -1.0;
  };
  for (const double omega : {1.0, 1.3, 1.6, 1.9}) EXPECT_EQ(after_pull(omega), 0.0) << omega;
}

// A capped step in which every force vanishes (the resting disk pulled away, its one contact
// opened in the step's only sweep) reports a relative change of 1, the whole force, and is no
// blow-up. The residual was infinity (sum |dR| / sum |R| with sum |R| = 0), which the step took
// for a blow-up: a packing whose last contacts all opened in a capped step stopped there (the
// benchmark's densification of a loose system 7 did).
TEST(DiskOnWall, EveryForceVanishingInACappedStepIsNoBlowUp) {
  testing::Simulation sim = disk_pulled_off_the_floor();
  ASSERT_GT(sim.last().solver.active_contacts, 0);
  sim.options.solver.max_sweeps = 1;
  sim.run(1);
  const StepReport& pulled = sim.last();
  EXPECT_FALSE(pulled.blown_up) << pulled.problem;
  EXPECT_TRUE(pulled.solver.hit_cap);
  EXPECT_EQ(pulled.solver.active_contacts, 0);
  EXPECT_EQ(pulled.solver.residual, 1.0);
}

}  // namespace
}  // namespace cdshear
