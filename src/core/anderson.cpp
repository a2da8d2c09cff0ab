#include "anderson.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace cdshear {

namespace {

constexpr int kMaxDepth = 16;  // kMaxAndersonDepth

/// a . b with four running sums (i mod 4), added at the end: four independent chains of
/// additions instead of one, in a fixed order (the same result on every run).
double dot(const double* a, const double* b, std::size_t n) {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += a[i] * b[i];
    s1 += a[i + 1] * b[i + 1];
    s2 += a[i + 2] * b[i + 2];
    s3 += a[i + 3] * b[i + 3];
  }
  for (; i < n; ++i) s0 += a[i] * b[i];
  return (s0 + s1) + (s2 + s3);
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
    for (int j = 0; j < kept_; ++j) {
      const double v = dot(df, column(delta_f_, j), n);
      gram_[static_cast<std::size_t>(c * depth_ + j)] = v;
      gram_[static_cast<std::size_t>(j * depth_ + c)] = v;
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
    b[r] = dot(column(delta_f_, r), last_f_.data(), n);
  }
  if (!solve_small(a, b, m)) {
    kept_ = 0;  // start the history again
    return;
  }
  for (int j = 0; j < m; ++j) {
    const double* dg = column(delta_g_, j);
    const double gamma = b[j];
    for (std::size_t i = 0; i < n; ++i) g[i] -= gamma * dg[i];
  }
}

}  // namespace cdshear
