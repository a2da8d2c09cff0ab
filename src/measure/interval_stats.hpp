// Solver and step statistics over a sampling interval: what every row of a time series reports,
// so that no capped step or overlap between two samples goes unseen.
#pragma once

#include <algorithm>
#include <cstdint>

#include "contact_dynamics.hpp"

namespace cdshear {

struct IntervalStats {
  std::uint64_t steps = 0;
  std::uint64_t capped_steps = 0;  ///< steps whose solver hit the sweep cap
  double sweeps_sum = 0.0;
  int sweeps_max = 0;
  double residual_max = 0.0;  ///< largest final residual of a step
  double overlap_max = 0.0;   ///< largest overlap after a step [length]

  void add(const StepReport& r) {
    ++steps;
    capped_steps += r.solver.hit_cap ? 1 : 0;
    sweeps_sum += r.solver.sweeps;
    sweeps_max = std::max(sweeps_max, r.solver.sweeps);
    residual_max = std::max(residual_max, r.solver.residual);
    overlap_max = std::max(overlap_max, r.max_overlap);
  }
  double sweeps_mean() const { return steps > 0 ? sweeps_sum / static_cast<double>(steps) : 0.0; }
};

}  // namespace cdshear
