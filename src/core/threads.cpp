#include "threads.hpp"

#include <algorithm>

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

}  // namespace cdshear
