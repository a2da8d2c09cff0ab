// Anderson acceleration (type II, Walker and Ni 2011) of a fixed-point iteration x <- G(x): the
// next iterate mixes the last `depth` images of G instead of taking the last one alone,
//   x_{k+1} = G(x_k) - sum_j gamma_j (G(x_{j+1}) - G(x_j)),
//   gamma = argmin || f_k - sum_j gamma_j (f_{j+1} - f_j) ||_2,   f = G(x) - x,
// the least-squares problem solved through its normal equations (depth is small), with a
// relative Tikhonov term so that nearly parallel differences do not blow gamma up. Safeguard:
// when the residual |f| of a map is larger than the last one's, the history is dropped and the
// iterate is left unmixed (restart). A plain function of the vectors it is given: no I/O, no
// randomness, fixed summation order.
//
// Threads: mix() may be called by every thread of an OpenMP team at once (as the solver does,
// inside its parallel region): its passes over the vectors are shared among them (orphaned
// `omp for`), and the small steps between passes run on one (`omp single`). Called outside a
// parallel region, it runs on the calling thread alone. The vectors are cut into chunks of
// kChunk elements whatever the number of threads; each sum is added within a chunk, then chunk
// by chunk in order, so the result is the same bit for bit on any number of threads.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace cdshear {

class AndersonMixer {
 public:
  /// Largest history kept (reset clamps `depth` to it): the fixed-size scratch of a mix.
  static constexpr int kMaxDepth = 16;
  /// Elements per chunk of the passes (a multiple of 4; a chunk of two vectors fits in L1).
  static constexpr std::size_t kChunk = 512;

  /// Forgets the history; vectors of length n from now on, `depth` differences kept (>= 1).
  void reset(std::size_t n, int depth);

  /// x: the iterate G was applied to; g: G(x). On return g holds the accelerated iterate (equal
  /// to G(x) on the first call after a reset). Either every thread of a team calls it with the
  /// same vectors, or one thread outside any parallel region (see above).
  void mix(const std::vector<double>& x, std::vector<double>& g);

  /// Differences currently kept.
  int kept() const { return kept_; }

 private:
  // The phases of a mix, each called by every thread of a team (or by one thread alone).
  /// Pass 1: f = g - x, its differences to the last map into column c, each chunk's |f|^2.
  void store_differences(const std::vector<double>& x, const std::vector<double>& g, int c);
  /// One thread: the restart test on |f|^2 and the ring's bookkeeping.
  void update_history(int c);
  /// Pass 2: column c's row of the Gram matrix and the right-hand side; then gamma_.
  void add_gram_row(int c);
  /// Pass 3: g -= sum_j gamma_j delta_g_j.
  void subtract_mixes(std::vector<double>& g);

  /// The mixing coefficients gamma_ from the Gram matrix and rhs_ (one thread); false, and the
  /// history dropped if the system is singular, when there is nothing to mix.
  bool solve_for_gamma();

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
  std::vector<double> gram_;               // depth x depth, delta_f^T delta_f
  std::array<double, kMaxDepth> rhs_{};    // delta_f_j . f of the last map
  std::array<double, kMaxDepth> gamma_{};  // the mixing coefficients of this map
  std::vector<double> chunk_f2_;           // each chunk's share of |f|^2
  std::vector<double> chunk_dots_;  // per chunk: kMaxDepth Gram-row shares, then kMaxDepth rhs
  // Decisions of the one-thread steps, read by every thread after the barrier that ends them.
  bool dots_pending_ = false;    // a new difference: its Gram row and rhs_ to compute
  bool update_pending_ = false;  // gamma_ found: g to update
};

}  // namespace cdshear
