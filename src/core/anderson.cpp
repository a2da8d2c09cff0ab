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
  double f2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) f2 += (g[i] - x[i]) * (g[i] - x[i]);
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
    const int c = next_column_;
    double* df = column(delta_f_, c);
    double* dg = column(delta_g_, c);
    for (std::size_t i = 0; i < n; ++i) {
      const double f = g[i] - x[i];
      df[i] = f - last_f_[i];
      dg[i] = g[i] - last_g_[i];
      last_f_[i] = f;
      last_g_[i] = g[i];
    }
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
    for (std::size_t i = 0; i < n; ++i) {
      last_f_[i] = g[i] - x[i];
      last_g_[i] = g[i];
    }
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
    kept_ = 0;  // start the history again
    return;
  }
  // g -= sum_j gamma_j delta_g_j, the terms subtracted in order j = 0, 1, ...: one pass over g.
  std::array<const double*, kMaxDepth> dg{};
  for (int j = 0; j < m; ++j) dg[j] = column(delta_g_, j);
  for (std::size_t i = 0; i < n; ++i) {
    double gi = g[i];
    for (int j = 0; j < m; ++j) gi -= b[j] * dg[j][i];
    g[i] = gi;
  }
}

}  // namespace cdshear
