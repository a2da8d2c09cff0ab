#include "random_shuffle.hpp"

#include <algorithm>
#include <array>
#include <utility>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace cdshear {

namespace {

/// The counter of block `block` of CounterRandom(seed, stream, a, b): (a low, a high,
/// b ^ stream << 24, block), as CounterRandom::refill forms it.
struct BlockCounter {
  std::uint32_t c0, c1, c2;
};

/// Blocks [first, first + blocks) of the generator, each one's four numbers in order: the
/// draws 4 first .. 4 (first + blocks) - 1.
void philox_blocks(const BlockCounter& ctr, std::uint32_t key0, std::uint32_t key1,
                   std::uint32_t first, std::size_t blocks, std::uint32_t* out) {
  std::size_t done = 0;
#if defined(__AVX2__)
  // Philox4x32-10 (Salmon et al. 2011, Random123's philox.h): ten rounds of
  //   (x0, x1, x2, x3) <- (hi(M1 x2) ^ x1 ^ k0, lo(M1 x2), hi(M0 x0) ^ x3 ^ k1, lo(M0 x0)),
  // the key (k0, k1) bumped by (W0, W1) between rounds, with philox.h's constants. Written out
  // here only for the four-lane version; one block at a time is Random123's own.
  constexpr std::uint32_t kM0 = PHILOX_M4x32_0, kM1 = PHILOX_M4x32_1;
  constexpr std::uint32_t kW0 = PHILOX_W32_0, kW1 = PHILOX_W32_1;
  constexpr int kRounds = PHILOX4x32_DEFAULT_ROUNDS;
  // Four blocks at once, one per 64-bit lane (each word in a lane's low half): _mm256_mul_epu32
  // is the 32 x 32 -> 64 bit product of each lane.
  const __m256i low_half = _mm256_set1_epi64x(0xffffffffll);
  const __m256i m0 = _mm256_set1_epi64x(kM0), m1 = _mm256_set1_epi64x(kM1);
  for (; done + 4 <= blocks; done += 4) {
    const auto b = static_cast<long long>(first + done);
    __m256i x0 = _mm256_set1_epi64x(ctr.c0), x1 = _mm256_set1_epi64x(ctr.c1);
    __m256i x2 = _mm256_set1_epi64x(ctr.c2);
    __m256i x3 = _mm256_set_epi64x(b + 3, b + 2, b + 1, b);
    std::uint32_t k0 = key0, k1 = key1;
    for (int r = 0; r < kRounds; ++r) {
      if (r > 0) {
        k0 += kW0;
        k1 += kW1;
      }
      const __m256i p0 = _mm256_mul_epu32(x0, m0), p1 = _mm256_mul_epu32(x2, m1);
      const __m256i y0 =
          _mm256_xor_si256(_mm256_xor_si256(_mm256_srli_epi64(p1, 32), x1), _mm256_set1_epi64x(k0));
      const __m256i y2 =
          _mm256_xor_si256(_mm256_xor_si256(_mm256_srli_epi64(p0, 32), x3), _mm256_set1_epi64x(k1));
      x1 = _mm256_and_si256(p1, low_half);
      x3 = _mm256_and_si256(p0, low_half);
      x0 = y0;
      x2 = y2;
    }
    alignas(32) std::array<std::uint64_t, 4> w0, w1, w2, w3;
    _mm256_store_si256(reinterpret_cast<__m256i*>(w0.data()), x0);
    _mm256_store_si256(reinterpret_cast<__m256i*>(w1.data()), x1);
    _mm256_store_si256(reinterpret_cast<__m256i*>(w2.data()), x2);
    _mm256_store_si256(reinterpret_cast<__m256i*>(w3.data()), x3);
    for (std::size_t l = 0; l < 4; ++l) {
      std::uint32_t* o = out + 4 * (done + l);
      o[0] = static_cast<std::uint32_t>(w0[l]);
      o[1] = static_cast<std::uint32_t>(w1[l]);
      o[2] = static_cast<std::uint32_t>(w2[l]);
      o[3] = static_cast<std::uint32_t>(w3[l]);
    }
  }
#endif
  // The rest one at a time, by Random123's Philox4x32 as CounterRandom::refill calls it.
  r123::Philox4x32 philox;
  const r123::Philox4x32::key_type key = {{key0, key1}};
  for (; done < blocks; ++done) {
    const r123::Philox4x32::ctr_type counter = {
        {ctr.c0, ctr.c1, ctr.c2, first + static_cast<std::uint32_t>(done)}};
    const r123::Philox4x32::ctr_type block = philox(counter, key);
    std::copy(block.begin(), block.end(), out + 4 * done);
  }
}

}  // namespace

void shuffle_rows(std::uint32_t* items, std::size_t count, std::uint64_t seed, RandomStream stream,
                  std::uint64_t a, std::uint64_t b) {
  if (count < 2) return;
  const BlockCounter ctr{
      static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(a >> 32),
      static_cast<std::uint32_t>(b) ^ (static_cast<std::uint32_t>(stream) << 24)};
  const auto key0 = static_cast<std::uint32_t>(seed), key1 = static_cast<std::uint32_t>(seed >> 32);
  // The draws in batches of up to kBatch blocks (no more than the draws still to come), as the
  // shuffle consumes them: one per k, from k = count down to 2, by CounterRandom::below's
  // multiply-shift.
  constexpr std::size_t kBatch = 16;
  std::array<std::uint32_t, 4 * kBatch> draws;
  std::size_t used = 0, made = 0;
  std::uint32_t next_block = 0;
  for (std::size_t k = count; k > 1; --k) {
    if (used == made) {
      const std::size_t blocks = std::min(kBatch, (k - 1 + 3) / 4);
      philox_blocks(ctr, key0, key1, next_block, blocks, draws.data());
      next_block += static_cast<std::uint32_t>(blocks);
      made = 4 * blocks;
      used = 0;
    }
    const auto pick = static_cast<std::size_t>(
        (static_cast<std::uint64_t>(draws[used++]) * static_cast<std::uint32_t>(k)) >> 32);
    std::swap(items[k - 1], items[pick]);
  }
}

}  // namespace cdshear
