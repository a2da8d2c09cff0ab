// Nonlinear Gauss-Seidel (NLGS) solver of the Contact Dynamics step (Moreau-Jean), SPEC 3.
//
// A function of (contacts, bodies, dt, options) that returns a report. Bodies carry the free
// end-of-step velocities on entry (previous velocities plus dt times external accelerations) and
// the end-of-step velocities on exit; contacts carry warm-start impulses on entry and the
// solution on exit.
//
// Each sweep visits every contact once (in a seeded random order, or in key order) and solves its
// 2x2 problem exactly (local_solve.hpp) with the other impulses held fixed. Body velocities are
// kept equal to free velocity + M^-1 H^T R at all times, so that a contact's free velocity is its
// current relative velocity minus W times its current impulse: a contact update costs O(1).
//
// Convergence (SPEC 3.5): after each sweep, with dR_k the change of contact k's impulse during
// that sweep, stop when both
//   - |dR_k|^2 <= alpha |R_k|^2 for at least `converged_fraction` of the force-carrying contacts
//     (R_k != 0 before or after the sweep; idle candidates are not counted), and
//   - (sum_k |dR_k| / sum_k |R_k|)^2 <= alpha  (the mean force; true when every R_k is zero),
// or when `max_sweeps` is reached (reported as hit_cap).
#pragma once

#include <cstdint>
#include <vector>

#include "contact.hpp"
#include "vec2.hpp"

namespace cdshear {

/// What the solver needs of a body. Walls have inverse inertia 0 and a per-axis inverse mass that
/// is 0 on fixed or imposed axes: no special case in the hot loop.
struct SolverBody {
  Vec2 velocity;
  double omega = 0.0;
  Vec2 inv_mass;             ///< (1/m_x, 1/m_y); equal for disks [1/mass]
  double inv_inertia = 0.0;  ///< [1/(mass length^2)]
};

enum class ContactOrder { kRandom, kSequential };

struct SolverOptions {
  double alpha = 1e-6;              ///< tolerance on the squared relative force change
  double converged_fraction = 0.9;  ///< share of contacts that must meet the tolerance
  int max_sweeps = 200;             ///< cap on sweeps per step
  ContactOrder order = ContactOrder::kRandom;
  std::uint64_t seed = 1;  ///< keys the random contact order
};

struct SolverReport {
  int sweeps = 0;
  bool hit_cap = false;
  double residual = 0.0;            ///< (sum |dR| / sum |R|)^2 of the last sweep
  double converged_fraction = 1.0;  ///< share of force-carrying contacts meeting it, last sweep
  int active_contacts = 0;          ///< contacts with R_n > 0 at the end
};

/// Reusable scratch memory, so that a step allocates nothing once warmed up.
struct SolverWorkspace {
  std::vector<std::uint32_t> order;
};

/// Solves the contact problem of one step. `step` keys the random order (with options.seed).
SolverReport solve_contacts(std::vector<Contact>& contacts, std::vector<SolverBody>& bodies,
                            double dt, const SolverOptions& options, std::uint64_t step,
                            SolverWorkspace& workspace);

}  // namespace cdshear
