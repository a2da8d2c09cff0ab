// Fisher-Yates shuffles of row numbers with the draws of CounterRandom (random.hpp), the
// Philox blocks made four at a time. The coloured order shuffles every group of rows at every
// step; drawing one number at a time (a Philox block per four draws, each block a chain of ten
// dependent rounds) was about 1.6% of a system-1 step.
#pragma once

#include <cstddef>
#include <cstdint>

#include "random.hpp"

namespace cdshear {

/// The same permutation as `CounterRandom rng(seed, stream, a, b); shuffle(items, count, rng);`
/// bit for bit (test Random.BatchedShuffleIsTheGeneratorsShuffle), with the generator's blocks
/// made several at once (on four lanes where the build has AVX2: random_shuffle.cpp).
void shuffle_rows(std::uint32_t* items, std::size_t count, std::uint64_t seed, RandomStream stream,
                  std::uint64_t a, std::uint64_t b);

}  // namespace cdshear
