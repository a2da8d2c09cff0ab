// The solver's compact view of bodies and contacts (nlgs_solver.hpp): what a sweep reads and
// writes, and the phases of groups that share no body. Shared by the sweeps (nlgs_solver.cpp)
// and the slab correction (slab_correction.hpp), which gathers its sums in the sweep before it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "threads.hpp"
#include "vec2.hpp"

namespace cdshear {

/// What the solver needs of a body. Walls have inverse inertia 0 and a per-axis inverse mass that
/// is 0 on fixed or imposed axes: no special case in the hot loop.
///
/// One cache line each: two threads updating two different bodies never write the same line.
struct alignas(64) SolverBody {
  Vec2 velocity;
  double omega = 0.0;
  Vec2 inv_mass;             ///< (1/m_x, 1/m_y); equal for disks [1/mass]
  double inv_inertia = 0.0;  ///< [1/(mass length^2)]
  /// Where the body is, coarsely (a band of heights): the coloured order keeps the contacts of a
  /// colour sorted by it, so that each thread works on its own part of the packing and the
  /// bodies it updates stay in its cache. Any value gives the same results.
  std::uint32_t band = 0;
};

/// One contact as the sweeps see it: what an update reads and writes, compact (88 bytes) and
/// stored in visit order, so that a sweep streams through memory front to back. The tangent is
/// perp(normal) and is not stored. The Delassus entries themselves are needed only by coupled
/// rows (w_nt != 0, rare): they live in SolverWorkspace::delassus, out of the stream; a coupled
/// row is marked by inv_w_tt = kCoupledRow (a decoupled row has inv_w_tt > 0).
/// On system 7's shape the rows of a step (about 11000) are about 1 MB, the awake ones first
/// (put_awake_rows_first); their size is a few percent of an update's cost there (88 against 112
/// bytes: 0.958; docs/performance.md, "Rows in visit order").
struct SolverRow {
  std::uint32_t body_a = 0, body_b = 0;  ///< solver body indices
  Vec2 normal;                           ///< unit, from b to a
  double lever_a = 0.0, lever_b = 0.0;   ///< as in Contact [length]
  double bias_n = 0.0;                   ///< gap / dt [length/time]
  double friction = 0.0;                 ///< Coulomb coefficient
  double impulse_n = 0.0, impulse_t = 0.0;
  /// 1/w_nn [mass], times omega when the solve over-relaxes (omega > 1: the factor of its
  /// one-stage update, formed once per step by fill_row instead of in every update)
  double inv_w_nn = 0.0;
  double inv_w_tt = 0.0;  ///< 1/w_tt [mass], times omega likewise; kCoupledRow for a coupled row
};
static_assert(sizeof(SolverRow) == 88);

/// inv_w_tt of a coupled row (w_nt != 0): it goes through the general local solve.
inline constexpr double kCoupledRow = -1.0;

/// Applies impulse (dn, dt) along (n, t = perp(n)) of a row: +P on a, -P on b, torques
/// lever * dt on both. Applying a zero impulse changes nothing, so no branch is needed. `Row` is
/// anything with normal, lever_a and lever_b: a SolverRow, or a Contact (the active-set
/// refinement works on the contacts).
template <class Row>
inline void apply_row_impulse(const Row& r, SolverBody& a, SolverBody& b, double dn, double dt) {
  const double px = dn * r.normal.x - dt * r.normal.y;
  const double py = dn * r.normal.y + dt * r.normal.x;
  a.velocity.x += a.inv_mass.x * px;
  a.velocity.y += a.inv_mass.y * py;
  b.velocity.x -= b.inv_mass.x * px;
  b.velocity.y -= b.inv_mass.y * py;
  a.omega += a.inv_inertia * r.lever_a * dt;
  b.omega += b.inv_inertia * r.lever_b * dt;
}

/// Applies impulse (dn, dt) to the two bodies of a contact (a Contact: its key names the bodies
/// by their index in `bodies`), as apply_row_impulse does to a row's.
template <class ContactLike>
inline void apply_contact_impulse(const ContactLike& c, std::vector<SolverBody>& bodies, double dn,
                                  double dt) {
  apply_row_impulse(c, bodies[static_cast<std::size_t>(c.key.body_a)],
                    bodies[static_cast<std::size_t>(c.key.body_b)], dn, dt);
}

/// Local Delassus matrix of a row [1/mass] (local_solve.hpp), for the coupled rows' solve.
struct DelassusEntries {
  double w_nn = 0.0, w_nt = 0.0, w_tt = 0.0;
  /// kappa w_nn [1/mass]: the normal compliance of the row (SolverOptions::normal_compliance),
  /// added to w_nn in its local problem and times R_n to its normal velocity; 0 for a rigid one
  double compliance_n = 0.0;
};

/// The Delassus entries of a contact between bodies a and b: W = sum over its two bodies of
/// H_body M_body^-1 H_body^T with H rows (n, lever) and (t, lever) in (translation, rotation)
/// coordinates. With the inverse masses summed per axis, (m_x, m_y) = M_a^-1 + M_b^-1
/// (diagonal), and t = perp(n) = (-n_y, n_x):
///   w_nn = m_x n_x^2 + m_y n_y^2,  w_tt = m_x n_y^2 + m_y n_x^2 + levers^2 / inertias,
///   w_nt = m_x n_x t_x + m_y n_y t_y = (m_y - m_x) n_x n_y,
/// so w_nt is exactly 0 whenever m_x = m_y (any two disks) or n is along an axis (a flat wall).
/// (Computed as n.(M^-1 t), it was a rounding residue of order 1e-17 instead of 0, which sent
/// most rows to the general local solve.) `Row` is anything with normal, lever_a and lever_b.
template <class Row>
inline DelassusEntries delassus_entries(const Row& c, const SolverBody& a, const SolverBody& b) {
  const Vec2 n = c.normal;
  const double m_x = a.inv_mass.x + b.inv_mass.x, m_y = a.inv_mass.y + b.inv_mass.y;
  return {m_x * n.x * n.x + m_y * n.y * n.y, (m_y - m_x) * n.x * n.y,
          m_x * n.y * n.y + m_y * n.x * n.x + c.lever_a * c.lever_a * a.inv_inertia +
              c.lever_b * c.lever_b * b.inv_inertia};
}

/// Groups [first_group, last_group) of rows that share no body: a sweep solves them at once,
/// on as many threads as it has.
struct SolverPhase {
  std::size_t first_group = 0, last_group = 0;
};

/// The groups of `phase` that thread p takes: its share_of the phase's groups (consecutive
/// groups, the same split in every pass). Every pass over the groups splits them so (the
/// sweeps, the warm start, the mix, the sums, the dormant rows' look, the slab correction), so
/// that a thread reads the rows and bodies it wrote itself: a row or body handed from one core
/// to another costs cache-line transfers every step. Against passes split by rows over all
/// groups at once, 4 to 5% less solve time on system 5 on two threads (docs/performance.md,
/// "Threads").
inline Share phase_share(const SolverPhase& phase, TeamPlace p) {
  const Share s = share_of(phase.last_group - phase.first_group, p);
  return {phase.first_group + s.first, phase.first_group + s.last};
}

/// Runs `for_group(g)` over the groups of every phase, phase by phase, each phase's groups
/// shared among the calling OpenMP team (phase_share, then a barrier; one thread outside a
/// parallel region runs them all). The serial group, in no phase, is left out. Groups of a
/// phase share no body, so each body meets the groups' changes in group order.
template <class ForGroup>
void for_each_phased_group(const std::vector<SolverPhase>& phases, const ForGroup& for_group) {
  const TeamPlace place = team_place();
  for (const SolverPhase& phase : phases) {
    const Share mine = phase_share(phase, place);
    for (std::size_t g = mine.first; g < mine.last; ++g) for_group(g);
    team_barrier();
  }
}

/// Runs `for_group(g)` over the groups thread p takes in the passes over every group at once:
/// its phase_share of each phase, then the serial group (the last, `serial_group`) on thread 0.
/// No barrier.
template <class ForGroup>
void for_each_own_group(const std::vector<SolverPhase>& phases, std::size_t serial_group,
                        TeamPlace p, const ForGroup& for_group) {
  for (const SolverPhase& phase : phases) {
    const Share mine = phase_share(phase, p);
    for (std::size_t g = mine.first; g < mine.last; ++g) for_group(g);
  }
  if (p.thread == 0) for_group(serial_group);
}

}  // namespace cdshear
