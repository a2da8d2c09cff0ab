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
    const double e2 = contact_law_violation2(u_n, u_t, c.impulse_n, c.impulse_t, c.friction);
    r.largest = std::max(r.largest, std::sqrt(e2));
    if (impulse_status(c) != ImpulseStatus::kOpen) {
      sum2 += e2;
      ++r.carrying;
    }
  }
  if (r.carrying > 0) r.rms_carrying = std::sqrt(sum2 / static_cast<double>(r.carrying));
  return r;
}

}  // namespace cdshear
