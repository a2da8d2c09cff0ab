// How many OpenMP threads to give a piece of work: shared by the solver and contact detection.
#pragma once

#include <cstddef>

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace cdshear {

/// Processors OpenMP may use (1 in a build without OpenMP): the default of `--threads`.
int processors_available();

/// Threads to share `items` among: at most `requested` and the processors available, and fewer
/// when each would get less than `min_items_per_thread` items (a parallel region and its
/// barriers then cost more than the work they share); at least 1.
int threads_for(std::size_t items, std::size_t min_items_per_thread, int requested);

/// Calls part(first, last, thread) on each thread of a new team of `team` (on the calling thread
/// alone when team is 1), thread t taking the t-th of its consecutive shares of [0, count): the
/// same split on every call, whatever the scheduling. Per-thread results, merged afterwards in
/// thread order (or by an exact operation such as a maximum), then do not depend on the timing.
/// A team may have fewer threads than asked for; the shares then still cover [0, count).
template <class Part>
void for_shares(int team, std::size_t count, const Part& part) {
#if defined(_OPENMP)
  if (team > 1) {
#pragma omp parallel num_threads(team)
    {
      const auto size = static_cast<std::size_t>(omp_get_num_threads());
      const auto t = static_cast<std::size_t>(omp_get_thread_num());
      part(count * t / size, count * (t + 1) / size, t);
    }
    return;
  }
#endif
  part(std::size_t{0}, count, std::size_t{0});
}

}  // namespace cdshear
