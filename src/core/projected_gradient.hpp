// Conjugate projected gradient (CPG) for the Contact Dynamics step: the alternative to the
// Gauss-Seidel sweeps of nlgs_solver.hpp that LMGC90 offers for large dense packings (Renouf and
// Alart 2004), measured against them in docs/performance.md.
//
// With the friction threshold s_k = mu_k R_n,k of the current iterate held fixed, the step's
// contact problem is the box-constrained quadratic program (Tresca friction)
//   min 1/2 R^T W R + q^T R,  R_n >= 0, |R_t| <= s,
// whose gradient W R + q is the biased relative velocity u (u_n + gap/dt, u_t): what the body
// velocities give, since they are kept equal to v_free + M^-1 H^T R. Each iteration
//   - projects the descent direction -u on the set's tangent cone (w),
//   - scales it by the diagonal of W (Jacobi preconditioner: z = D^-1 w),
//   - makes the search direction W-conjugate to the last one (p = z + beta p),
//   - steps to the line minimum along p and projects on the Signorini-Coulomb set, with the
//     threshold of the new R_n (the fixed point on s is taken along the way, as Renouf and Alart
//     do). Its fixed points are those of Gauss-Seidel: R = proj(R - D^-1 u).
// An iteration is four passes over the rows (two of them scatter to the bodies), against one
// gather and one scatter for a Gauss-Seidel sweep.
#pragma once

#include <vector>

#include "nlgs_solver.hpp"

namespace cdshear {


/// Solves the rows' problem from their current impulses (already applied to the bodies); stops
/// on the test of SPEC 3.5 applied to an iteration's change, or at options.max_sweeps
/// iterations. Fills report.sweeps (iterations), residual, converged_fraction, hit_cap.
void solve_by_projected_gradient(std::vector<SolverRow>& rows,
                                 const std::vector<DelassusEntries>& delassus,
                                 std::vector<SolverBody>& bodies, const SolverOptions& options,
                                 ProjectedGradientScratch& scratch, SolverReport& report);

void solve_by_accelerated_gradient(std::vector<SolverRow>& rows,
                                   const std::vector<DelassusEntries>& delassus,
                                   std::vector<SolverBody>& bodies, const SolverOptions& options,
                                   ProjectedGradientScratch& scratch, SolverReport& report);

}  // namespace cdshear
