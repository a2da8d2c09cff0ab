#include "velocity_residual.hpp"

#include <algorithm>
#include <cmath>

#include "threads.hpp"

namespace cdshear {

VelocityResidual velocity_residual(const std::vector<Contact>& contacts,
                                   const std::vector<SolverBody>& bodies, double dt, int threads) {
  // Chunks of kChunk contacts whatever the thread count: each chunk's sums, then the chunks'
  // added in chunk order, so that the figures do not depend on the threads (a maximum and a
  // count are exact in any order).
  constexpr std::size_t kChunk = 512;
  const std::size_t chunks = (contacts.size() + kChunk - 1) / kChunk;
  std::vector<VelocityResidual> parts(chunks);
  std::vector<double> sums2(chunks, 0.0);
  const double inv_dt = 1.0 / dt;
  for_shares(threads, chunks, [&](std::size_t first, std::size_t last, std::size_t) {
    for (std::size_t chunk = first; chunk < last; ++chunk) {
      VelocityResidual& part = parts[chunk];
      double sum2 = 0.0;
      const std::size_t end = std::min(contacts.size(), (chunk + 1) * kChunk);
      for (std::size_t i = chunk * kChunk; i < end; ++i) {
        const Contact& c = contacts[i];
        const auto [u_n, u_t] = contact_velocity(c, bodies, inv_dt);
        const double e2 = contact_law_violation2(u_n, u_t, c.impulse_n, c.impulse_t, c.friction);
        part.largest = std::max(part.largest, std::sqrt(e2));
        if (impulse_status(c) != ImpulseStatus::kOpen) {
          sum2 += e2;
          ++part.carrying;
        }
      }
      sums2[chunk] = sum2;
    }
  });
  VelocityResidual r;
  double sum2 = 0.0;
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    r.largest = std::max(r.largest, parts[chunk].largest);
    r.carrying += parts[chunk].carrying;
    sum2 += sums2[chunk];
  }
  if (r.carrying > 0) r.rms_carrying = std::sqrt(sum2 / static_cast<double>(r.carrying));
  return r;
}

}  // namespace cdshear
