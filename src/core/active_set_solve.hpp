// Active-set Newton refinement of a Contact Dynamics step's impulses (nlgs_solver.hpp's problem).
//
// Gauss-Seidel finds which contacts are open, sticking or sliding long before it finds their
// impulses: in a dense packing the impulses' error decays by 0.97 to 0.999 per sweep, because a
// sweep moves information about one contact and the Delassus operator W = H M^-1 H^T of a nearly
// rigid packing is badly conditioned. Once the status of every contact is known, the impulses
// solve a linear system, which a sparse factorisation solves exactly whatever its conditioning
// and the size of the packing. Each iteration is one of a primal-dual active-set (semismooth
// Newton) method on the natural map of the contact problem:
//
//   1. Status of each contact from the current impulse R and relative velocity u (the exact
//      local solution's case, local_solve.hpp, with W reduced to its diagonal, i.e. the
//      Alart-Curnier classification with rho = 1 / w_kk):
//        sigma_n = R_n - (u_n + gap/dt) / w_nn < 0                     -> open:     R = 0;
//        |sigma_t| <= mu sigma_n, sigma_t = R_t - u_t / w_tt            -> sticking: u = 0;
//        otherwise                                                      -> sliding:  u_n = 0,
//                                                      R_t = s mu R_n, s = sign(sigma_t).
//      (sigma_n = 0, a touching contact at rest without force, counts as closed: a column at
//      rest would otherwise close one contact per iteration.)
//   2. The open contacts' impulses set to 0, the sliding ones' R_t to s mu R_n, applied.
//   3. The unknown corrections dR (n and t of sticking contacts, n of sliding ones, whose R_t
//      follows s mu R_n) solve
//        B dR = -u_A,   B = H_rows M^-1 H_cols^T + beta I,
//      H_rows: the velocities held at 0 (u_n, and u_t of sticking contacts), H_cols: the
//      directions of the unknowns' impulses (n, t; n + s mu t for a sliding contact: B is not
//      symmetric, Coulomb friction being non-associated). In a step's first iteration B is
//      formed by CHOLMOD's sparse product and factorised by KLU (SuiteSparse; no BLAS, a fixed
//      ordering: the same result on any machine load and thread count). A later iteration
//      changes the statuses of a few contacts only, i.e. a few rows and columns of B: it solves
//      by GMRES without forming B (a product with B is one pass over the contacts), with the
//      kept factorisation as the preconditioner, and factorises anew only when more than a few
//      statuses changed since or GMRES does not converge. beta, a 1e-10 fraction of the mean
//      w_nn, keeps self-stress states (null vectors of W in a hyperstatic packing) finite.
//   4. R + tau dR, tau <= 1 the longest step keeping every closed contact carrying force inside
//      its cone (a ratio test: the first contacts to reach the boundary open or slide in the
//      next iteration), projected on the cone and applied.
//   5. A line search on the natural-map residual |R - proj_C(R - D^-1 u)| / |R| (D the diagonal
//      of W: zero exactly at a solution) between the iterate the iteration started from and
//      the new one: the step if it brings the residual below the largest of the last five
//      iterates' (non-monotone), else 1/2, 1/4 ... 1/64 of it. If none does, steps 3 to 5
//      again with beta 1000 times larger and the full step (Levenberg-Marquardt; up to 1e-1 W);
//      if still none, the iteration is undone and the refinement stops.
// Repeated until the residual is below the tolerance or the iterations run out; the best
// iterate is returned, never worse than the sweeps' by this residual (by the RMS velocity residual
// it can be: ContactDynamics::step then keeps the sweeps' result where theirs met the step's
// contact-law bound and the refined one does not). Works on the solver
// bodies (free velocity + M^-1 H^T R on entry, and on exit) and the contacts' impulses.
//
// With a normal compliance (ActiveSetOptions::normal_compliance, kappa; c = kappa w_nn per
// contact) the normal law is that of the compliant velocity u_n + c R_n (nlgs_solver.cpp,
// update_row): the classification, the right-hand side and the merit read u_n + c R_n where the
// rigid laws read u_n, and B gains c on the diagonal of each closed contact's normal unknown
// (d(u_n + c R_n) / dR_n = w_nn + c for a sticking contact; w_nn + s mu w_nt + c for a sliding
// one). Everything else is unchanged. Where every closed contact sticks, B is then W + C,
// positive definite: no loop of closed contacts leaves it singular.
//
// Why the ratio test: in a hyperstatic packing the gaps of a loop of closed contacts are in
// general closed by no motion, so B is singular with a right-hand side outside its range, and
// dR runs along the loop's self-stress without bound; the exact solution opens one contact of
// the loop, which is where the ratio test stops.
//
// Measured (docs/performance.md, "Active-set Newton refinement"): where the sweeps' statuses
// are nearly right (system 1) two to four iterations solve a step to round-off; in the tall
// cells (system 5) early in the shear the iterations fix one or two statuses at a time (the
// ratio test), and with 16 iterations most steps reach round-off, each later iteration by a few
// GMRES iterations. On an old, dense flow (system 5 after 4000 t) they seldom do: the system for
// the sweeps' statuses is nearly singular with a right-hand side mostly outside its range (|dR|
// 4e3 to 2e5 times |R|), the ratio test stops each step at 1e-11 to 1e-6 of it, where the first
// contact reaches its cone's boundary, and the residual falls by a third in 126 iterations
// (`cdshear_bench --state ... --newton-history`).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "contact.hpp"
#include "solver_rows.hpp"

namespace cdshear {

struct ActiveSetOptions {
  int max_iterations = 4;         ///< Newton iterations at most
  double regularisation = 1e-10;  ///< beta, as a fraction of the mean w_nn
  double tolerance = 1e-12;       ///< stop when the natural-map residual / |R| is below this
  /// kappa (SolverOptions::normal_compliance): the compliant normal law u_n + gap/dt + kappa
  /// w_nn R_n >= 0 instead of the rigid one (0)
  double normal_compliance = 0.0;
  bool record_history = false;  ///< fill ActiveSetReport::history
};

/// One refinement iteration, as ActiveSetOptions::record_history records it.
struct ActiveSetIteration {
  std::size_t changed = 0;                     ///< statuses changed by its classification
  std::size_t unknowns = 0;                    ///< of the system it solved
  std::size_t open = 0, stick = 0, slide = 0;  ///< contacts of each status
  double ratio_step = 1.0;                     ///< the ratio test's step (1: none limited it)
  std::size_t blocking = 0;                    ///< contacts within 1e-9 of the ratio step's bound
  double newton_norm = 0.0;  ///< |dR| / |R| of its first solve (beta), before the ratio test
  double line_step = 1.0;    ///< the line search's fraction of that step (0: no descent)
  int attempt = 0;           ///< regularisations raised before it descended (0: beta itself)
  bool by_krylov = false;    ///< solved by GMRES on a kept factorisation
  double residual = 0.0;     ///< natural-map residual / |R on entry| after it
};

struct ActiveSetReport {
  bool ran = false;        ///< the refinement ran on this step (it had contacts)
  bool converged = false;  ///< it ended with the residual at or below the tolerance
  int iterations = 0;
  std::size_t unknowns = 0;       ///< of the last system solved
  std::size_t changed = 0;        ///< contacts whose status changed in the last iteration
  double correction = 0.0;        ///< |dR| / |R| of the last iteration
  bool factorised = true;         ///< false: the factorisation failed
  int factorisations = 0;         ///< sparse LU factorisations of B (KLU)
  int krylov_solves = 0;          ///< systems solved by GMRES on a kept factorisation instead
  double initial_residual = 0.0;  ///< natural-map residual / |R on entry| on entry
  double residual = 0.0;          ///< ... on exit, / |R on entry| too
  /// The step kept the sweeps' result instead of the refinement's: the sweeps' met the
  /// contact-law bound (SolverOptions::residual_tolerance) and the refined one did not
  /// (ContactDynamics::step). The refinement keeps its best iterate by the natural map, which
  /// weighs the contacts otherwise than the bound's root mean square velocity.
  bool undone = false;
  std::vector<ActiveSetIteration> history;  ///< with ActiveSetOptions::record_history
};

/// The refinement over many steps (a run's summary, a benchmark's): the steps it ran on, those it
/// ended at its tolerance (a solution to round-off), its iterations summed, and the largest
/// natural-map residual it left (relative to the step's impulses; a NaN shows and stays, which
/// std::max would drop).
struct RefinementTally {
  std::uint64_t steps = 0;
  std::uint64_t steps_to_tolerance = 0;
  std::uint64_t steps_undone = 0;  ///< ActiveSetReport::undone
  std::uint64_t iterations = 0;
  double largest_residual = 0.0;

  void add(const ActiveSetReport& r) {
    if (!r.ran) return;
    ++steps;
    steps_to_tolerance += r.converged ? 1 : 0;
    steps_undone += r.undone ? 1 : 0;
    iterations += static_cast<std::uint64_t>(r.iterations);
    // a NaN, once there, stays: NaN <= x is false either way round
    if (!std::isnan(largest_residual) && !(r.residual <= largest_residual))
      largest_residual = r.residual;
  }
  double mean_iterations() const {
    return steps > 0 ? static_cast<double>(iterations) / static_cast<double>(steps) : 0.0;
  }
};

class ActiveSetSolver {
 public:
  ActiveSetSolver();
  ~ActiveSetSolver();
  ActiveSetSolver(const ActiveSetSolver&);  ///< a fresh solver: scratch is not state
  ActiveSetSolver& operator=(const ActiveSetSolver&);

  ActiveSetReport refine(std::vector<Contact>& contacts, std::vector<SolverBody>& bodies, double dt,
                         const ActiveSetOptions& options);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdshear
