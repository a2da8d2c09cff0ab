#include "active_set_solve.hpp"

#include <cholmod.h>
#include <klu.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <tuple>

#include "local_solve.hpp"
#include "velocity_residual.hpp"

namespace cdshear {

namespace {

/// Regularisations tried before an iteration gives up (each 1000 times the last), and the
/// shortest step of the line search.
constexpr int kRegularisationAttempts = 4;
constexpr double kSmallestStep = 1.0 / 64.0;

/// A non-monotone line search (Grippo, Lampariello and Lucidi 1986): an iteration is kept where
/// it lowers the merit below the largest of the last kMeritMemory iterates' (1: below the
/// current one's). The ratio test lets each iteration fix one or two statuses; where the merit
/// must rise on the way to the solution a monotone search stops there. The best iterate is
/// returned. System 5, 8 paired steps: at V = 0.1 all 8 end at round-off instead of 5 (at 0.5, 6
/// either way), and a step costs half as much (fewer steps stall at the iteration cap); memory
/// 10 gave the same as 5 (docs/performance.md).
constexpr std::size_t kMeritMemory = 5;

/// The Krylov solve of a later iteration (reusing the step's last factorisation): at most this
/// many GMRES iterations, and the relative residual it must reach; otherwise B is factorised
/// anew.
constexpr int kKrylovIterations = 30;
constexpr double kKrylovTolerance = 1e-13;
/// Each status changed since the factorisation changes up to two rows and columns of B: GMRES
/// then needs about twice as many iterations plus one, each about 1/20 of a factorisation.
/// Beyond this many changed statuses B is factorised anew.
constexpr std::size_t kKrylovChangedStatuses = 8;

enum Status : std::int8_t { kOpen = 0, kStick = 1, kSlidePositive = 2, kSlideNegative = 3 };

/// s mu of a sliding contact, whose R_t follows s mu R_n; 0 for any other status.
double sliding_slope(std::int8_t status, double friction) {
  return status == kSlidePositive ? friction : status == kSlideNegative ? -friction : 0.0;
}

/// A sparse matrix being built entry by entry: one row per unknown, one column per body degree
/// of freedom (x, y, rotation of each body), scaled by M^-1/2.
struct Triplets {
  std::vector<int> rows, cols;
  std::vector<double> values;

  void clear() {
    rows.clear();
    cols.clear();
    values.clear();
  }
  /// Row `row` of H M^-1/2 for a direction `dir` with levers (lever_a, lever_b) between bodies
  /// a and b: (dir, lever_a) on a, (-dir, lever_b) on b (contact.hpp); degrees of freedom of
  /// zero inverse mass (imposed axes, walls' rotation) and zero entries are left out.
  void add_row(std::size_t row, std::size_t ia, const SolverBody& a, std::size_t ib,
               const SolverBody& b, Vec2 dir, double lever_a, double lever_b) {
    add(row, ia, 0, dir.x, a.inv_mass.x);
    add(row, ia, 1, dir.y, a.inv_mass.y);
    add(row, ia, 2, lever_a, a.inv_inertia);
    add(row, ib, 0, -dir.x, b.inv_mass.x);
    add(row, ib, 1, -dir.y, b.inv_mass.y);
    add(row, ib, 2, lever_b, b.inv_inertia);
  }

 private:
  void add(std::size_t row, std::size_t body, std::size_t axis, double value, double inv_m) {
    if (inv_m == 0.0 || value == 0.0) return;
    rows.push_back(static_cast<int>(row));
    cols.push_back(static_cast<int>(3 * body + axis));
    values.push_back(value * std::sqrt(inv_m));
  }
};

/// The velocity of contact k that its normal law holds non-negative: u_n + gap/dt, plus c R_n
/// with a normal compliance (c = kappa w_nn; 0 for rigid contacts).
double law_velocity_n(const Contact& c, const ContactVelocity& u, double compliance) {
  return u.n + compliance * c.impulse_n;
}

/// Natural-map residual of the contact problem: sum over contacts of |R - proj_C(R - D^-1 u)|^2,
/// D = diag(w_nn, w_tt), u_n the law's velocity (law_velocity_n) (the change each contact's
/// exact local update, decoupled_update of local_solve.hpp, would make if it were updated now
/// with the others held: zero exactly at a solution), and sum |R|^2.
std::pair<double, double> natural_residual(const std::vector<Contact>& contacts,
                                           const std::vector<SolverBody>& bodies, double inv_dt,
                                           const std::vector<double>& inv_w_nn,
                                           const std::vector<double>& inv_w_tt,
                                           const std::vector<double>& compliance) {
  double residual2 = 0.0, force2 = 0.0;
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const Contact& c = contacts[k];
    const ContactVelocity u = contact_velocity(c, bodies, inv_dt);
    const LocalImpulse next =
        decoupled_update({c.impulse_n, c.impulse_t}, law_velocity_n(c, u, compliance[k]), u.t,
                         inv_w_nn[k], inv_w_tt[k], c.friction);
    const double dn = next.n - c.impulse_n, dt = next.t - c.impulse_t;
    residual2 += dn * dn + dt * dt;
    force2 += c.impulse_n * c.impulse_n + c.impulse_t * c.impulse_t;
  }
  return {residual2, force2};
}

}  // namespace

/// The refinement's scratch and phases; refine() below is the loop over them. Each phase takes
/// the step's contacts and bodies, which hold the current iterate.
struct ActiveSetSolver::Impl {
  using Impulses = std::vector<std::pair<double, double>>;

  cholmod_common common;
  std::size_t nc = 0;
  double inv_dt = 0.0;
  double mean_diagonal = 0.0;  ///< mean w_nn, the scale of the regularisation
  double entry_force2 = 0.0;   ///< sum |R|^2 on entry, the residual's fixed scale
  std::vector<std::int8_t> status;
  std::vector<std::int64_t> unknown;       ///< first unknown of each contact, -1 for an open one
  std::vector<double> inv_w_nn, inv_w_tt;  ///< 1 / the diagonal Delassus entries
  std::vector<double> compliance;          ///< c = kappa w_nn of each contact [1/mass]
  std::vector<SolverBody> base_bodies, start_bodies, full_bodies, best_bodies;
  Impulses base_impulses, start_impulses, full_impulses, best_impulses;
  /// where the diagonal entries of the B last formed (delassus_matrix) are in its values
  std::vector<std::int64_t> diagonal;
  std::vector<double> solution;
  /// H_rows M^-1/2 (the velocities held at 0) and H_cols M^-1/2 (the unknowns' impulses)
  Triplets velocities, impulses;
  std::vector<double> rhs;

  /// The step's last factorisation of B, kept as the preconditioner of later iterations' Krylov
  /// solves, and the statuses and numbering it was made with.
  struct Factorisation {
    klu_common kc;
    klu_symbolic* symbolic = nullptr;
    klu_numeric* numeric = nullptr;
    std::vector<std::int8_t> status;
    std::vector<std::int64_t> unknown;
    std::size_t size = 0;
    double beta = 0.0;
    bool valid() const { return numeric != nullptr; }
    void release() {
      if (numeric) klu_free_numeric(&numeric, &kc);
      if (symbolic) klu_free_symbolic(&symbolic, &kc);
    }
  } factorisation;
  /// The Krylov solve's scratch: bodies holding M^-1 H_cols^T x, the basis and its
  /// preconditioned images, the Hessenberg matrix and its rotations.
  std::vector<SolverBody> product_bodies;
  std::vector<double> basis, images, hessenberg, cosines, sines, projected, work, mapped;

  Impl() {
    cholmod_start(&common);
    common.print = 0;  // CHOLMOD forms B (sparse products); KLU factorises it
    common.error_handler = nullptr;
  }
  ~Impl() {
    factorisation.release();
    cholmod_finish(&common);
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  /// Sizes the scratch and reads the diagonal Delassus entries, the compliances (kappa: the
  /// normal compliance) and the residual's scale.
  void begin(const std::vector<Contact>& contacts, const std::vector<SolverBody>& bodies, double dt,
             double kappa) {
    nc = contacts.size();
    inv_dt = 1.0 / dt;
    factorisation.release();
    product_bodies = bodies;
    status.assign(nc, kOpen);
    unknown.assign(nc, -1);
    inv_w_nn.resize(nc);
    inv_w_tt.resize(nc);
    compliance.resize(nc);
    mean_diagonal = 0.0;
    for (std::size_t k = 0; k < nc; ++k) {
      const Contact& c = contacts[k];
      const DelassusEntries w = delassus_entries(c, bodies[static_cast<std::size_t>(c.key.body_a)],
                                                 bodies[static_cast<std::size_t>(c.key.body_b)]);
      inv_w_nn[k] = 1.0 / w.w_nn;
      inv_w_tt[k] = 1.0 / w.w_tt;
      compliance[k] = kappa * w.w_nn;
      mean_diagonal += w.w_nn;
    }
    mean_diagonal /= static_cast<double>(nc);
    // The residual relative to |R| on entry, a fixed scale (relative to the current |R|, a step
    // could lower it by inflating the forces along a self-stress); absolute where every impulse
    // was 0.
    entry_force2 =
        natural_residual(contacts, bodies, inv_dt, inv_w_nn, inv_w_tt, compliance).second;
  }

  /// The merit of the current iterate: its natural-map residual on the fixed scale.
  double merit(const std::vector<Contact>& contacts, const std::vector<SolverBody>& bodies) const {
    const double r2 =
        natural_residual(contacts, bodies, inv_dt, inv_w_nn, inv_w_tt, compliance).first;
    return entry_force2 > 0.0 ? std::sqrt(r2 / entry_force2) : std::sqrt(r2);
  }

  /// The iterate a step starts from (impulses and bodies) and the full Newton iterate, between
  /// which the line search moves: both are on the cone, so is every point between them, and the
  /// bodies' velocities are affine in the impulses.
  void save(const std::vector<Contact>& contacts, const std::vector<SolverBody>& bodies,
            std::vector<SolverBody>& b, Impulses& r) const {
    b = bodies;
    r.resize(nc);
    for (std::size_t k = 0; k < nc; ++k) r[k] = {contacts[k].impulse_n, contacts[k].impulse_t};
  }
  void restore(std::vector<Contact>& contacts, std::vector<SolverBody>& bodies,
               const std::vector<SolverBody>& b, const Impulses& r) const {
    bodies = b;
    for (std::size_t k = 0; k < nc; ++k)
      std::tie(contacts[k].impulse_n, contacts[k].impulse_t) = r[k];
  }
  /// The point lambda of the way from the base iterate to the full Newton iterate.
  void blend(double lambda, std::vector<Contact>& contacts, std::vector<SolverBody>& bodies) const {
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      const SolverBody& b0 = base_bodies[i];
      const SolverBody& b1 = full_bodies[i];
      bodies[i].velocity = b0.velocity + lambda * (b1.velocity - b0.velocity);
      bodies[i].omega = b0.omega + lambda * (b1.omega - b0.omega);
    }
    for (std::size_t k = 0; k < nc; ++k) {
      const auto [n0, t0] = base_impulses[k];
      const auto [n1, t1] = full_impulses[k];
      contacts[k].impulse_n = n0 + lambda * (n1 - n0);
      contacts[k].impulse_t = t0 + lambda * (t1 - t0);
    }
  }

  /// Phases 1 and 2: each contact's status from the current iterate (the Alart-Curnier
  /// classification, rho = 1 / w), its unknowns numbered, open impulses set to 0 and sliding
  /// ones to their thresholds. Returns how many statuses changed (all in the first iteration).
  std::size_t classify(std::vector<Contact>& contacts, std::vector<SolverBody>& bodies, bool first,
                       std::size_t& unknowns) {
    std::size_t changed = 0;
    unknowns = 0;
    for (std::size_t k = 0; k < nc; ++k) {
      Contact& c = contacts[k];
      const ContactVelocity u = contact_velocity(c, bodies, inv_dt);
      const double sigma_n = c.impulse_n - law_velocity_n(c, u, compliance[k]) * inv_w_nn[k];
      std::int8_t next = kOpen;
      if (sigma_n >= 0.0) {
        const double sigma_t = c.impulse_t - u.t * inv_w_tt[k];
        const double limit = c.friction * sigma_n;
        next = std::abs(sigma_t) <= limit ? kStick
               : sigma_t > 0.0            ? kSlidePositive
                                          : kSlideNegative;
      }
      changed += next != status[k] || first;
      status[k] = next;
      if (next == kOpen) {
        unknown[k] = -1;
      } else {
        unknown[k] = static_cast<std::int64_t>(unknowns);
        unknowns += next == kStick ? 2 : 1;
      }
    }
    for (std::size_t k = 0; k < nc; ++k) {
      Contact& c = contacts[k];
      double r_n = c.impulse_n, r_t = c.impulse_t;
      if (status[k] == kOpen) {
        r_n = r_t = 0.0;
      } else if (status[k] != kStick) {
        r_t = sliding_slope(status[k], c.friction) * r_n;
      }
      apply_contact_impulse(c, bodies, r_n - c.impulse_n, r_t - c.impulse_t);
      c.impulse_n = r_n;
      c.impulse_t = r_t;
    }
    return changed;
  }

  /// Phase 3: the right-hand side, minus the constrained velocities (the law's u_n, and u_t of
  /// sticking contacts) of the iterate.
  void constrained_velocities(const std::vector<Contact>& contacts,
                              const std::vector<SolverBody>& bodies, std::size_t unknowns) {
    rhs.assign(unknowns, 0.0);
    for (std::size_t k = 0; k < nc; ++k) {
      if (unknown[k] < 0) continue;
      const ContactVelocity u = contact_velocity(contacts[k], bodies, inv_dt);
      const auto row = static_cast<std::size_t>(unknown[k]);
      rhs[row] = -law_velocity_n(contacts[k], u, compliance[k]);
      if (status[k] == kStick) rhs[row + 1] = -u.t;
    }
  }

  /// Phase 3: B = H_rows M^-1 H_cols^T + C (the regularisation is added by the solves), H_rows:
  /// the constrained velocities, H_cols: the impulse directions of the unknowns (n and t of a
  /// sticking contact; n + s mu t of a sliding one, whose R_t follows s mu R_n), C: each closed
  /// contact's compliance c on its normal unknown's diagonal. B depends on the statuses and the
  /// geometry only, not on the iterate. Null where CHOLMOD runs out of
  /// memory or the system exceeds the int indices CHOLMOD and KLU use here (then the sweeps'
  /// result stands).
  cholmod_sparse* delassus_matrix(const std::vector<Contact>& contacts,
                                  const std::vector<SolverBody>& bodies, std::size_t unknowns) {
    velocities.clear();
    impulses.clear();
    for (std::size_t k = 0; k < nc; ++k) {
      if (unknown[k] < 0) continue;
      const Contact& c = contacts[k];
      const auto ia = static_cast<std::size_t>(c.key.body_a);
      const auto ib = static_cast<std::size_t>(c.key.body_b);
      const SolverBody& a = bodies[ia];
      const SolverBody& b = bodies[ib];
      const Vec2 n = c.normal, t{-n.y, n.x};
      const auto row = static_cast<std::size_t>(unknown[k]);
      velocities.add_row(row, ia, a, ib, b, n, 0.0, 0.0);
      if (status[k] == kStick) {
        impulses.add_row(row, ia, a, ib, b, n, 0.0, 0.0);
        velocities.add_row(row + 1, ia, a, ib, b, t, c.lever_a, c.lever_b);
        impulses.add_row(row + 1, ia, a, ib, b, t, c.lever_a, c.lever_b);
      } else {
        const double st = sliding_slope(status[k], c.friction);
        impulses.add_row(row, ia, a, ib, b, n + st * t, st * c.lever_a, st * c.lever_b);
      }
    }
    constexpr auto kMaxIndex = static_cast<std::size_t>(std::numeric_limits<int>::max());
    if (3 * bodies.size() > kMaxIndex || unknowns > kMaxIndex ||
        std::max(velocities.values.size(), impulses.values.size()) > kMaxIndex)
      return nullptr;
    const auto to_sparse = [&](const Triplets& m) -> cholmod_sparse* {
      cholmod_triplet* triplet = cholmod_allocate_triplet(
          unknowns, 3 * bodies.size(), m.values.size(), 0, CHOLMOD_REAL, &common);
      if (triplet == nullptr) return nullptr;
      std::copy(m.rows.begin(), m.rows.end(), static_cast<int*>(triplet->i));
      std::copy(m.cols.begin(), m.cols.end(), static_cast<int*>(triplet->j));
      std::copy(m.values.begin(), m.values.end(), static_cast<double*>(triplet->x));
      triplet->nnz = m.values.size();
      cholmod_sparse* sparse = cholmod_triplet_to_sparse(triplet, triplet->nnz, &common);
      cholmod_free_triplet(&triplet, &common);
      return sparse;
    };
    cholmod_sparse* h_rows = to_sparse(velocities);
    cholmod_sparse* h_cols = to_sparse(impulses);
    cholmod_sparse* h_cols_t = h_cols ? cholmod_transpose(h_cols, 1, &common) : nullptr;
    cholmod_sparse* b_matrix =
        h_rows && h_cols_t ? cholmod_ssmult(h_rows, h_cols_t, 0, 1, 1, &common) : nullptr;
    cholmod_free_sparse(&h_rows, &common);  // each a no-op on a null pointer
    cholmod_free_sparse(&h_cols, &common);
    cholmod_free_sparse(&h_cols_t, &common);
    if (b_matrix != nullptr) {
      find_diagonal(b_matrix, unknowns);
      add_compliance(b_matrix);
    }
    return b_matrix;
  }

  /// Where B's diagonal entries are in its values (`diagonal`, -1 for an entry the product does
  /// not hold), for the compliance and the regularisation added to them.
  void find_diagonal(const cholmod_sparse* b_matrix, std::size_t unknowns) {
    const auto* bp = static_cast<const int*>(b_matrix->p);
    const auto* bi = static_cast<const int*>(b_matrix->i);
    diagonal.assign(unknowns, -1);
    for (std::size_t j = 0; j < unknowns; ++j)
      for (int q = bp[j]; q < bp[j + 1]; ++q)
        if (static_cast<std::size_t>(bi[q]) == j) diagonal[j] = q;
  }

  /// C of delassus_matrix: c_k added to B's diagonal entry of contact k's normal unknown. The
  /// product always holds that entry (the normal row and the unknown's column act on the same
  /// bodies), kept even where its value cancels.
  void add_compliance(cholmod_sparse* b_matrix) const {
    auto* bx = static_cast<double*>(b_matrix->x);
    for (std::size_t k = 0; k < nc; ++k) {
      if (unknown[k] < 0 || compliance[k] == 0.0) continue;
      const std::int64_t q = diagonal[static_cast<std::size_t>(unknown[k])];
      if (q >= 0) bx[q] += compliance[k];
    }
  }

  /// Ratio test: the longest step along the solution dR, at most 1, that keeps every closed
  /// contact carrying force inside its cone; the first contacts to reach the boundary end on it
  /// (open, or sliding) and change status in the next iteration. Where the statuses leave a
  /// self-stress whose gaps no motion closes, dR runs along it without bound, and the projected
  /// full step zeroes half the forces; this step instead stops where the first contact of the
  /// loop opens, as the exact solution has it.
  double ratio_step(const std::vector<Contact>& contacts) const {
    double step = 1.0;
    for (std::size_t k = 0; k < nc; ++k) step = std::min(step, contact_bound(contacts, k));
    return step;
  }

  /// The longest step along dR that keeps contact k inside its cone (infinite for an open
  /// contact, or one the step does not push out).
  double contact_bound(const std::vector<Contact>& contacts, std::size_t k) const {
    double bound = std::numeric_limits<double>::infinity();
    if (unknown[k] < 0) return bound;
    const Contact& c = contacts[k];
    const auto row = static_cast<std::size_t>(unknown[k]);
    const double dn = solution[row];
    // A closed contact without force that the step would pull: let it open (projection).
    if (c.impulse_n <= 0.0) return bound;
    if (dn < 0.0) bound = std::min(bound, c.impulse_n / -dn);
    if (status[k] == kStick) {
      const double d_t = solution[row + 1];
      const double upper = c.friction * c.impulse_n - c.impulse_t;
      const double lower = c.friction * c.impulse_n + c.impulse_t;
      const double d_upper = c.friction * dn - d_t, d_lower = c.friction * dn + d_t;
      // A contact on its cone's edge (the sweeps leave many) that the step pushes out is
      // projected back: it would otherwise stop the step at 0.
      if (d_upper < 0.0 && upper > 0.0) bound = std::min(bound, upper / -d_upper);
      if (d_lower < 0.0 && lower > 0.0) bound = std::min(bound, lower / -d_lower);
    }
    return bound;
  }

  /// The contacts whose bound is within a relative 1e-9 of `step` (step < 1): those that the
  /// ratio test stops at.
  std::size_t blocking_contacts(const std::vector<Contact>& contacts, double step) const {
    if (!(step < 1.0)) return 0;
    std::size_t count = 0;
    for (std::size_t k = 0; k < nc; ++k) count += contact_bound(contacts, k) <= step * (1 + 1e-9);
    return count;
  }

  /// R + dR projected on the cone, applied to the bodies. Returns |dR| / |R + dR|.
  double apply_solution(std::vector<Contact>& contacts, std::vector<SolverBody>& bodies) const {
    double change2 = 0.0, force2 = 0.0;
    for (std::size_t k = 0; k < nc; ++k) {
      if (unknown[k] < 0) continue;
      Contact& c = contacts[k];
      const auto row = static_cast<std::size_t>(unknown[k]);
      const double r_n = std::max(0.0, c.impulse_n + solution[row]);
      double r_t;
      if (status[k] == kStick) {
        const double limit = c.friction * r_n;
        r_t = std::clamp(c.impulse_t + solution[row + 1], -limit, limit);
      } else {
        r_t = sliding_slope(status[k], c.friction) * r_n;
      }
      const double dn = r_n - c.impulse_n, dtt = r_t - c.impulse_t;
      change2 += dn * dn + dtt * dtt;
      force2 += r_n * r_n + r_t * r_t;
      apply_contact_impulse(c, bodies, dn, dtt);
      c.impulse_n = r_n;
      c.impulse_t = r_t;
    }
    return force2 > 0.0 ? std::sqrt(change2 / force2) : 0.0;
  }

  /// y = (B + beta I) x without forming B: the impulses x applied to bodies at rest (M^-1
  /// H_cols^T x), their constrained velocities read back (H_rows ...), plus C x. O(contacts).
  void multiply(const std::vector<Contact>& contacts, const double* x, double* y, double beta) {
    for (SolverBody& b : product_bodies) {
      b.velocity = Vec2{};
      b.omega = 0.0;
    }
    for (std::size_t k = 0; k < nc; ++k) {
      if (unknown[k] < 0) continue;
      const auto row = static_cast<std::size_t>(unknown[k]);
      apply_contact_impulse(contacts[k], product_bodies, x[row],
                            status[k] == kStick
                                ? x[row + 1]
                                : sliding_slope(status[k], contacts[k].friction) * x[row]);
    }
    for (std::size_t k = 0; k < nc; ++k) {
      if (unknown[k] < 0) continue;
      const auto row = static_cast<std::size_t>(unknown[k]);
      const ContactVelocity u = contact_velocity(contacts[k], product_bodies, 0.0);
      y[row] = u.n + (beta + compliance[k]) * x[row];
      if (status[k] == kStick) y[row + 1] = u.t + beta * x[row + 1];
    }
  }

  /// z = P^-1 v, P: the step's last factorisation, read through the statuses it was made with.
  /// A constrained velocity that both numberings hold (u_n of a contact closed in both, u_t of
  /// one sticking in both) goes through the factorisation; an unknown whose status changed
  /// since is scaled by its diagonal Delassus entry instead. A fixed linear map, so GMRES may
  /// use it; where few statuses changed, P^-1 B is the identity plus a low-rank term.
  void precondition(const double* v, double* z) {
    Factorisation& f = factorisation;
    mapped.assign(f.size, 0.0);
    for (std::size_t k = 0; k < nc; ++k) {
      if (unknown[k] < 0 || f.unknown[k] < 0) continue;
      const auto row = static_cast<std::size_t>(unknown[k]);
      const auto old = static_cast<std::size_t>(f.unknown[k]);
      mapped[old] = v[row];
      if (status[k] == kStick && f.status[k] == kStick) mapped[old + 1] = v[row + 1];
    }
    klu_solve(f.symbolic, f.numeric, static_cast<int>(f.size), 1, mapped.data(), &f.kc);
    for (std::size_t k = 0; k < nc; ++k) {
      if (unknown[k] < 0) continue;
      const auto row = static_cast<std::size_t>(unknown[k]);
      const bool stick = status[k] == kStick;
      if (f.unknown[k] >= 0 && f.status[k] == status[k]) {
        const auto old = static_cast<std::size_t>(f.unknown[k]);
        z[row] = mapped[old];
        if (stick) z[row + 1] = mapped[old + 1];
      } else {
        z[row] = v[row] * inv_w_nn[k];
        if (stick) z[row + 1] = v[row + 1] * inv_w_tt[k];
      }
    }
  }

  /// (B + beta I) dR = rhs by right-preconditioned GMRES (modified Gram-Schmidt, Givens
  /// rotations, no restart) with the step's last factorisation as the preconditioner. True when
  /// the residual fell below kKrylovTolerance |rhs| within kKrylovIterations iterations.
  bool krylov_solve(const std::vector<Contact>& contacts, std::size_t unknowns, double beta) {
    const std::size_t n = unknowns;
    constexpr int m = kKrylovIterations;
    const auto m_size = static_cast<std::size_t>(m);
    basis.resize((m_size + 1) * n);
    images.resize(m_size * n);
    hessenberg.assign((m_size + 1) * m_size, 0.0);
    cosines.assign(m_size, 0.0);
    sines.assign(m_size, 0.0);
    projected.assign(m_size + 1, 0.0);
    const auto h = [&](std::size_t i, std::size_t j) -> double& {
      return hessenberg[i * m_size + j];
    };
    const auto dot = [n](const double* a, const double* b) {
      double sum = 0.0;
      for (std::size_t i = 0; i < n; ++i) sum += a[i] * b[i];
      return sum;
    };
    solution.assign(n, 0.0);
    const double norm_b = std::sqrt(dot(rhs.data(), rhs.data()));
    if (norm_b == 0.0) return true;
    for (std::size_t i = 0; i < n; ++i) basis[i] = rhs[i] / norm_b;
    projected[0] = norm_b;
    std::size_t done = 0;
    bool converged = false;
    for (std::size_t j = 0; j < m_size && !converged; ++j) {
      double* z = &images[j * n];
      double* w = &basis[(j + 1) * n];
      precondition(&basis[j * n], z);
      multiply(contacts, z, w, beta);
      for (int pass = 0; pass < 2; ++pass) {  // twice: B is badly conditioned
        for (std::size_t i = 0; i <= j; ++i) {
          const double* vi = &basis[i * n];
          const double c = dot(w, vi);
          h(i, j) += c;
          for (std::size_t q = 0; q < n; ++q) w[q] -= c * vi[q];
        }
      }
      const double norm_w = std::sqrt(dot(w, w));
      h(j + 1, j) = norm_w;
      if (norm_w > 0.0)
        for (std::size_t q = 0; q < n; ++q) w[q] /= norm_w;
      for (std::size_t i = 0; i < j; ++i) {
        const double a = h(i, j), b = h(i + 1, j);
        h(i, j) = cosines[i] * a + sines[i] * b;
        h(i + 1, j) = -sines[i] * a + cosines[i] * b;
      }
      const double r = std::hypot(h(j, j), h(j + 1, j));
      if (r == 0.0) break;
      cosines[j] = h(j, j) / r;
      sines[j] = h(j + 1, j) / r;
      h(j, j) = r;
      h(j + 1, j) = 0.0;
      projected[j + 1] = -sines[j] * projected[j];
      projected[j] *= cosines[j];
      done = j + 1;
      converged = std::abs(projected[j + 1]) <= kKrylovTolerance * norm_b || norm_w == 0.0;
    }
    if (!converged) return false;
    // y from the triangular system, dR = sum y_j z_j.
    std::vector<double>& y = work;
    y.assign(done, 0.0);
    for (std::size_t i = done; i-- > 0;) {
      double sum = projected[i];
      for (std::size_t j = i + 1; j < done; ++j) sum -= h(i, j) * y[j];
      y[i] = sum / h(i, i);
    }
    for (std::size_t j = 0; j < done; ++j)
      for (std::size_t q = 0; q < n; ++q) solution[q] += y[j] * images[j * n + q];
    return true;
  }

  /// How many contacts' statuses differ from those the kept factorisation was made with.
  std::size_t changed_since_factorisation() const {
    std::size_t changed = 0;
    for (std::size_t k = 0; k < nc; ++k) changed += status[k] != factorisation.status[k];
    return changed;
  }

  /// (B + beta I) dR = rhs by KLU. The factorisation is kept as the preconditioner of later
  /// iterations, a larger regularisation's too (so the next iteration factorises anew: keeping
  /// the first attempt's instead measured slower, 20 against 32 steps per CPU second on system
  /// 5 at V = 0.5). `added`: the regularisation already in B's values; `analysed`: whether the
  /// kept symbolic analysis is B's (then only the numeric factorisation is redone).
  bool factorise_and_solve(cholmod_sparse* b_matrix, std::size_t unknowns, double beta,
                           double& added, bool& analysed) {
    Factorisation& f = factorisation;
    auto* bp = static_cast<int*>(b_matrix->p);
    auto* bi = static_cast<int*>(b_matrix->i);
    auto* bx = static_cast<double*>(b_matrix->x);
    const int nu = static_cast<int>(unknowns);
    if (!analysed) {
      f.release();
      klu_defaults(&f.kc);
      f.symbolic = klu_analyze(nu, bp, bi, &f.kc);
      if (f.symbolic == nullptr) return false;
      analysed = true;
    } else if (f.numeric) {
      klu_free_numeric(&f.numeric, &f.kc);
    }
    for (std::size_t j = 0; j < unknowns; ++j)
      if (diagonal[j] >= 0) bx[diagonal[j]] += beta - added;
    added = beta;
    f.numeric = klu_factor(bp, bi, bx, f.symbolic, &f.kc);
    if (f.numeric == nullptr) return false;
    f.status = status;
    f.unknown = unknown;
    f.size = unknowns;
    f.beta = beta;
    solution = rhs;
    return klu_solve(f.symbolic, f.numeric, nu, 1, solution.data(), &f.kc) != 0;
  }

  /// Phases 4 and 5: solve (B + beta I) dR = rhs, R + dR on the cone, applied; then a line
  /// search on the merit between the iterate this iteration started from and that one. The
  /// first iteration of a step factorises B (KLU); a later one solves by GMRES with that
  /// factorisation as its preconditioner, where only a few statuses changed since (most
  /// iterations: B is then factorised anew only if GMRES does not converge). Without descent,
  /// again with a regularisation 1000 times larger (Levenberg-Marquardt, factorised): where the
  /// statuses are wrong the system can be singular with a right-hand side outside its range,
  /// and its exact solution is useless. True when the merit went below `accept` (the
  /// non-monotone search's bound; `current` then holds it); false also where B is too large to
  /// form (report.factorised then false).
  bool solve_and_search(std::vector<Contact>& contacts, std::vector<SolverBody>& bodies,
                        std::size_t unknowns, const ActiveSetOptions& options, double& current,
                        double accept, ActiveSetReport& report, ActiveSetIteration* record) {
    constrained_velocities(contacts, bodies, unknowns);
    save(contacts, bodies, start_bodies, start_impulses);  // where every solve starts from
    cholmod_sparse* b_matrix = nullptr;
    bool descended = false, any_solved = false, analysed = false;
    double beta = options.regularisation * mean_diagonal, added = 0.0;
    const bool reuse = factorisation.valid() && factorisation.beta == beta &&
                       changed_since_factorisation() <= kKrylovChangedStatuses;
    for (int attempt = 0; attempt < kRegularisationAttempts; ++attempt, beta *= 1e3) {
      bool solved = attempt == 0 && reuse && krylov_solve(contacts, unknowns, beta);
      const bool solved_by_krylov = solved;
      report.krylov_solves += solved;
      if (!solved) {
        if (b_matrix == nullptr) b_matrix = delassus_matrix(contacts, bodies, unknowns);
        if (b_matrix == nullptr) break;
        solved = factorise_and_solve(b_matrix, unknowns, beta, added, analysed);
        ++report.factorisations;
      }
      if (!solved) continue;
      any_solved = true;
      restore(contacts, bodies, start_bodies, start_impulses);
      // The ratio test on the first attempt only.
      const double step = ratio_step(contacts);
      if (record != nullptr && attempt == 0) {
        double solution2 = 0.0, force2 = 0.0;
        for (const double x : solution) solution2 += x * x;
        for (const Contact& c : contacts)
          force2 += c.impulse_n * c.impulse_n + c.impulse_t * c.impulse_t;
        record->newton_norm = force2 > 0.0 ? std::sqrt(solution2 / force2) : 0.0;
      }
      if (attempt == 0 && step > 0.0 && step < 1.0) {
        if (record != nullptr) {
          record->ratio_step = step;
          record->blocking = blocking_contacts(contacts, step);
        }
        for (double& x : solution) x *= step;
      }
      report.correction = apply_solution(contacts, bodies);
      double next = merit(contacts, bodies), line_step = 1.0;
      if (!(next < accept)) {
        save(contacts, bodies, full_bodies, full_impulses);
        for (line_step = 0.5; line_step >= kSmallestStep; line_step *= 0.5) {
          blend(line_step, contacts, bodies);
          next = merit(contacts, bodies);
          if (next < accept) break;
        }
      }
      if (next < accept) {
        current = next;
        descended = true;
        if (record != nullptr) {
          record->line_step = line_step;
          record->attempt = attempt;
          record->by_krylov = solved_by_krylov;
        }
        break;
      }
    }
    cholmod_free_sparse(&b_matrix, &common);  // a no-op on a null pointer
    if (!descended) report.factorised = any_solved;
    return descended;
  }
};

ActiveSetSolver::ActiveSetSolver() : impl_(std::make_unique<Impl>()) {}
ActiveSetSolver::~ActiveSetSolver() = default;
ActiveSetSolver::ActiveSetSolver(const ActiveSetSolver&) : impl_(std::make_unique<Impl>()) {}
ActiveSetSolver& ActiveSetSolver::operator=(const ActiveSetSolver&) {
  return *this;
}

ActiveSetReport ActiveSetSolver::refine(std::vector<Contact>& contacts,
                                        std::vector<SolverBody>& bodies, double dt,
                                        const ActiveSetOptions& options) {
  Impl& s = *impl_;
  ActiveSetReport report;
  if (contacts.empty()) return report;
  report.ran = true;
  s.begin(contacts, bodies, dt, options.normal_compliance);
  double current = s.merit(contacts, bodies);
  report.initial_residual = current;
  std::deque<double> history{current};  // the merits of the last kMeritMemory iterates
  double best = current;                // lowered only together with best_bodies, best_impulses
  for (int iteration = 1; iteration <= options.max_iterations && current > options.tolerance;
       ++iteration) {
    report.iterations = iteration;
    s.save(contacts, bodies, s.base_bodies, s.base_impulses);
    if (current <= best) {  // the best iterate so far: returned if the last is worse
      best = current;
      s.best_bodies = s.base_bodies;
      s.best_impulses = s.base_impulses;
    }
    std::size_t unknowns = 0;
    report.changed = s.classify(contacts, bodies, iteration == 1, unknowns);
    report.unknowns = unknowns;
    if (unknowns == 0) {  // every contact open: R = 0 is the step, if it is better
      const double open = s.merit(contacts, bodies);
      if (open < current)
        current = open;
      else
        s.restore(contacts, bodies, s.base_bodies, s.base_impulses);
      if (options.record_history) {
        ActiveSetIteration record;
        record.changed = report.changed;
        record.open = s.nc;
        record.residual = current;
        report.history.push_back(record);
      }
      break;
    }
    const double accept = *std::max_element(history.begin(), history.end());
    ActiveSetIteration record;
    if (options.record_history) {
      record.changed = report.changed;
      record.unknowns = unknowns;
      for (std::size_t k = 0; k < s.nc; ++k) {
        record.open += s.status[k] == kOpen;
        record.stick += s.status[k] == kStick;
      }
      record.slide = s.nc - record.open - record.stick;
    }
    const bool descended = s.solve_and_search(contacts, bodies, unknowns, options, current, accept,
                                              report, options.record_history ? &record : nullptr);
    if (options.record_history) {
      if (!descended) record.line_step = 0.0;
      record.residual = descended ? current : history.back();
      report.history.push_back(record);
    }
    if (!descended) {  // back to the iterate this iteration started from
      s.restore(contacts, bodies, s.base_bodies, s.base_impulses);
      break;
    }
    history.push_back(current);
    if (history.size() > kMeritMemory) history.pop_front();
  }
  if (best < current) {
    s.restore(contacts, bodies, s.best_bodies, s.best_impulses);
    current = best;
  }
  report.residual = current;
  report.converged = current <= options.tolerance;
  return report;
}

}  // namespace cdshear
