// cdshear_factor_cost: what one sparse Cholesky factorisation of a step's Delassus operator costs
// (docs/performance.md, "What did not help": ADMM on the Delassus operator). Reads a symmetric
// Matrix Market file (W + rho I, written by `bench/admm_step.py --write-matrix`) and prints, for
// CHOLMOD's simplicial and supernodal LDL^T with its default ordering, the analysis time (once per
// sparsity pattern), the best of five numeric factorisations and of five solves, nnz(L) and the
// factorisation's flop count.
//
//   cdshear_factor_cost MATRIX.mtx
#include <cholmod.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

namespace {

double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

template <class F>
double best_of_five(F&& f) {
  double best = 1e300;
  for (int k = 0; k < 5; ++k) {
    const double t0 = seconds_now();
    f();
    best = std::min(best, seconds_now() - t0);
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: cdshear_factor_cost MATRIX.mtx\n");
    return 2;
  }
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(argv[1], "r"), &std::fclose);
  if (!file) {
    std::fprintf(stderr, "error: %s: cannot open\n", argv[1]);
    return 1;
  }
  cholmod_common common;
  cholmod_start(&common);
  cholmod_sparse* a = cholmod_read_sparse(file.get(), &common);
  if (a == nullptr || a->stype == 0) {
    std::fprintf(stderr, "error: %s: not a symmetric Matrix Market matrix\n", argv[1]);
    cholmod_finish(&common);
    return 1;
  }
  for (const int kind : {CHOLMOD_SIMPLICIAL, CHOLMOD_SUPERNODAL}) {
    common.supernodal = kind;
    const double t0 = seconds_now();
    cholmod_factor* l = cholmod_analyze(a, &common);
    const double analyse_s = seconds_now() - t0;
    const double factor_s = best_of_five([&] { cholmod_factorize(a, l, &common); });
    cholmod_dense* b = cholmod_ones(a->nrow, 1, a->xtype, &common);
    const double solve_s = best_of_five([&] {
      cholmod_dense* x = cholmod_solve(CHOLMOD_A, l, b, &common);
      cholmod_free_dense(&x, &common);
    });
    std::printf(
        "%s: n %zu, nnz(A) %ld: analyse %.1f ms, factorise %.2f ms, solve %.2f ms, "
        "nnz(L) %.0f, flops %.2e\n",
        kind == CHOLMOD_SIMPLICIAL ? "simplicial" : "supernodal", a->nrow,
        static_cast<long>(cholmod_nnz(a, &common)), 1e3 * analyse_s, 1e3 * factor_s, 1e3 * solve_s,
        common.lnz, common.fl);
    cholmod_free_dense(&b, &common);
    cholmod_free_factor(&l, &common);
  }
  cholmod_free_sparse(&a, &common);
  cholmod_finish(&common);
  return 0;
}
