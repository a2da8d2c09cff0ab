#include "anderson.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace cdshear {

namespace {

constexpr int kMaxDepth = AndersonMixer::kMaxDepth;

/// The dot products of `u` and of `v` with m columns, in one pass over the columns:
/// uc[j] = u . c_j and vc[j] = v . c_j. Each product keeps four running sums (i mod 4) that are
/// added at the end, (s0 + s1) + (s2 + s3): four independent chains of additions instead of one,
/// in a fixed order. The pass goes block by block (a multiple of 4 elements, so every running sum
/// still adds its terms in increasing i): a block of u and v stays in L1 while the m columns go
/// by, and each column is read from memory once for both products.
void dot_columns(const double* u, const double* v, const double* const* columns, int m,
                 std::size_t n, double* uc, double* vc) {
  constexpr std::size_t kBlock = 512;
  std::array<std::array<double, 4>, kMaxDepth> su{}, sv{};
  std::size_t begin = 0;
  for (; begin + 4 <= n; begin += kBlock) {
    const std::size_t end = std::min(n - n % 4, begin + kBlock);
    for (int j = 0; j < m; ++j) {
      const double* c = columns[j];
      double u0 = su[j][0], u1 = su[j][1], u2 = su[j][2], u3 = su[j][3];
      double v0 = sv[j][0], v1 = sv[j][1], v2 = sv[j][2], v3 = sv[j][3];
      for (std::size_t i = begin; i < end; i += 4) {
        u0 += u[i] * c[i];
        u1 += u[i + 1] * c[i + 1];
        u2 += u[i + 2] * c[i + 2];
        u3 += u[i + 3] * c[i + 3];
        v0 += v[i] * c[i];
        v1 += v[i + 1] * c[i + 1];
        v2 += v[i + 2] * c[i + 2];
        v3 += v[i + 3] * c[i + 3];
      }
      su[j] = {u0, u1, u2, u3};
      sv[j] = {v0, v1, v2, v3};
    }
  }
  for (int j = 0; j < m; ++j) {
    for (std::size_t i = n - n % 4; i < n; ++i) {
      su[j][0] += u[i] * columns[j][i];
      sv[j][0] += v[i] * columns[j][i];
    }
    uc[j] = (su[j][0] + su[j][1]) + (su[j][2] + su[j][3]);
    vc[j] = (sv[j][0] + sv[j][1]) + (sv[j][2] + sv[j][3]);
  }
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
  delta_f_.assign(n * static_cast<std::size_t>(depth_), 0.0);
  delta_g_.assign(n * static_cast<std::size_t>(depth_), 0.0);
  last_f_.assign(n, 0.0);
  last_g_.assign(n, 0.0);
  gram_.assign(static_cast<std::size_t>(depth_ * depth_), 0.0);
}

void AndersonMixer::mix(const std::vector<double>& x, std::vector<double>& g) {
  const std::size_t n = n_;
  // One pass: f = g - x, its squared length, and the new differences delta_f = f - f_last and
  // delta_g = g - g_last written into the ring's next column. When there is no last map yet, or
  // the history is dropped below, that column is not in use (kept_ = 0) and what was written
  // there is never read. |f|^2 keeps four running sums (i mod 4), added (s0 + s1) + (s2 + s3):
  // it only decides the restart below.
  const int c = next_column_;
  double* __restrict df = column(delta_f_, c);
  double* __restrict dg = column(delta_g_, c);
  double* __restrict last_f = last_f_.data();
  double* __restrict last_g = last_g_.data();
  const double* __restrict xs = x.data();
  const double* __restrict gs = g.data();
  std::array<double, 4> f2_sums{};
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    for (std::size_t k = 0; k < 4; ++k) {
      const double f = gs[i + k] - xs[i + k];
      f2_sums[k] += f * f;
      df[i + k] = f - last_f[i + k];
      dg[i + k] = gs[i + k] - last_g[i + k];
      last_f[i + k] = f;
      last_g[i + k] = gs[i + k];
    }
  }
  for (; i < n; ++i) {
    const double f = gs[i] - xs[i];
    f2_sums[0] += f * f;
    df[i] = f - last_f[i];
    dg[i] = gs[i] - last_g[i];
    last_f[i] = f;
    last_g[i] = gs[i];
  }
  const double f2 = (f2_sums[0] + f2_sums[1]) + (f2_sums[2] + f2_sums[3]);
  if (have_last_ && f2 > last_f2_) {
    // The residual grew since the last map: the mixes of the kept history made things worse
    // (the map is only piecewise linear: contacts open, close, stick and slip). Start again
    // from this iterate, unmixed.
    kept_ = 0;
    next_column_ = 0;
    have_last_ = false;
  }
  last_f2_ = f2;
  if (have_last_) {
    next_column_ = (c + 1) % depth_;
    kept_ = std::min(kept_ + 1, depth_);
    // The new column's row of the Gram matrix, and the right-hand side delta_f_j . f (below).
    std::array<const double*, kMaxDepth> columns{};
    for (int j = 0; j < kept_; ++j) columns[j] = column(delta_f_, j);
    std::array<double, kMaxDepth> gram_row{};
    dot_columns(df, last_f_.data(), columns.data(), kept_, n, gram_row.data(), rhs_.data());
    for (int j = 0; j < kept_; ++j) {
      gram_[static_cast<std::size_t>(c * depth_ + j)] = gram_row[j];
      gram_[static_cast<std::size_t>(j * depth_ + c)] = gram_row[j];
    }
  } else {
    have_last_ = true;
  }
  if (kept_ == 0) return;

  const int m = kept_;
  std::array<double, kMaxDepth * kMaxDepth> a{};
  std::array<double, kMaxDepth> b{};
  double trace = 0.0;
  for (int j = 0; j < m; ++j) trace += gram_[static_cast<std::size_t>(j * depth_ + j)];
  if (!(trace > 0.0)) return;
  for (int r = 0; r < m; ++r) {
    for (int c = 0; c < m; ++c) a[r * m + c] = gram_[static_cast<std::size_t>(r * depth_ + c)];
    a[r * m + r] += 1e-10 * trace;
    b[r] = rhs_[r];
  }
  if (!solve_small(a, b, m)) {
    // Start the history again; the ring too, since the columns in use are always 0 .. kept_ - 1
    // (with next_column_ left where it was, the next difference would be written to a column
    // the next mix does not read, and column 0's stale one read instead).
    kept_ = 0;
    next_column_ = 0;
    return;
  }
  // g -= sum_j gamma_j delta_g_j, each element's terms subtracted in order j = 0, 1, ...: block
  // by block (a block of g stays in L1 while the m columns go by), the inner loop over the
  // elements of a block (independent, so it vectorises).
  constexpr std::size_t kBlock = 512;
  double* __restrict gw = g.data();
  for (std::size_t begin = 0; begin < n; begin += kBlock) {
    const std::size_t end = std::min(n, begin + kBlock);
    for (int j = 0; j < m; ++j) {
      const double* __restrict dgj = column(delta_g_, j);
      const double gamma = b[j];
      for (std::size_t k = begin; k < end; ++k) gw[k] -= gamma * dgj[k];
    }
  }
}

}  // namespace cdshear
