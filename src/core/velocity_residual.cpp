#include "velocity_residual.hpp"

#include <algorithm>
#include <cmath>

#include "threads.hpp"

namespace cdshear {

VelocityResidual velocity_residual(const std::vector<Contact>& contacts,
                                   const std::vector<SolverBody>& bodies, double dt, int threads,
                                   double normal_compliance) {
  // Chunks of kChunk contacts whatever the thread count: each chunk's sums, then the chunks'
  // added in chunk order, so that the figures do not depend on the threads (a maximum and a
  // count are exact in any order).
  constexpr std::size_t kChunk = 512;
  struct ChunkSums {
    double largest = 0.0, sum2 = 0.0;  ///< largest e, sum of e^2 over the force-carrying ones
    std::size_t carrying = 0;
  };
  std::vector<ChunkSums> chunk_sums((contacts.size() + kChunk - 1) / kChunk);
  const double inv_dt = 1.0 / dt;
  for_shares(threads, chunk_sums.size(), [&](std::size_t first, std::size_t last, std::size_t) {
    for (std::size_t chunk = first; chunk < last; ++chunk) {
      ChunkSums sums;
      const std::size_t end = std::min(contacts.size(), (chunk + 1) * kChunk);
      for (std::size_t i = chunk * kChunk; i < end; ++i) {
        const Contact& c = contacts[i];
        auto [u_n, u_t] = contact_velocity(c, bodies, inv_dt);
        if (normal_compliance != 0.0 && c.impulse_n != 0.0)
          u_n += normal_compliance * c.impulse_n *
                 delassus_entries(c, bodies[static_cast<std::size_t>(c.key.body_a)],
                                  bodies[static_cast<std::size_t>(c.key.body_b)])
                     .w_nn;
        const double e2 = contact_law_violation2(u_n, u_t, c.impulse_n, c.impulse_t, c.friction);
        sums.largest = std::max(sums.largest, std::sqrt(e2));
        if (impulse_status(c) != ImpulseStatus::kOpen) {
          sums.sum2 += e2;
          ++sums.carrying;
        }
      }
      chunk_sums[chunk] = sums;
    }
  });
  VelocityResidual r;
  double sum2 = 0.0;
  for (const ChunkSums& sums : chunk_sums) {
    r.largest = std::max(r.largest, sums.largest);
    r.carrying += sums.carrying;
    sum2 += sums.sum2;
  }
  if (r.carrying > 0) r.rms_carrying = std::sqrt(sum2 / static_cast<double>(r.carrying));
  return r;
}

}  // namespace cdshear
