#include "anderson.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "threads.hpp"

namespace cdshear {

namespace {

constexpr int kMaxDepth = AndersonMixer::kMaxDepth;

/// Two doubles as one value (a GNU vector type, which g++ and clang both have; SSE2, in every
/// x86-64). The loops below keep four running sums (element i in sum i mod 4) as two pairs,
/// (s0, s1) and (s2, s3): each lane does what the scalar sum did, the same operations in the same
/// order, so the results are the same bit for bit, in half the instructions. At -O2 g++ 12
/// vectorised none of the mix's loops, whose three passes were about 11% of a system-1 step.
/// (Four doubles as one value compiled, for the x86-64 baseline, to running sums kept on the
/// stack, slower than the scalar loops.)
using Pair = double __attribute__((vector_size(16)));

/// A vector of doubles (Pair, or Quad below) from memory at p, and back: memcpy, so no alignment
/// is assumed (g++ makes it one unaligned load or store).
template <class Vector>
inline Vector load(const double* p) {
  Vector v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

template <class Vector>
inline void store(double* p, Vector v) {
  std::memcpy(p, &v, sizeof v);
}

/// (s0 + s1) + (s2 + s3) of the pairs (s0, s1) and (s2, s3): the scalar loops' order.
inline double sum_of_pairs(Pair low, Pair high) {
  return (low[0] + low[1]) + (high[0] + high[1]);
}

/// The dot products, over one chunk of `len` elements, of `u` and of `v` with m columns read
/// from element `offset` on: uc[j] = u . c_j and vc[j] = v . c_j. Each product keeps four
/// running sums (i mod 4, the tail in sum 0) that are added at the end, (s0 + s1) + (s2 + s3):
/// four independent chains of additions instead of one, in a fixed order. The chunk of u and v
/// stays in L1 while the m columns go by, and each column is read once for both products.
///
/// The columns go two at a time (a lone last one after them): each column's sums are the same
/// operations in the same order as with one column at a time, so the same bits, but the two
/// columns' chains of additions run side by side, and u and v are read once for both.
///
/// Four running sums, element i of a product in sum i mod 4, added at the end as
/// (s0 + s1) + (s2 + s3). Where the build has AVX (the solver's builds for x86-64-v3) they are one
/// value of four doubles, else two pairs: each sum sees the same operations in the same order
/// either way, so the same bits, in half the instructions with AVX (alone in a loop, 1000
/// elements and five columns: 0.77 of the time of the pairs).
#if defined(__AVX__)
using Quad = double __attribute__((vector_size(32)));

struct FourSums {
  Quad s{};
  void add_products(const double* a, const double* b) { s += load<Quad>(a) * load<Quad>(b); }
  void add_product(double a, double b) { s[0] += a * b; }
  double total() const { return (s[0] + s[1]) + (s[2] + s[3]); }
};
#else
struct FourSums {
  Pair s01{}, s23{};
  void add_products(const double* a, const double* b) {
    s01 += load<Pair>(a) * load<Pair>(b);
    s23 += load<Pair>(a + 2) * load<Pair>(b + 2);
  }
  void add_product(double a, double b) { s01[0] += a * b; }
  double total() const { return sum_of_pairs(s01, s23); }
};
#endif

void dot_columns(const double* u, const double* v, const double* const* columns, std::size_t offset,
                 int m, std::size_t len, double* uc, double* vc) {
  const std::size_t body = len - len % 4;
  int j = 0;
  for (; j + 2 <= m; j += 2) {
    const double* c = columns[j] + offset;
    const double* d = columns[j + 1] + offset;
    FourSums u_c, v_c, u_d, v_d;
    for (std::size_t i = 0; i < body; i += 4) {
      u_c.add_products(u + i, c + i);
      v_c.add_products(v + i, c + i);
      u_d.add_products(u + i, d + i);
      v_d.add_products(v + i, d + i);
    }
    for (std::size_t i = body; i < len; ++i) {
      u_c.add_product(u[i], c[i]);
      v_c.add_product(v[i], c[i]);
      u_d.add_product(u[i], d[i]);
      v_d.add_product(v[i], d[i]);
    }
    uc[j] = u_c.total();
    vc[j] = v_c.total();
    uc[j + 1] = u_d.total();
    vc[j + 1] = v_d.total();
  }
  if (j < m) {
    const double* c = columns[j] + offset;
    FourSums u_c, v_c;
    for (std::size_t i = 0; i < body; i += 4) {
      u_c.add_products(u + i, c + i);
      v_c.add_products(v + i, c + i);
    }
    for (std::size_t i = body; i < len; ++i) {
      u_c.add_product(u[i], c[i]);
      v_c.add_product(v[i], c[i]);
    }
    uc[j] = u_c.total();
    vc[j] = v_c.total();
  }
}

/// values[0] + values[stride] + ... + values[(count - 1) stride], added in that order: the
/// chunks' shares of a sum, so that the sum does not depend on which thread did which chunk.
double sum_in_chunk_order(const double* values, std::size_t stride, std::size_t count) {
  double sum = 0.0;
  for (std::size_t k = 0; k < count; ++k) sum += values[k * stride];
  return sum;
}

/// store_differences over one chunk [begin, end): f = g - x, the differences df = f - last_f and
/// dg = g - last_g, and the new last values last_f = f, last_g = g. Returns the chunk's share of
/// |f|^2, four running sums i mod 4 (as pairs, or as one Quad with AVX: the same lanes, the same
/// bits).
double store_chunk_differences(const double* __restrict xs, const double* __restrict gs,
                               double* __restrict df, double* __restrict dg,
                               double* __restrict last_f, double* __restrict last_g,
                               std::size_t begin, std::size_t end) {
  Pair f2_01{}, f2_23{};
  // Differences and new last values of the vector (a Pair or a Quad, the type of `like`) at
  // `at`; returns f there.
  const auto differences = [&](std::size_t at, auto like) {
    using Vector = decltype(like);
    const Vector g_at = load<Vector>(gs + at);
    const Vector f = g_at - load<Vector>(xs + at);
    store(df + at, f - load<Vector>(last_f + at));
    store(dg + at, g_at - load<Vector>(last_g + at));
    store(last_f + at, f);
    store(last_g + at, g_at);
    return f;
  };
  std::size_t i = begin;
#if defined(__AVX__)
  Quad f2_0123{};
  for (; i + 4 <= end; i += 4) {
    const Quad f = differences(i, Quad{});
    f2_0123 += f * f;
  }
  f2_01 = Pair{f2_0123[0], f2_0123[1]};
  f2_23 = Pair{f2_0123[2], f2_0123[3]};
#else
  for (; i + 4 <= end; i += 4) {
    const Pair f01 = differences(i, Pair{}), f23 = differences(i + 2, Pair{});
    f2_01 += f01 * f01;
    f2_23 += f23 * f23;
  }
#endif
  for (; i < end; ++i) {
    const double f = gs[i] - xs[i];
    f2_01[0] += f * f;
    df[i] = f - last_f[i];
    dg[i] = gs[i] - last_g[i];
    last_f[i] = f;
    last_g[i] = gs[i];
  }
  return sum_of_pairs(f2_01, f2_23);
}

/// g -= sum_j gamma_j dg_columns[j] over one chunk [begin, end), each element's terms subtracted
/// in order j = 0, 1, ...: eight elements at a time (sixteen with AVX), all m terms while they
/// stay in registers (column by column, g went through memory m times, a load and a store per
/// term; the same subtractions in the same order, so the same bits). 0.7 of the time of the
/// column-by-column loop for 1000 elements and five columns, alone in a loop.
void subtract_chunk_mixes(double* __restrict gw, const double* const* dg_columns,
                          const double* gamma, int m, std::size_t begin, std::size_t end) {
  // Four vectors of g (Pairs, or Quads with AVX: the type of `like`) from element k, each with
  // all m terms subtracted while it stays in a register: four independent chains. gamma_j - 0
  // is gamma_j in every lane, signed zeros included.
  const auto subtract_terms = [&](std::size_t k, auto like) {
    using Vector = decltype(like);
    constexpr std::size_t w = sizeof(Vector) / sizeof(double);
    Vector g0 = load<Vector>(gw + k), g1 = load<Vector>(gw + k + w),
           g2 = load<Vector>(gw + k + 2 * w), g3 = load<Vector>(gw + k + 3 * w);
    for (int j = 0; j < m; ++j) {
      const double* d = dg_columns[j] + k;
      const Vector gamma_j = gamma[j] - Vector{};
      g0 -= gamma_j * load<Vector>(d);
      g1 -= gamma_j * load<Vector>(d + w);
      g2 -= gamma_j * load<Vector>(d + 2 * w);
      g3 -= gamma_j * load<Vector>(d + 3 * w);
    }
    store(gw + k, g0);
    store(gw + k + w, g1);
    store(gw + k + 2 * w, g2);
    store(gw + k + 3 * w, g3);
  };
  std::size_t k = begin;
#if defined(__AVX__)
  for (; k + 16 <= end; k += 16) subtract_terms(k, Quad{});
#endif
  for (; k + 8 <= end; k += 8) subtract_terms(k, Pair{});
  for (; k < end; ++k)
    for (int j = 0; j < m; ++j) gw[k] -= gamma[j] * dg_columns[j][k];
}

/// Solves the m x m system a x = b (a symmetric positive semi-definite plus a small diagonal)
/// by Gaussian elimination with partial pivoting; false if a pivot vanishes.
bool solve_small(std::array<double, kMaxDepth * kMaxDepth>& a, std::array<double, kMaxDepth>& b,
                 int m) {
  for (int col = 0; col < m; ++col) {
    int pivot = col;
    for (int r = col + 1; r < m; ++r)
      if (std::abs(a[r * m + col]) > std::abs(a[pivot * m + col])) pivot = r;
    if (!(std::abs(a[pivot * m + col]) > 0.0)) return false;
    if (pivot != col) {
      for (int c = 0; c < m; ++c) std::swap(a[col * m + c], a[pivot * m + c]);
      std::swap(b[col], b[pivot]);
    }
    for (int r = col + 1; r < m; ++r) {
      const double factor = a[r * m + col] / a[col * m + col];
      for (int c = col; c < m; ++c) a[r * m + c] -= factor * a[col * m + c];
      b[r] -= factor * b[col];
    }
  }
  for (int r = m - 1; r >= 0; --r) {
    double s = b[r];
    for (int c = r + 1; c < m; ++c) s -= a[r * m + c] * b[c];
    b[r] = s / a[r * m + r];
  }
  return true;
}

}  // namespace

void AndersonMixer::reset(std::size_t n, int depth) {
  n_ = n;
  depth_ = std::clamp(depth, 1, kMaxDepth);
  kept_ = 0;
  next_column_ = 0;
  have_last_ = false;
  // Sized, not cleared: a column, a last map and a Gram entry are written before they are read
  // (mix reads the columns 0 .. kept_ - 1 and last_f_, last_g_ only once have_last_ is set, both
  // false here). Clearing them was a serial memset of 2 depth + 2 values per mixed value, about
  // 1.7 MB per step on system 7, on one thread while the others waited.
  delta_f_.resize(n * static_cast<std::size_t>(depth_));
  delta_g_.resize(n * static_cast<std::size_t>(depth_));
  last_f_.resize(n);
  last_g_.resize(n);
  gram_.resize(static_cast<std::size_t>(depth_ * depth_));
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  chunk_f2_.assign(chunks, 0.0);
  chunk_dots_.assign(chunks * 2 * kMaxDepth, 0.0);
}

void AndersonMixer::mix(const std::vector<double>& x, std::vector<double>& g) {
  // Every thread reads next_column_ before the barrier that ends store_differences.
  const int c = next_column_;
  store_differences(x, g, c);
  update_history(c);
  if (dots_pending_) add_gram_row(c);
  if (update_pending_) subtract_mixes(g);
}

void AndersonMixer::store_differences(const std::vector<double>& x, const std::vector<double>& g,
                                      int c) {
  // Chunk by chunk: f = g - x, each chunk's share of |f|^2, and the new differences
  // delta_f = f - f_last and delta_g = g - g_last written into the ring's column c. When there
  // is no last map yet, or the history is dropped next, that column is not in use (kept_ = 0)
  // and what was written there is never read. |f|^2 only decides the restart.
  const std::size_t chunks = chunk_f2_.size();
#if defined(_OPENMP)
#pragma omp for schedule(static) nowait
#endif
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    const std::size_t begin = chunk * kChunk, end = std::min(n_, begin + kChunk);
    chunk_f2_[chunk] =
        store_chunk_differences(x.data(), g.data(), column(delta_f_, c), column(delta_g_, c),
                                last_f_.data(), last_g_.data(), begin, end);
  }
  team_barrier();
}

void AndersonMixer::update_history(int c) {
#if defined(_OPENMP)
#pragma omp single nowait
#endif
  {
    const double f2 = sum_in_chunk_order(chunk_f2_.data(), 1, chunk_f2_.size());
    if (have_last_ && f2 > last_f2_) {
      // The residual grew since the last map: the mixes of the kept history made things worse
      // (the map is only piecewise linear: contacts open, close, stick and slip). Start again
      // from this iterate, unmixed.
      kept_ = 0;
      next_column_ = 0;
      have_last_ = false;
    }
    last_f2_ = f2;
    dots_pending_ = have_last_;
    if (have_last_) {
      next_column_ = (c + 1) % depth_;
      kept_ = std::min(kept_ + 1, depth_);
    } else {
      have_last_ = true;
    }
    update_pending_ = false;
  }
  team_barrier();
}

void AndersonMixer::add_gram_row(int c) {
  // The new column's row of the Gram matrix, delta_f_c . delta_f_j, and the right-hand side
  // delta_f_j . f, chunk by chunk (a chunk of both vectors stays in L1 while the columns go by;
  // each column is read once for both products); then gamma_ on one thread.
  const std::size_t chunks = chunk_f2_.size();
  const int m = kept_;
  std::array<const double*, kMaxDepth> columns{};
  for (int j = 0; j < m; ++j) columns[j] = column(delta_f_, j);
  const double* df = column(delta_f_, c);
  const double* f = last_f_.data();
#if defined(_OPENMP)
#pragma omp for schedule(static) nowait
#endif
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    const std::size_t begin = chunk * kChunk, end = std::min(n_, begin + kChunk);
    double* sums = &chunk_dots_[chunk * 2 * kMaxDepth];
    dot_columns(df + begin, f + begin, columns.data(), begin, m, end - begin, sums,
                sums + kMaxDepth);
  }
  team_barrier();
#if defined(_OPENMP)
#pragma omp single nowait
#endif
  {
    for (int j = 0; j < m; ++j) {
      const double gram = sum_in_chunk_order(&chunk_dots_[j], 2 * kMaxDepth, chunks);
      gram_[static_cast<std::size_t>(c * depth_ + j)] = gram;
      gram_[static_cast<std::size_t>(j * depth_ + c)] = gram;
      rhs_[j] = sum_in_chunk_order(&chunk_dots_[kMaxDepth + j], 2 * kMaxDepth, chunks);
    }
    update_pending_ = solve_for_gamma();
  }
  team_barrier();
}

void AndersonMixer::subtract_mixes(std::vector<double>& g) {
  // g -= sum_j gamma_j delta_g_j, chunk by chunk.
  const std::size_t chunks = chunk_f2_.size();
  const int m = kept_;
  std::array<const double*, kMaxDepth> dg_columns{};
  for (int j = 0; j < m; ++j) dg_columns[j] = column(delta_g_, j);
#if defined(_OPENMP)
#pragma omp for schedule(static) nowait
#endif
  for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
    const std::size_t begin = chunk * kChunk, end = std::min(n_, begin + kChunk);
    subtract_chunk_mixes(g.data(), dg_columns.data(), gamma_.data(), m, begin, end);
  }
  team_barrier();
}

bool AndersonMixer::solve_for_gamma() {
  const int m = kept_;
  if (m == 0) return false;
  std::array<double, kMaxDepth * kMaxDepth> a{};
  double trace = 0.0;
  for (int j = 0; j < m; ++j) trace += gram_[static_cast<std::size_t>(j * depth_ + j)];
  if (!(trace > 0.0)) return false;
  for (int r = 0; r < m; ++r) {
    for (int col = 0; col < m; ++col)
      a[r * m + col] = gram_[static_cast<std::size_t>(r * depth_ + col)];
    a[r * m + r] += 1e-10 * trace;
    gamma_[r] = rhs_[r];
  }
  if (!solve_small(a, gamma_, m)) {
    // Start the history again; the ring too, since the columns in use are always 0 .. kept_ - 1
    // (with next_column_ left where it was, the next difference would be written to a column
    // the next mix does not read, and column 0's stale one read instead).
    kept_ = 0;
    next_column_ = 0;
    return false;
  }
  return true;
}

}  // namespace cdshear
