#include "velocity_residual.hpp"

#include <algorithm>
#include <cmath>

namespace cdshear {

VelocityResidual velocity_residual(const std::vector<Contact>& contacts,
                                   const std::vector<SolverBody>& bodies, double dt) {
  VelocityResidual r;
  const double inv_dt = 1.0 / dt;
  double sum2 = 0.0;
  for (const Contact& c : contacts) {
    const auto [u_n, u_t] = contact_velocity(c, bodies, inv_dt);
    const ImpulseStatus status = impulse_status(c);
    double e_n = 0.0, e_t = 0.0;
    if (status == ImpulseStatus::kOpen) {
      e_n = std::max(0.0, -u_n);
    } else {
      e_n = std::abs(u_n);
      if (c.friction == 0.0)
        e_t = 0.0;  // frictionless: free to slide either way
      else if (status == ImpulseStatus::kSticking)
        e_t = std::abs(u_t);
      else
        e_t = std::max(0.0, c.impulse_t > 0.0 ? u_t : -u_t);
    }
    const double e2 = e_n * e_n + e_t * e_t;
    r.largest = std::max(r.largest, std::sqrt(e2));
    if (status != ImpulseStatus::kOpen) {
      sum2 += e2;
      ++r.carrying;
    }
  }
  if (r.carrying > 0) r.rms_carrying = std::sqrt(sum2 / static_cast<double>(r.carrying));
  return r;
}

}  // namespace cdshear
