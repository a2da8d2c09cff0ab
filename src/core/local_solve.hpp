// Exact solution of one contact's 2x2 frictional problem with the others held fixed: the
// building block of the nonlinear Gauss-Seidel solver.
//
// Unknown: impulse R = (R_n, R_t). The end-of-step relative velocity is affine in R:
//     u = b + W R,   W = [[w_nn, w_nt], [w_nt, w_tt]]  (symmetric positive definite),
// where b is the "free" velocity (all other impulses applied, this one removed). The normal
// component carries the gap bias: b_n = u_n,free + gap / dt, so that u_n = 0 means
// gap + dt u_n(end) = 0 (docs/model.md section 3, item 3: inelastic Signorini, existing overlaps
// removed in one step).
// Conditions:
//   Signorini:  R_n >= 0,  u_n >= 0,  R_n u_n = 0
//   Coulomb:    |R_t| <= mu R_n;  |R_t| < mu R_n => u_t = 0;  R_t = -s mu R_n => s u_t >= 0.
// Cases, tried in order (each is checked against all conditions):
//   1. separation: b_n >= 0 -> R = 0;
//   2. sticking:   R = -W^-1 b, accepted if R_n > 0 and |R_t| <= mu R_n;
//   3. sliding in direction s = sign(u_t) in {+1, -1}: R_t = -s mu R_n and u_n = 0 give
//      R_n = -b_n / (w_nn - s mu w_nt); accepted if R_n >= 0 and s u_t >= 0.
// With w_nt = 0 (any two disks, or a wall whose inverse mass is isotropic or axis-aligned with
// the contact) exactly one case holds. With w_nn > mu |w_nt| at least one case holds in exact
// arithmetic; if rounding rejects all of them (solution on the stick/slide boundary), the sliding
// candidate closest to its sliding condition is returned. If none holds because mu |w_nt| >= w_nn
// (w_nt != 0 and large mu), the sticking solution is projected onto the cone.
#pragma once

#include <algorithm>

namespace cdshear {

struct LocalProblem {
  double w_nn = 0.0, w_nt = 0.0, w_tt = 0.0;  ///< Delassus matrix entries [1/mass]
  double b_n = 0.0, b_t = 0.0;                ///< biased free velocity [length/time]
  double mu = 0.0;                            ///< Coulomb coefficient
};

enum class LocalStatus { kSeparated, kSticking, kSlidingPositive, kSlidingNegative, kProjected };

struct LocalSolution {
  double r_n = 0.0, r_t = 0.0;
  LocalStatus status = LocalStatus::kSeparated;
};

LocalSolution solve_local(const LocalProblem& p);

/// An impulse (normal, tangential) [mass length/time].
struct LocalImpulse {
  double n = 0.0, t = 0.0;
};

/// The decoupled case (w_nt = 0) written as a correction of the old impulse R, with u_n the
/// current biased normal velocity (u_n + gap/dt) and u_t the tangential one, R's own share
/// included (so b = u - W R, and cases 1 to 3 above reduce to)
///   R_n' = max(0, R_n - u_n / w_nn),   R_t' = clamp(R_t - u_t / w_tt, -mu R_n', mu R_n'),
/// with no branch on the case. The Gauss-Seidel update, at omega = 1 exactly (x * 1 is x).
///
/// With omega > 1, the same formula with the steps scaled by omega is the projected
/// over-relaxation of the exact update, proj_C(R + omega (R_GS - R)) with C the Coulomb cone
/// (relax_and_project below), in one stage, provided the old R is in C (|R_t| <= mu R_n: every
/// impulse the solver computes is, being a projection or a positive multiple of one; only a
/// hand-edited checkpoint could start a row outside, and then only its first update differs).
/// Derivation, x = u_n / w_nn, y = u_t / w_tt, c = 1 - omega < 0:
///   normal: if R_n - x >= 0, R_n + omega (R_n - x - R_n) = R_n - omega x. Otherwise x > R_n >= 0,
///     so R_n + omega (0 - R_n) = c R_n <= 0 and R_n - omega x < R_n - x < 0: both give 0.
///   tangential, R_GS unclamped: R_t + omega (R_t - y - R_t) = R_t - omega y, clamped alike.
///     R_GS clamped at +mu R_n,GS (R_t - y > mu R_n,GS; -mu R_n,GS is the mirror image): the
///     two-stage value is V = c R_t + omega mu R_n,GS, and with R_n' = c R_n + omega R_n,GS
///     (R_n' > 0; at R_n' = 0 both give 0), V - mu R_n' = c (R_t - mu R_n) >= 0, so V clamps to
///     mu R_n'; the one-stage value R_t - omega y = c R_t + omega (R_t - y) > V clamps to mu R_n'
///     too.
/// So both give the same impulse in exact arithmetic; the one stage has a dependency chain
/// through the bodies' velocities about a third shorter (docs/performance.md). It does not
/// hold for omega < 1 (c > 0), which the solver does not offer.
inline LocalImpulse decoupled_update(LocalImpulse old, double u_n, double u_t, double inv_w_nn,
                                     double inv_w_tt, double mu, double omega = 1.0) {
  const double r_n = std::max(0.0, old.n - u_n * (omega * inv_w_nn));
  const double limit = mu * r_n;
  return {r_n, std::clamp(old.t - u_t * (omega * inv_w_tt), -limit, limit)};
}

/// Projected relaxation of an exact local solution `exact` from the old impulse:
///   R_n' = max(0, R_n + omega (R_n,exact - R_n)),  R_t' = clamp(R_t + omega (R_t,exact - R_t),
///   -mu R_n', mu R_n').
inline LocalImpulse relax_and_project(LocalImpulse old, LocalImpulse exact, double omega,
                                      double mu) {
  const double r_n = std::max(0.0, old.n + omega * (exact.n - old.n));
  const double limit = mu * r_n;
  return {r_n, std::clamp(old.t + omega * (exact.t - old.t), -limit, limit)};
}

}  // namespace cdshear
