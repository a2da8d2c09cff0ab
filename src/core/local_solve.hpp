// Exact solution of one contact's 2x2 frictional problem with the others held fixed: the
// building block of the nonlinear Gauss-Seidel solver.
//
// Unknown: impulse R = (R_n, R_t). The end-of-step relative velocity is affine in R:
//     u = b + W R,   W = [[w_nn, w_nt], [w_nt, w_tt]]  (symmetric positive definite),
// where b is the "free" velocity (all other impulses applied, this one removed). The normal
// component carries the gap bias: b_n = u_n,free + gap / dt, so that u_n = 0 means
// gap + dt u_n(end) = 0 (SPEC 3.3: inelastic Signorini, existing overlaps removed in one step).
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

}  // namespace cdshear
