// How many OpenMP threads to give a piece of work: shared by the solver and contact detection.
#pragma once

#include <cstddef>

namespace cdshear {

/// Processors OpenMP may use (1 in a build without OpenMP): the default of `--threads`.
int processors_available();

/// Threads to share `items` among: at most `requested` and the processors available, and fewer
/// when each would get less than `min_items_per_thread` items (a parallel region and its
/// barriers then cost more than the work they share); at least 1.
int threads_for(std::size_t items, std::size_t min_items_per_thread, int requested);

}  // namespace cdshear
