#include "threads.hpp"

#include <algorithm>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace cdshear {

int processors_available() {
#if defined(_OPENMP)
  return omp_get_num_procs();
#else
  return 1;
#endif
}

int threads_for(std::size_t items, std::size_t min_items_per_thread, int requested) {
  if (requested <= 1) return 1;
  return static_cast<int>(std::clamp<std::size_t>(
      items / std::max<std::size_t>(min_items_per_thread, 1), 1,
      static_cast<std::size_t>(std::min(requested, processors_available()))));
}

namespace detail {
thread_local SpinBarrier* team_spin_barrier = nullptr;
}  // namespace detail

namespace {
inline void pause_a_moment() {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#endif
}
}  // namespace

void SpinBarrier::wait(unsigned team) {
  if (team <= 1) return;
  const unsigned generation = generation_.load(std::memory_order_acquire);
  if (arrived_.fetch_add(1, std::memory_order_acq_rel) + 1 == team) {
    // The last to arrive: the count starts again for the next barrier before the others leave.
    arrived_.store(0, std::memory_order_relaxed);
    generation_.store(generation + 1, std::memory_order_seq_cst);
    // Sequentially consistent with the sleepers' count below: either a thread about to sleep
    // sees the new generation, or this sees it counted and wakes it.
    if (sleepers_.load(std::memory_order_seq_cst) > 0) generation_.notify_all();
    return;
  }
  for (int i = 0; i < kSpins; ++i) {
    if (generation_.load(std::memory_order_acquire) != generation) return;
    pause_a_moment();
  }
  sleepers_.fetch_add(1, std::memory_order_seq_cst);
  while (generation_.load(std::memory_order_seq_cst) == generation)
    generation_.wait(generation, std::memory_order_acquire);
  sleepers_.fetch_sub(1, std::memory_order_relaxed);
}

SpinBarrierScope::SpinBarrierScope(SpinBarrier& barrier) {
  detail::team_spin_barrier = &barrier;
}

SpinBarrierScope::~SpinBarrierScope() {
  detail::team_spin_barrier = nullptr;
}

}  // namespace cdshear
