// Unit and property tests of solve_local (local_solve.hpp), the exact 2x2 frictional contact
// solution used by every Gauss-Seidel update, and of the decoupled update forms the solver
// computes instead (decoupled_update, over-relaxed in one stage, and relax_and_project).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>

#include "local_solve.hpp"

namespace cdshear {
namespace {

struct Velocity {
  double n, t;
};

Velocity end_velocity(const LocalProblem& p, const LocalSolution& s) {
  return {p.b_n + p.w_nn * s.r_n + p.w_nt * s.r_t, p.b_t + p.w_nt * s.r_n + p.w_tt * s.r_t};
}

/// Checks Signorini and Coulomb (with sliding direction) for a candidate solution. `tol` is the
/// relative round-off allowance: velocities are compared with tol * (|b| + |W| |R|), impulses
/// with tol * |R|. Returns an empty string when every condition holds, else what failed.
std::string violated(const LocalProblem& p, double r_n, double r_t, double tol) {
  const LocalSolution s{r_n, r_t, LocalStatus::kSticking};
  const Velocity u = end_velocity(p, s);
  const double r_scale = std::hypot(r_n, r_t);
  const double w_scale = std::abs(p.w_nn) + std::abs(p.w_nt) + std::abs(p.w_tt);
  const double u_tol = tol * (std::hypot(p.b_n, p.b_t) + w_scale * r_scale);
  const double r_tol = tol * r_scale;
  if (r_n < 0.0) return "R_n < 0";
  if (u.n < -u_tol) return "u_n < 0 (interpenetration)";
  if (r_n > r_tol && std::abs(u.n) > u_tol) return "R_n > 0 but u_n != 0";
  if (std::abs(r_t) > p.mu * r_n + r_tol) return "outside the Coulomb cone";
  const bool inside = std::abs(r_t) < p.mu * r_n - r_tol;
  if (inside && std::abs(u.t) > u_tol) return "inside the cone but u_t != 0";
  if (!inside && r_n > r_tol) {
    // On the edge: R_t = -s mu R_n requires s u_t >= 0 (friction opposes sliding).
    const double s_dir = r_t < 0.0 ? 1.0 : -1.0;
    if (p.mu > 0.0 && s_dir * u.t < -u_tol) return "friction does not oppose sliding";
  }
  return {};
}

std::string describe(const LocalProblem& p, const LocalSolution& s) {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "W=[%.17g %.17g; %.17g %.17g] b=(%.17g, %.17g) mu=%.17g -> R=(%.17g, %.17g) "
                "status %d",
                p.w_nn, p.w_nt, p.w_nt, p.w_tt, p.b_n, p.b_t, p.mu, s.r_n, s.r_t,
                static_cast<int>(s.status));
  return buf;
}

// Round-off allowance of the checks: the solution costs a handful of flops, each with relative
// error 1e-16, amplified by at most the condition number of W (kept below 1e4 in the random
// problems). 1e-10 leaves a wide margin yet is far below the O(1) violations a wrong branch gives.
constexpr double kTol = 1e-10;

// A disk-disk contact of two unit-radius disks of mass 1 (J = 1/2): w_nn = 2, w_tt = 2 + 2 * 2.
constexpr double kWnn = 2.0, kWtt = 6.0;

TEST(LocalSolve, SeparatesWhenApproachIsNotClosingTheGap) {
  for (const double b_n : {0.0, 1e-12, 0.5}) {
    const LocalProblem p{kWnn, 0.0, kWtt, b_n, 3.0, 0.5};
    const LocalSolution s = solve_local(p);
    EXPECT_EQ(s.status, LocalStatus::kSeparated);
    EXPECT_EQ(s.r_n, 0.0);
    EXPECT_EQ(s.r_t, 0.0);
  }
}

TEST(LocalSolve, SticksInsideTheCone) {
  // R = -W^-1 b = (0.5, -0.2/6): |R_t| = 0.033 < mu R_n = 0.25.
  const LocalProblem p{kWnn, 0.0, kWtt, -1.0, 0.2, 0.5};
  const LocalSolution s = solve_local(p);
  EXPECT_EQ(s.status, LocalStatus::kSticking);
  // Exact up to the round-off of one division (1e-16 relative): 1e-14 absolute on O(1) values.
  EXPECT_NEAR(s.r_n, 0.5, 1e-14);
  EXPECT_NEAR(s.r_t, -0.2 / 6.0, 1e-14);
  const Velocity u = end_velocity(p, s);
  EXPECT_NEAR(u.n, 0.0, 1e-14);
  EXPECT_NEAR(u.t, 0.0, 1e-14);
}

TEST(LocalSolve, SlidesInBothDirections) {
  for (const double sign : {1.0, -1.0}) {
    // Sticking would need |R_t| = 3/6 = 0.5 > mu R_n = 0.25: the contact slides along +-t and
    // friction is -sign mu R_n.
    const LocalProblem p{kWnn, 0.0, kWtt, -1.0, sign * 3.0, 0.5};
    const LocalSolution s = solve_local(p);
    EXPECT_EQ(s.status, sign > 0 ? LocalStatus::kSlidingPositive : LocalStatus::kSlidingNegative);
    EXPECT_NEAR(s.r_n, 0.5, 1e-14);
    EXPECT_NEAR(s.r_t, -sign * 0.25, 1e-14);
    const Velocity u = end_velocity(p, s);
    EXPECT_NEAR(u.n, 0.0, 1e-14);
    EXPECT_NEAR(u.t, sign * (3.0 - 6.0 * 0.25), 1e-14);  // still sliding the same way
  }
}

TEST(LocalSolve, FrictionlessContactHasNoTangentialImpulse) {
  const LocalProblem p{kWnn, 0.0, kWtt, -1.0, 0.7, 0.0};
  const LocalSolution s = solve_local(p);
  EXPECT_NEAR(s.r_n, 0.5, 1e-14);
  EXPECT_EQ(s.r_t, 0.0);
}

TEST(LocalSolve, CoupledDelassusMatrixCases) {
  // w_nt != 0: a wall whose inverse mass is not aligned with the contact. The closed forms
  // (local_solve.hpp) are: stick R = -W^-1 b; slide s: R_n = -b_n / (w_nn - s mu w_nt).
  const double wnn = 2.0, wnt = 0.7, wtt = 3.0, mu = 0.4;
  {  // stick
    const LocalProblem p{wnn, wnt, wtt, -1.0, 0.1, mu};
    const LocalSolution s = solve_local(p);
    EXPECT_EQ(s.status, LocalStatus::kSticking);
    const Velocity u = end_velocity(p, s);
    EXPECT_NEAR(u.n, 0.0, 1e-14);
    EXPECT_NEAR(u.t, 0.0, 1e-14);
    EXPECT_EQ(violated(p, s.r_n, s.r_t, kTol), "") << describe(p, s);
  }
  for (const double sign : {1.0, -1.0}) {  // slide
    const LocalProblem p{wnn, wnt, wtt, -1.0, sign * 5.0, mu};
    const LocalSolution s = solve_local(p);
    EXPECT_EQ(s.status, sign > 0 ? LocalStatus::kSlidingPositive : LocalStatus::kSlidingNegative);
    EXPECT_NEAR(s.r_n, 1.0 / (wnn - sign * mu * wnt), 1e-14);
    EXPECT_NEAR(s.r_t, -sign * mu * s.r_n, 1e-14);
    EXPECT_EQ(violated(p, s.r_n, s.r_t, kTol), "") << describe(p, s);
  }
}

TEST(LocalSolve, StickSlideBoundaryWithCoupling) {
  // The sticking solution placed exactly on the cone edge, R* = (1, -+mu): stick and slide are
  // the same solution, and round-off decides which test accepts it. Whichever does, the answer
  // must be R* (up to round-off), never a fallback.
  const double wnn = 2.0, wnt = 0.7, wtt = 3.0;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.05, 1.2);
  for (int k = 0; k < 2000; ++k) {
    const double mu = unit(rng), r_n = unit(rng), sign = k % 2 ? 1.0 : -1.0;
    const double r_t = -sign * mu * r_n;
    const LocalProblem p{wnn, wnt, wtt, -(wnn * r_n + wnt * r_t), -(wnt * r_n + wtt * r_t), mu};
    const LocalSolution s = solve_local(p);
    ASSERT_EQ(violated(p, s.r_n, s.r_t, kTol), "") << describe(p, s);
    ASSERT_NEAR(s.r_n, r_n, 1e-12 * r_n) << describe(p, s);
    ASSERT_NEAR(s.r_t, r_t, 1e-12 * r_n) << describe(p, s);
  }
}

/// Random symmetric positive definite W with condition number below 1e4 (see kTol).
struct RandomProblems {
  std::mt19937_64 rng{20240601};
  std::uniform_real_distribution<double> unit{-1.0, 1.0};
  std::uniform_real_distribution<double> decade{-2.0, 2.0};

  double scale() { return std::pow(10.0, decade(rng)); }
  LocalProblem next(bool coupled) {
    LocalProblem p;
    const double s = scale();
    if (coupled) {
      // W = Q diag(l1, l2) Q^T with eigenvalues l2 / l1 in [1, 1e4).
      const double angle = std::numbers::pi * unit(rng);
      const double l1 = s, l2 = s * std::pow(10.0, 2.0 + 2.0 * unit(rng));
      const double c = std::cos(angle), si = std::sin(angle);
      p.w_nn = l1 * c * c + l2 * si * si;
      p.w_tt = l1 * si * si + l2 * c * c;
      p.w_nt = (l1 - l2) * c * si;
    } else {
      p.w_nn = s * std::pow(10.0, unit(rng));
      p.w_tt = s * std::pow(10.0, unit(rng));
    }
    const double b = scale();
    p.b_n = b * unit(rng);
    p.b_t = b * unit(rng) * (unit(rng) > 0.0 ? 1.0 : 10.0);
    p.mu = std::abs(unit(rng)) * 1.5;
    if (unit(rng) > 0.9) p.mu = 0.0;
    return p;
  }
};

TEST(LocalSolve, PropertyEverySolutionSatisfiesAllConditionsUncoupled) {
  // w_nt = 0 (every disk-disk contact): exactly one case holds; the solver must find it.
  RandomProblems gen;
  int counts[5] = {};
  for (int k = 0; k < 200000; ++k) {
    const LocalProblem p = gen.next(false);
    const LocalSolution s = solve_local(p);
    ++counts[static_cast<int>(s.status)];
    ASSERT_NE(s.status, LocalStatus::kProjected) << describe(p, s);
    ASSERT_EQ(violated(p, s.r_n, s.r_t, kTol), "") << describe(p, s);
  }
  // The generator must exercise every regime, or the property test proves little.
  EXPECT_GT(counts[static_cast<int>(LocalStatus::kSeparated)], 10000);
  EXPECT_GT(counts[static_cast<int>(LocalStatus::kSticking)], 10000);
  EXPECT_GT(counts[static_cast<int>(LocalStatus::kSlidingPositive)], 10000);
  EXPECT_GT(counts[static_cast<int>(LocalStatus::kSlidingNegative)], 10000);
}

TEST(LocalSolve, PropertyEverySolutionSatisfiesAllConditionsCoupled) {
  // w_nt != 0. When w_nn > mu |w_nt| both sliding directions have a positive R_n and a solution
  // always exists (the tangential velocity along the cone edge is continuous, so either one edge
  // slides or the sticking solution lies inside): the solver must return one.
  RandomProblems gen;
  int counts[5] = {};
  int beyond = 0;
  for (int k = 0; k < 200000; ++k) {
    const LocalProblem p = gen.next(true);
    const LocalSolution s = solve_local(p);
    const bool solvable = p.w_nn > p.mu * std::abs(p.w_nt) * (1.0 + 1e-9);
    if (!solvable) {
      // Outside the guaranteed range the answer must at least be an admissible impulse.
      ++beyond;
      ASSERT_GE(s.r_n, 0.0) << describe(p, s);
      ASSERT_LE(std::abs(s.r_t), p.mu * s.r_n * (1.0 + kTol)) << describe(p, s);
      continue;
    }
    ++counts[static_cast<int>(s.status)];
    ASSERT_EQ(violated(p, s.r_n, s.r_t, kTol), "") << describe(p, s);
  }
  EXPECT_GT(counts[static_cast<int>(LocalStatus::kSeparated)], 2000);
  EXPECT_GT(counts[static_cast<int>(LocalStatus::kSticking)], 2000);
  EXPECT_GT(counts[static_cast<int>(LocalStatus::kSlidingPositive)], 2000);
  EXPECT_GT(counts[static_cast<int>(LocalStatus::kSlidingNegative)], 2000);
  EXPECT_EQ(counts[static_cast<int>(LocalStatus::kProjected)], 0);
  EXPECT_GT(beyond, 0);  // the generator also reaches the large-mu, strongly coupled range
}

// The decoupled update (w_nt = 0) as the solver writes it, a correction of the old impulse R
// from the current velocity u (R's own share included): b = u - W R. At omega = 1 it is the
// exact solution, solve_local's.
TEST(DecoupledUpdate, IsTheExactLocalSolution) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.1, 3.0), friction(0.0, 1.0);
  for (int i = 0; i < 20000; ++i) {
    const double w_nn = positive(rng), w_tt = positive(rng), mu = friction(rng);
    const double r_n = std::max(0.0, unit(rng)), r_t = mu * r_n * unit(rng);
    const double u_n = unit(rng), u_t = unit(rng);
    LocalProblem p;
    p.w_nn = w_nn;
    p.w_tt = w_tt;
    p.mu = mu;
    p.b_n = u_n - w_nn * r_n;
    p.b_t = u_t - w_tt * r_t;
    const LocalSolution exact = solve_local(p);
    const LocalImpulse update = decoupled_update({r_n, r_t}, u_n, u_t, 1.0 / w_nn, 1.0 / w_tt, mu);
    const double scale = 1.0 + std::abs(r_n) + std::abs(u_n) / w_nn + std::abs(u_t) / w_tt;
    ASSERT_NEAR(update.n, exact.r_n, 1e-13 * scale) << "case " << i;
    ASSERT_NEAR(update.t, exact.r_t, 1e-13 * scale) << "case " << i;
  }
}

// Over-relaxation in one stage (the solver's update for omega > 1) against the definition,
// the exact update relaxed and projected on the cone: the same impulse up to rounding whenever
// the old impulse is in the cone (local_solve.hpp derives it), in every regime (opening,
// sticking, sliding either way, before and after relaxing). Not for omega < 1 (checked below),
// which the solver does not offer.
TEST(DecoupledUpdate, OverRelaxedInOneStageIsTheRelaxedExactUpdate) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.1, 3.0), friction(0.0, 1.0),
      over(1.0, 2.0), under(0.05, 1.0);
  int opened = 0, slid = 0, inside = 0, on_edge = 0, differ_under = 0;
  const int cases = 50000;
  for (int i = 0; i < cases; ++i) {
    const double inv_w_nn = positive(rng), inv_w_tt = positive(rng), mu = friction(rng);
    const double r_n = i % 7 == 0 ? 0.0 : std::max(0.0, unit(rng));
    // Old impulses inside the cone and on its edges (sliding contacts).
    const double r_t = i % 5 == 0 ? (i % 2 == 0 ? 1.0 : -1.0) * mu * r_n : mu * r_n * unit(rng);
    const double u_n = unit(rng), u_t = unit(rng);
    const LocalImpulse old{r_n, r_t};
    const LocalImpulse exact = decoupled_update(old, u_n, u_t, inv_w_nn, inv_w_tt, mu);
    const double scale = 1.0 + r_n + std::abs(u_n) * inv_w_nn + std::abs(u_t) * inv_w_tt;
    const double omega = over(rng);
    const LocalImpulse two_stage = relax_and_project(old, exact, omega, mu);
    const LocalImpulse one_stage = decoupled_update(old, u_n, u_t, inv_w_nn, inv_w_tt, mu, omega);
    ASSERT_NEAR(one_stage.n, two_stage.n, 1e-13 * scale) << "case " << i << " omega " << omega;
    ASSERT_NEAR(one_stage.t, two_stage.t, 1e-13 * scale) << "case " << i << " omega " << omega;
    opened += one_stage.n == 0.0;
    slid += one_stage.n > 0.0 && std::abs(one_stage.t) == mu * one_stage.n;
    inside += std::abs(one_stage.t) < mu * one_stage.n;
    on_edge += std::abs(exact.t) == mu * exact.n && exact.n > 0.0;
    const double omega_under = under(rng);
    const LocalImpulse relaxed = relax_and_project(old, exact, omega_under, mu);
    const LocalImpulse scaled =
        decoupled_update(old, u_n, u_t, inv_w_nn, inv_w_tt, mu, omega_under);
    differ_under += std::abs(relaxed.n - scaled.n) + std::abs(relaxed.t - scaled.t) > 1e-6 * scale;
  }
  // Every regime is reached by a good share of the cases.
  EXPECT_GT(opened, cases / 20);
  EXPECT_GT(slid, cases / 20);
  EXPECT_GT(inside, cases / 20);
  EXPECT_GT(on_edge, cases / 20);
  EXPECT_GT(differ_under, cases / 20);
}

}  // namespace
}  // namespace cdshear
