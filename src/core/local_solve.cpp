#include "local_solve.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cdshear {

LocalSolution solve_local(const LocalProblem& p) {
  if (p.b_n >= 0.0) return {0.0, 0.0, LocalStatus::kSeparated};

  const double det = p.w_nn * p.w_tt - p.w_nt * p.w_nt;
  const double stick_n = (-p.b_n * p.w_tt + p.b_t * p.w_nt) / det;
  const double stick_t = (-p.b_t * p.w_nn + p.b_n * p.w_nt) / det;
  if (stick_n > 0.0 && std::abs(stick_t) <= p.mu * stick_n)
    return {stick_n, stick_t, LocalStatus::kSticking};

  for (const double s : {1.0, -1.0}) {
    const double denom = p.w_nn - s * p.mu * p.w_nt;
    if (denom <= 0.0) continue;
    const double r_n = -p.b_n / denom;
    const double r_t = -s * p.mu * r_n;
    const double u_t = p.b_t + p.w_nt * r_n + p.w_tt * r_t;
    if (s * u_t >= 0.0)
      return {r_n, r_t, s > 0 ? LocalStatus::kSlidingPositive : LocalStatus::kSlidingNegative};
  }

  // Round-off guard: with w_nn > mu |w_nt| an exact case always exists (local_solve.hpp), so
  // reaching this point means the solution lies on the stick/slide boundary and rounding
  // rejected both tests (|R_t| a few ulps above mu R_n, s u_t a few ulps below 0). There the
  // sticking and sliding solutions coincide: return the sliding candidate whose u_t is least on
  // the wrong side; it satisfies Signorini exactly, unlike the projection below.
  if (p.w_nn > p.mu * std::abs(p.w_nt)) {
    LocalSolution best;
    double best_slip = -std::numeric_limits<double>::infinity();
    for (const double s : {1.0, -1.0}) {
      const double r_n = -p.b_n / (p.w_nn - s * p.mu * p.w_nt);
      const double r_t = -s * p.mu * r_n;
      const double slip = s * (p.b_t + p.w_nt * r_n + p.w_tt * r_t);
      if (slip > best_slip) {
        best_slip = slip;
        best = {r_n, r_t, s > 0 ? LocalStatus::kSlidingPositive : LocalStatus::kSlidingNegative};
      }
    }
    return best;
  }

  // Fallback (no exact case, possible only when mu |w_nt| >= w_nn): normal from u_n = 0 with no
  // friction, friction clamped to the cone.
  const double r_n = std::max(0.0, -p.b_n / p.w_nn);
  const double r_t = std::clamp(stick_t, -p.mu * r_n, p.mu * r_n);
  return {r_n, r_t, LocalStatus::kProjected};
}

}  // namespace cdshear
