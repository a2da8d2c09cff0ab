#include "projected_gradient.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace cdshear {

namespace {

/// Biased relative velocity (the gradient) of row r in the bodies' velocities.
inline void row_velocity(const SolverRow& r, const std::vector<SolverBody>& bodies, double& u_n,
                         double& u_t) {
  const SolverBody& a = bodies[r.body_a];
  const SolverBody& b = bodies[r.body_b];
  const double dvx = a.velocity.x - b.velocity.x;
  const double dvy = a.velocity.y - b.velocity.y;
  u_n = dvx * r.normal.x + dvy * r.normal.y + r.bias_n;
  u_t = dvy * r.normal.x - dvx * r.normal.y + r.lever_a * a.omega + r.lever_b * b.omega;
}

/// The descent direction -u projected on the tangent cone of the set at R (Tresca threshold
/// mu R_n): a component pushing out of the set at its bound is held (0).
inline void projected_descent(const SolverRow& r, double u_n, double u_t, double& w_n,
                              double& w_t) {
  w_n = (r.impulse_n <= 0.0 && u_n > 0.0) ? 0.0 : -u_n;
  const double limit = r.friction * r.impulse_n;
  const bool at_top = r.impulse_t >= limit && u_t < 0.0;
  const bool at_bottom = r.impulse_t <= -limit && u_t > 0.0;
  w_t = (at_top || at_bottom) ? 0.0 : -u_t;
}

}  // namespace

void solve_by_projected_gradient(std::vector<SolverRow>& rows,
                                 const std::vector<DelassusEntries>& delassus,
                                 std::vector<SolverBody>& bodies, const SolverOptions& options,
                                 ProjectedGradientScratch& s, SolverReport& report) {
  const std::size_t n = rows.size();
  s.descent.resize(2 * n);
  s.direction.resize(2 * n);
  s.w_times_p.resize(2 * n);
  s.held.resize(2 * n);
  s.body_change.resize(3 * bodies.size());
  auto& w = s.descent;
  auto& p = s.direction;
  auto& wp = s.w_times_p;
  auto& dv = s.body_change;

  // z = D^-1 w, the preconditioned descent; returns nothing, writes w and z (into p's slot
  // when `first`).
  const auto precondition = [&](std::size_t i, double w_n, double w_t, double& z_n,
                                double& z_t) {
    z_n = w_n * rows[i].inv_w_nn;
    z_t = w_t / delassus[i].w_tt;
  };

  // Initial direction: the preconditioned projected descent.
  for (std::size_t i = 0; i < n; ++i) {
    double u_n, u_t;
    row_velocity(rows[i], bodies, u_n, u_t);
    projected_descent(rows[i], u_n, u_t, w[2 * i], w[2 * i + 1]);
    precondition(i, w[2 * i], w[2 * i + 1], p[2 * i], p[2 * i + 1]);
  }

  for (int it = 1; it <= options.max_sweeps; ++it) {
    // W p = H M^-1 H^T p: scatter p to the bodies, gather it back.
    std::fill(dv.begin(), dv.end(), 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const SolverRow& r = rows[i];
      const double pn = p[2 * i], pt = p[2 * i + 1];
      const double px = pn * r.normal.x - pt * r.normal.y;
      const double py = pn * r.normal.y + pt * r.normal.x;
      const SolverBody& a = bodies[r.body_a];
      const SolverBody& b = bodies[r.body_b];
      double* da = &dv[3 * r.body_a];
      double* db = &dv[3 * r.body_b];
      da[0] += a.inv_mass.x * px;
      da[1] += a.inv_mass.y * py;
      da[2] += a.inv_inertia * r.lever_a * pt;
      db[0] -= b.inv_mass.x * px;
      db[1] -= b.inv_mass.y * py;
      db[2] += b.inv_inertia * r.lever_b * pt;
    }
    double p_wp = 0.0, w_p = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const SolverRow& r = rows[i];
      const double* da = &dv[3 * r.body_a];
      const double* db = &dv[3 * r.body_b];
      const double dvx = da[0] - db[0], dvy = da[1] - db[1];
      wp[2 * i] = dvx * r.normal.x + dvy * r.normal.y;
      wp[2 * i + 1] = dvy * r.normal.x - dvx * r.normal.y + r.lever_a * da[2] + r.lever_b * db[2];
      p_wp += p[2 * i] * wp[2 * i] + p[2 * i + 1] * wp[2 * i + 1];
      w_p += w[2 * i] * p[2 * i] + w[2 * i + 1] * p[2 * i + 1];
    }
    // Line minimum along p (p W p > 0 unless p moves no body: then nothing is left to do).
    const double step = p_wp > 0.0 ? w_p / p_wp : 0.0;

    // Step and project; the bodies follow the change of each impulse.
    std::size_t converged = 0, carrying = 0;
    double sum_change = 0.0, sum_force = 0.0;
    std::size_t clipped = 0;
    for (std::size_t i = 0; i < n; ++i) {
      SolverRow& r = rows[i];
      const double trial_n = r.impulse_n + step * p[2 * i];
      const double r_n = std::max(0.0, trial_n);
      const double limit = r.friction * r_n;
      const double trial_t = r.impulse_t + step * p[2 * i + 1];
      const double r_t = std::clamp(trial_t, -limit, limit);
      clipped += (trial_n < 0.0 && p[2 * i] != 0.0) || (r_t != trial_t && p[2 * i + 1] != 0.0);
      const double dn = r_n - r.impulse_n, dt = r_t - r.impulse_t;
      SolverBody& a = bodies[r.body_a];
      SolverBody& b = bodies[r.body_b];
      const double px = dn * r.normal.x - dt * r.normal.y;
      const double py = dn * r.normal.y + dt * r.normal.x;
      a.velocity.x += a.inv_mass.x * px;
      a.velocity.y += a.inv_mass.y * py;
      b.velocity.x -= b.inv_mass.x * px;
      b.velocity.y -= b.inv_mass.y * py;
      a.omega += a.inv_inertia * r.lever_a * dt;
      b.omega += b.inv_inertia * r.lever_b * dt;
      r.impulse_n = r_n;
      r.impulse_t = r_t;
      const double change2 = dn * dn + dt * dt, force2 = r_n * r_n + r_t * r_t;
      const bool carries = r_n > 0.0 || dn != 0.0;
      carrying += carries;
      converged += carries && change2 <= options.alpha * force2;
      sum_change += std::sqrt(change2);
      sum_force += std::sqrt(force2);
    }

    // New descent, and the next direction W-conjugate to p.
    double z_wp = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      double u_n, u_t;
      row_velocity(rows[i], bodies, u_n, u_t);
      projected_descent(rows[i], u_n, u_t, w[2 * i], w[2 * i + 1]);
      double z_n, z_t;
      precondition(i, w[2 * i], w[2 * i + 1], z_n, z_t);
      z_wp += z_n * wp[2 * i] + z_t * wp[2 * i + 1];
      // z stored in `held` form: p is rebuilt below, so keep z in wp's slot (wp is consumed).
      wp[2 * i] = z_n;
      wp[2 * i + 1] = z_t;
    }
    const double beta = p_wp > 0.0 && clipped == 0 ? std::max(0.0, -z_wp / p_wp) : 0.0;
    if (std::getenv("CPG_TRACE")) std::fprintf(stderr, "it %d step %.3g beta %.3g clipped %zu change %.3g\n", it, step, beta, clipped, sum_change / sum_force);
    for (std::size_t k = 0; k < 2 * n; ++k)
      p[k] = w[k] == 0.0 ? 0.0 : wp[k] + beta * p[k];

    report.sweeps = it;
    report.converged_fraction =
        carrying > 0 ? static_cast<double>(converged) / static_cast<double>(carrying) : 1.0;
    if (sum_force > 0.0) {
      const double ratio = sum_change / sum_force;
      report.residual = ratio * ratio;
    } else {
      report.residual = sum_change > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
    }
    if (report.converged_fraction >= options.converged_fraction &&
        report.residual <= options.alpha)
      return;
    if (step == 0.0 && beta == 0.0) return;  // nothing moves
  }
  report.hit_cap = true;
}

}  // namespace cdshear

namespace cdshear {

void solve_by_accelerated_gradient(std::vector<SolverRow>& rows,
                                   const std::vector<DelassusEntries>& delassus,
                                   std::vector<SolverBody>& bodies, const SolverOptions& options,
                                   ProjectedGradientScratch& s, SolverReport& report) {
  const std::size_t n = rows.size(), nb = bodies.size();
  const char* env_t = std::getenv("APGD_STEP");
  const double t_step = env_t ? std::atof(env_t) : 0.3;
  auto& prev = s.descent;     // R_{k-1}: 2 per row
  auto& next = s.direction;   // R_{k+1}
  s.body_change.resize(9 * nb);
  double* v = s.body_change.data();        // v_k
  double* v_prev = v + 3 * nb;             // v_{k-1}
  double* v_y = v + 6 * nb;                // v(y), then v_{k+1}
  prev.resize(2 * n);
  next.resize(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    prev[2 * i] = rows[i].impulse_n;
    prev[2 * i + 1] = rows[i].impulse_t;
  }
  for (std::size_t b = 0; b < nb; ++b) {
    v[3 * b] = v_prev[3 * b] = bodies[b].velocity.x;
    v[3 * b + 1] = v_prev[3 * b + 1] = bodies[b].velocity.y;
    v[3 * b + 2] = v_prev[3 * b + 2] = bodies[b].omega;
  }
  double theta = 1.0;
  for (int it = 1; it <= options.max_sweeps; ++it) {
    const double theta_next = 0.5 * (std::sqrt(theta * theta * theta * theta + 4.0 * theta * theta) -
                                     theta * theta);
    const double beta = theta * (1.0 - theta) / (theta * theta + theta_next);
    for (std::size_t k = 0; k < 3 * nb; ++k) v_y[k] = v[k] + beta * (v[k] - v_prev[k]);
    std::size_t converged = 0, carrying = 0;
    double sum_change = 0.0, sum_force = 0.0, restart_test = 0.0;
    // One pass: u(y) gathered from v_y... but the scatter must not disturb the gather: gather
    // all first into next[], then scatter.
    for (std::size_t i = 0; i < n; ++i) {
      const SolverRow& r = rows[i];
      const double y_n = r.impulse_n + beta * (r.impulse_n - prev[2 * i]);
      const double y_t = r.impulse_t + beta * (r.impulse_t - prev[2 * i + 1]);
      const double* a = v_y + 3 * r.body_a;
      const double* b = v_y + 3 * r.body_b;
      const double dvx = a[0] - b[0], dvy = a[1] - b[1];
      const double u_n = dvx * r.normal.x + dvy * r.normal.y + r.bias_n;
      const double u_t = dvy * r.normal.x - dvx * r.normal.y + r.lever_a * a[2] + r.lever_b * b[2];
      const double r_n = std::max(0.0, y_n - t_step * u_n * r.inv_w_nn);
      const double limit = r.friction * r_n;
      const double r_t = std::clamp(y_t - t_step * u_t / delassus[i].w_tt, -limit, limit);
      next[2 * i] = r_n;
      next[2 * i + 1] = r_t;
    }
    for (std::size_t i = 0; i < n; ++i) {
      SolverRow& r = rows[i];
      const double y_n = r.impulse_n + beta * (r.impulse_n - prev[2 * i]);
      const double y_t = r.impulse_t + beta * (r.impulse_t - prev[2 * i + 1]);
      const double dn = next[2 * i] - y_n, dt = next[2 * i + 1] - y_t;
      const SolverBody& A = bodies[r.body_a];
      const SolverBody& B = bodies[r.body_b];
      double* a = v_y + 3 * r.body_a;
      double* b = v_y + 3 * r.body_b;
      const double px = dn * r.normal.x - dt * r.normal.y;
      const double py = dn * r.normal.y + dt * r.normal.x;
      a[0] += A.inv_mass.x * px;
      a[1] += A.inv_mass.y * py;
      a[2] += A.inv_inertia * r.lever_a * dt;
      b[0] -= B.inv_mass.x * px;
      b[1] -= B.inv_mass.y * py;
      b[2] += B.inv_inertia * r.lever_b * dt;
      const double cn = next[2 * i] - r.impulse_n, ct = next[2 * i + 1] - r.impulse_t;
      restart_test += (y_n - next[2 * i]) * cn + (y_t - next[2 * i + 1]) * ct;
      const double change2 = cn * cn + ct * ct;
      const double force2 = next[2 * i] * next[2 * i] + next[2 * i + 1] * next[2 * i + 1];
      const bool carries = next[2 * i] > 0.0 || cn != 0.0;
      carrying += carries;
      converged += carries && change2 <= options.alpha * force2;
      sum_change += std::sqrt(change2);
      sum_force += std::sqrt(force2);
      prev[2 * i] = r.impulse_n;
      prev[2 * i + 1] = r.impulse_t;
      r.impulse_n = next[2 * i];
      r.impulse_t = next[2 * i + 1];
    }
    std::copy(v, v + 3 * nb, v_prev);
    std::copy(v_y, v_y + 3 * nb, v);
    theta = theta_next;
    if (restart_test > 0.0) theta = 1.0;  // gradient restart (O'Donoghue and Candes)
    report.sweeps = it;
    report.converged_fraction =
        carrying > 0 ? static_cast<double>(converged) / static_cast<double>(carrying) : 1.0;
    report.residual = sum_force > 0.0 ? (sum_change / sum_force) * (sum_change / sum_force) : 0.0;
    if (std::getenv("CPG_TRACE")) std::fprintf(stderr, "it %d beta %.3g change %.3g\n", it, beta, sum_change / sum_force);
    if (report.converged_fraction >= options.converged_fraction &&
        report.residual <= options.alpha)
      break;
  }
  if (report.sweeps == options.max_sweeps) report.hit_cap = true;
  for (std::size_t b = 0; b < nb; ++b) {
    bodies[b].velocity.x = v[3 * b];
    bodies[b].velocity.y = v[3 * b + 1];
    bodies[b].omega = v[3 * b + 2];
  }
}

}  // namespace cdshear
