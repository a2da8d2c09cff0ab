// OpenMP teams: how many threads a piece of work gets, fixed splits of a pass among a team (shared
// by the solver, contact detection and the step's per-disk passes), and the barrier the solver's
// team meets at.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <vector>

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

/// This thread's place in the team running a pass (thread 0 of 1 outside a parallel region).
struct TeamPlace {
  std::size_t thread = 0, size = 1;
};

inline TeamPlace team_place() {
#if defined(_OPENMP)
  return {static_cast<std::size_t>(omp_get_thread_num()),
          static_cast<std::size_t>(omp_get_num_threads())};
#else
  return {};
#endif
}

/// The share [first, last) of `count` items that thread p takes in the passes that split their
/// items themselves (the same split in every such pass, unlike `omp for`, whose static split the
/// standard leaves to the implementation).
struct Share {
  std::size_t first, last;
};
inline Share share_of(std::size_t count, TeamPlace p) {
  return {count * p.thread / p.size, count * (p.thread + 1) / p.size};
}

/// The share of thread p of items [0, start.size() - 1) of unequal weights, item k weighing
/// start[k + 1] - start[k] (start: non-decreasing offsets from 0): consecutive items holding
/// about an equal share of the total weight. Items as heavy as a share or heavier are not cut.
inline Share weighted_share_of(const std::vector<std::size_t>& start, TeamPlace p) {
  const std::size_t items = start.size() - 1;
  const auto first_at = [&](std::size_t t) -> std::size_t {
    if (t == 0) return 0;
    if (t >= p.size) return items;
    const std::size_t target = start.back() * t / p.size;
    return static_cast<std::size_t>(
        std::lower_bound(start.begin(), start.begin() + static_cast<std::ptrdiff_t>(items),
                         target) -
        start.begin());
  };
  return {first_at(p.thread), first_at(p.thread + 1)};
}

/// A barrier for one team's threads that costs no system call while they arrive close together.
/// libgomp's barrier makes its last thread wake the others with a futex system call at every
/// barrier, sleeping or not (about 0.25 us on the 2-core virtual machines, where this one takes
/// about 0.04 us in a loop of barriers); the solver meets 300 to 400 barriers per step. A thread
/// that waits spins for a while (kSpins pauses, about 0.5 ms on those machines) and then sleeps on
/// the generation (std::atomic::wait), so that a team sharing its processors with other work still
/// makes progress; the last thread wakes the sleepers only when there are any
/// (docs/performance.md, "Threads").
class SpinBarrier {
 public:
  /// Waits until `team` threads (every thread of the caller's team) have arrived.
  void wait(unsigned team);

 private:
  static constexpr int kSpins = 20000;
  alignas(64) std::atomic<unsigned> arrived_{0};
  alignas(64) std::atomic<unsigned> generation_{0};
  std::atomic<unsigned> sleepers_{0};
};

/// Makes team_barrier() use `barrier` on the calling thread while it lives: each thread of a
/// parallel region makes one, for the region's barrier.
class SpinBarrierScope {
 public:
  explicit SpinBarrierScope(SpinBarrier& barrier);
  ~SpinBarrierScope();
  SpinBarrierScope(const SpinBarrierScope&) = delete;
  SpinBarrierScope& operator=(const SpinBarrierScope&) = delete;
};

namespace detail {
/// The barrier of the caller's team (SpinBarrierScope), or null: then OpenMP's.
extern thread_local SpinBarrier* team_spin_barrier;
}  // namespace detail

/// A barrier of the team running the caller (nothing outside a parallel region).
inline void team_barrier() {
#if defined(_OPENMP)
  if (SpinBarrier* b = detail::team_spin_barrier) {
    b->wait(static_cast<unsigned>(omp_get_num_threads()));
    return;
  }
#pragma omp barrier
#endif
}

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
      const TeamPlace place = team_place();
      const Share mine = share_of(count, place);
      part(mine.first, mine.last, place.thread);
    }
    return;
  }
#endif
  part(std::size_t{0}, count, std::size_t{0});
}

}  // namespace cdshear
