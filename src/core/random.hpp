// Counter-based random numbers (Random123's Philox4x32-10), keyed on (seed, stream) with the
// counter (a, b). The same key and counter always give the same numbers, whichever thread asks
// and in whatever order: runs are reproducible and independent of the thread count.
#pragma once

#include <Random123/philox.h>

#include <cstdint>
#include <utility>
#include <vector>

namespace cdshear {

/// Streams keep unrelated uses of one seed apart.
enum class RandomStream : std::uint32_t {
  kContactOrder = 1,
  kPlacement = 2,
  kDiameters = 3,
};

class CounterRandom {
 public:
  CounterRandom(std::uint64_t seed, RandomStream stream, std::uint64_t a, std::uint64_t b = 0)
      : key_{{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)}},
        a_(a),
        b_(static_cast<std::uint32_t>(b)),
        stream_(static_cast<std::uint32_t>(stream)) {}

  /// Next 32 random bits.
  std::uint32_t next_u32() {
    if (used_ == 4) refill();
    return block_[used_++];
  }
  /// Uniform double in [0, 1) with 53 random bits.
  double uniform() {
    const std::uint64_t hi = next_u32() >> 5;  // 27 bits
    const std::uint64_t lo = next_u32() >> 6;  // 26 bits
    return static_cast<double>((hi << 26) | lo) * 0x1.0p-53;
  }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n), n > 0 (Lemire's multiply-shift, negligible bias for n << 2^32).
  std::uint32_t below(std::uint32_t n) {
    return static_cast<std::uint32_t>((static_cast<std::uint64_t>(next_u32()) * n) >> 32);
  }

 private:
  void refill() {
    r123::Philox4x32::ctr_type ctr = {{static_cast<std::uint32_t>(a_),
                                       static_cast<std::uint32_t>(a_ >> 32), b_ ^ (stream_ << 24),
                                       counter_++}};
    block_ = philox_(ctr, key_);
    used_ = 0;
  }

  r123::Philox4x32 philox_;
  r123::Philox4x32::key_type key_;
  r123::Philox4x32::ctr_type block_{};
  std::uint64_t a_;
  std::uint32_t b_;
  std::uint32_t stream_;
  std::uint32_t counter_ = 0;
  int used_ = 4;
};

/// Fisher-Yates shuffle of items[0, count) driven by `rng`.
template <class T>
void shuffle(T* items, std::size_t count, CounterRandom& rng) {
  for (std::size_t k = count; k > 1; --k) {
    const std::size_t pick = rng.below(static_cast<std::uint32_t>(k));
    std::swap(items[k - 1], items[pick]);
  }
}

/// Fisher-Yates shuffle of `items` driven by `rng`.
template <class T>
void shuffle(std::vector<T>& items, CounterRandom& rng) {
  shuffle(items.data(), items.size(), rng);
}

}  // namespace cdshear
