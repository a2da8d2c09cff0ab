#include "nlgs_solver.hpp"

#include <cmath>
#include <limits>
#include <numeric>

#include "local_solve.hpp"
#include "random.hpp"

namespace cdshear {
namespace {

/// Delassus entries of one contact: W = sum over its two bodies of H_body M_body^-1 H_body^T with
/// H rows (n, lever) and (t, lever) in (translation, rotation) coordinates.
void fill_delassus(Contact& c, const SolverBody& a, const SolverBody& b) {
  const Vec2 n = c.normal, t = c.tangent;
  const Vec2 mn = hadamard(a.inv_mass, n) + hadamard(b.inv_mass, n);
  const Vec2 mt = hadamard(a.inv_mass, t) + hadamard(b.inv_mass, t);
  c.w_nn = dot(n, mn);
  c.w_nt = dot(n, mt);
  c.w_tt =
      dot(t, mt) + c.lever_a * c.lever_a * a.inv_inertia + c.lever_b * c.lever_b * b.inv_inertia;
}

/// Applies impulse (dn, dt) of contact c: +P on a, -P on b, torques lever * dt on both.
inline void apply_impulse(const Contact& c, SolverBody& a, SolverBody& b, double dn, double dt) {
  const Vec2 p = dn * c.normal + dt * c.tangent;
  a.velocity += hadamard(a.inv_mass, p);
  b.velocity -= hadamard(b.inv_mass, p);
  a.omega += a.inv_inertia * c.lever_a * dt;
  b.omega += b.inv_inertia * c.lever_b * dt;
}

}  // namespace

SolverReport solve_contacts(std::vector<Contact>& contacts, std::vector<SolverBody>& bodies,
                            double dt, const SolverOptions& options, std::uint64_t step,
                            SolverWorkspace& workspace) {
  SolverReport report;
  const std::size_t nc = contacts.size();
  if (nc == 0) return report;

  // Prepare: Delassus matrices, then warm start (apply the carried-over impulses).
  for (Contact& c : contacts) {
    SolverBody& a = bodies[c.key.body_a];
    SolverBody& b = bodies[c.key.body_b];
    fill_delassus(c, a, b);
    if (c.impulse_n != 0.0 || c.impulse_t != 0.0) apply_impulse(c, a, b, c.impulse_n, c.impulse_t);
  }

  auto& order = workspace.order;
  order.resize(nc);
  std::iota(order.begin(), order.end(), 0u);
  if (options.order == ContactOrder::kRandom) {
    CounterRandom rng(options.seed, RandomStream::kContactOrder, step);
    shuffle(order, rng);
  }

  const double inv_dt = 1.0 / dt;
  for (int sweep = 1; sweep <= options.max_sweeps; ++sweep) {
    std::size_t converged = 0, carrying = 0;
    double sum_change = 0.0, sum_force = 0.0;
    for (const std::uint32_t k : order) {
      Contact& c = contacts[k];
      SolverBody& a = bodies[c.key.body_a];
      SolverBody& b = bodies[c.key.body_b];
      const Vec2 dv = a.velocity - b.velocity;
      const double u_n = dot(dv, c.normal);
      const double u_t = dot(dv, c.tangent) + c.lever_a * a.omega + c.lever_b * b.omega;
      LocalProblem p;
      p.w_nn = c.w_nn;
      p.w_nt = c.w_nt;
      p.w_tt = c.w_tt;
      p.b_n = u_n - (c.w_nn * c.impulse_n + c.w_nt * c.impulse_t) + c.gap * inv_dt;
      p.b_t = u_t - (c.w_nt * c.impulse_n + c.w_tt * c.impulse_t);
      p.mu = c.friction;
      const LocalSolution s = solve_local(p);
      const double dn = s.r_n - c.impulse_n, dtt = s.r_t - c.impulse_t;
      if (dn != 0.0 || dtt != 0.0) apply_impulse(c, a, b, dn, dtt);
      c.impulse_n = s.r_n;
      c.impulse_t = s.r_t;

      // Only contacts that carry force (before or after this update) take part in the count:
      // idle candidates (R = 0 staying 0) would otherwise pass for free, and the criterion would
      // depend on the contact margin.
      const double change2 = dn * dn + dtt * dtt;
      const double force2 = s.r_n * s.r_n + s.r_t * s.r_t;
      const bool carries = s.r_n > 0.0 || dn != 0.0;
      carrying += carries;
      converged += carries && change2 <= options.alpha * force2;
      sum_change += std::sqrt(change2);
      sum_force += std::sqrt(force2);
    }
    report.sweeps = sweep;
    report.converged_fraction =
        carrying > 0 ? static_cast<double>(converged) / static_cast<double>(carrying) : 1.0;
    if (sum_force > 0.0)
      report.residual = (sum_change / sum_force) * (sum_change / sum_force);
    else
      report.residual = sum_change > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
    if (report.converged_fraction >= options.converged_fraction && report.residual <= options.alpha)
      break;
    if (sweep == options.max_sweeps) report.hit_cap = true;
  }
  for (const Contact& c : contacts) report.active_contacts += c.impulse_n > 0.0;
  return report;
}

}  // namespace cdshear
