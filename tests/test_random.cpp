// The batched shuffle of the solver's contact orders (random_shuffle.hpp) against the
// generator's own draws, one at a time (random.hpp).
#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <vector>

#include "random.hpp"
#include "random_shuffle.hpp"

namespace cdshear {
namespace {

TEST(Random, BatchedShuffleIsTheGeneratorsShuffle) {
  // Counts across the batch's edges (4 draws a block, 16 blocks a batch, four blocks a lane
  // group) and keys with every part of the counter and key set, high words included.
  const std::vector<std::uint64_t> seeds = {0, 1, 0x123456789abcdefull, 0xffffffffffffffffull};
  const std::vector<std::uint64_t> as = {0, 7, 0xfedcba9876543210ull};
  const std::vector<std::uint64_t> bs = {0, 1, 513};
  std::size_t compared = 0;
  for (const std::uint64_t seed : seeds)
    for (const std::uint64_t a : as)
      for (const std::uint64_t b : bs)
        for (std::size_t count = 0; count <= 300; count += (count < 80 ? 1 : 37)) {
          std::vector<std::uint32_t> expected(count), batched(count);
          std::iota(expected.begin(), expected.end(), 0u);
          std::iota(batched.begin(), batched.end(), 0u);
          CounterRandom rng(seed, RandomStream::kContactOrder, a, b);
          shuffle(expected, rng);
          shuffle_rows(batched.data(), count, seed, RandomStream::kContactOrder, a, b);
          ASSERT_EQ(batched, expected)
              << "seed " << seed << " a " << a << " b " << b << " count " << count;
          ++compared;
        }
  EXPECT_GT(compared, 3000u);
  // And a shuffle of many items moves them (the test above would pass for two no-ops).
  std::vector<std::uint32_t> items(1000);
  std::iota(items.begin(), items.end(), 0u);
  shuffle_rows(items.data(), items.size(), 1, RandomStream::kContactOrder, 2, 3);
  std::size_t fixed = 0;
  for (std::uint32_t i = 0; i < items.size(); ++i) fixed += items[i] == i;
  EXPECT_LT(fixed, 20u);
}

}  // namespace
}  // namespace cdshear
