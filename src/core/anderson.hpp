// Anderson acceleration (type II, Walker and Ni 2011) of a fixed-point iteration x <- G(x): the
// next iterate mixes the last `depth` images of G instead of taking the last one alone,
//   x_{k+1} = G(x_k) - sum_j gamma_j (G(x_{j+1}) - G(x_j)),
//   gamma = argmin || f_k - sum_j gamma_j (f_{j+1} - f_j) ||_2,   f = G(x) - x,
// the least-squares problem solved through its normal equations (depth is small), with a
// relative Tikhonov term so that nearly parallel differences do not blow gamma up. Safeguard:
// when the residual |f| of a map is larger than the last one's, the history is dropped and the
// iterate is left unmixed (restart). A plain function of the vectors it is given: no I/O, no
// randomness, fixed summation order.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace cdshear {

class AndersonMixer {
 public:
  /// Largest history kept (reset clamps `depth` to it): the fixed-size scratch of a mix.
  static constexpr int kMaxDepth = 16;

  /// Forgets the history; vectors of length n from now on, `depth` differences kept (>= 1).
  void reset(std::size_t n, int depth);

  /// x: the iterate G was applied to; g: G(x). On return g holds the accelerated iterate (equal
  /// to G(x) on the first call after a reset).
  void mix(const std::vector<double>& x, std::vector<double>& g);

  /// Differences currently kept.
  int kept() const { return kept_; }

 private:
  double* column(std::vector<double>& columns, int j) {
    return &columns[static_cast<std::size_t>(j) * n_];
  }

  std::size_t n_ = 0;
  int depth_ = 1;
  int kept_ = 0;         // columns in use
  int next_column_ = 0;  // the ring's next column to overwrite
  bool have_last_ = false;
  double last_f2_ = 0.0;                   // |f|^2 of the last map
  std::vector<double> delta_f_, delta_g_;  // depth columns of n, column-major
  std::vector<double> last_f_, last_g_;
  std::vector<double> gram_;             // depth x depth, delta_f^T delta_f
  std::array<double, kMaxDepth> rhs_{};  // delta_f_j . f of the last map
};

}  // namespace cdshear
