// Anderson acceleration (anderson.hpp) on linear fixed-point problems, where its answer is known:
// with depth >= n it is a Krylov method and solves an n-dimensional linear problem in n + 1 maps
// (Walker and Ni 2011: type-II Anderson with full memory is equivalent to GMRES).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "anderson.hpp"
#include "test_support.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace cdshear {
namespace {

/// G(x)_i = constant + weight (x_{i-1} + x_{i+1}), with x_{-1} = x_n = 0: the maps below.
std::vector<double> neighbour_map(const std::vector<double>& x, double constant, double weight) {
  const std::size_t n = x.size();
  std::vector<double> g(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double left = i > 0 ? x[i - 1] : 0.0;
    const double right = i + 1 < n ? x[i + 1] : 0.0;
    g[i] = constant + weight * (left + right);
  }
  return g;
}

/// Jacobi iteration x <- G(x) = D^-1 (b - (A - D) x) of the 1D Laplacian A = tridiag(-1, 2, -1),
/// whose solution with b = 1 is x_i = (i + 1) (n - i) / 2. Jacobi alone contracts the error by
/// cos(pi / (n + 1)) per map: about 0.99 for n = 20.
std::vector<double> jacobi(const std::vector<double>& x) {
  return neighbour_map(x, 0.5, 0.5);
}

double error(const std::vector<double>& x) {
  const std::size_t n = x.size();
  double worst = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double exact = static_cast<double>((i + 1) * (n - i)) / 2.0;
    worst = std::max(worst, std::abs(x[i] - exact) / exact);
  }
  return worst;
}

TEST(Anderson, FullDepthSolvesALinearProblemInNPlusOneMaps) {
  constexpr std::size_t kN = 8;
  AndersonMixer mixer;
  mixer.reset(kN, 16);
  std::vector<double> x(kN, 0.0);
  for (std::size_t k = 0; k <= kN + 1; ++k) {
    std::vector<double> g = jacobi(x);
    mixer.mix(x, g);
    x = g;
  }
  EXPECT_LT(error(x), 1e-8);  // Jacobi alone after 10 maps: 0.6
  std::vector<double> plain(kN, 0.0);
  for (std::size_t k = 0; k <= kN + 1; ++k) plain = jacobi(plain);
  EXPECT_GT(error(plain), 0.1);
}

TEST(Anderson, SmallDepthBeatsThePlainIterationByFar) {
  // n = 20, depth 5, 60 maps: the plain iteration is still about 50% off (0.99^60, measured
  // 0.53); the mixed one is 4000 times closer (measured 1.3e-4). Required: below 1e-3.
  constexpr std::size_t kN = 20;
  AndersonMixer mixer;
  mixer.reset(kN, 5);
  std::vector<double> x(kN, 0.0), plain(kN, 0.0);
  for (int k = 0; k < 60; ++k) {
    std::vector<double> g = jacobi(x);
    mixer.mix(x, g);
    x = g;
    plain = jacobi(plain);
  }
  std::printf("relative error after 60 maps: Jacobi %.2g, with Anderson (depth 5) %.2g\n",
              error(plain), error(x));
  EXPECT_LT(error(x), 1e-3);
  EXPECT_GT(error(plain), 0.3);
  EXPECT_EQ(mixer.kept(), 5);
}

TEST(Anderson, FirstMixAfterAResetIsThePlainMap) {
  AndersonMixer mixer;
  mixer.reset(3, 4);
  const std::vector<double> x{1.0, 2.0, 3.0};
  std::vector<double> g = jacobi(x);
  const std::vector<double> expected = g;
  mixer.mix(x, g);
  EXPECT_EQ(g, expected);
  EXPECT_EQ(mixer.kept(), 0);
}

TEST(Anderson, AGrowingResidualDropsTheHistory) {
  // Residuals 1, 0.5 (kept: one difference), then 2 (grew: history dropped, iterate unmixed).
  AndersonMixer mixer;
  mixer.reset(2, 4);
  const std::vector<double> x{0.0, 0.0};
  std::vector<double> g{1.0, 0.0};
  mixer.mix(x, g);
  g = {0.5, 0.0};
  mixer.mix(x, g);
  EXPECT_EQ(mixer.kept(), 1);
  g = {2.0, 0.0};
  mixer.mix(x, g);
  EXPECT_EQ(mixer.kept(), 0);
  EXPECT_EQ(g, (std::vector<double>{2.0, 0.0}));
}

/// G(x)_i = 1 + 0.49 (x_{i-1} + x_{i+1}): a contraction (factor up to 0.98) of any length.
std::vector<double> damped_neighbours(const std::vector<double>& x) {
  return neighbour_map(x, 1.0, 0.49);
}

/// max_i |G(x)_i - x_i|.
double map_residual(const std::vector<double>& x) {
  const std::vector<double> g = damped_neighbours(x);
  double worst = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) worst = std::max(worst, std::abs(g[i] - x[i]));
  return worst;
}

/// 40 maps of damped_neighbours on 3079 unknowns (six chunks and a tail), depth 5, mixed by
/// `threads` threads calling mix() together inside a parallel region, or by the calling thread
/// alone outside any (threads = 0). Returns the last iterate; `team` gets the team's size.
std::vector<double> mixed_by_a_team(int threads, int& team) {
  constexpr std::size_t kN = 6 * AndersonMixer::kChunk + 7;
  AndersonMixer mixer;
  mixer.reset(kN, 5);
  std::vector<double> x(kN, 0.0), g;
  team = 1;
  if (threads == 0) {
    for (int k = 0; k < 40; ++k) {
      g = damped_neighbours(x);
      mixer.mix(x, g);
      x = g;
    }
    return x;
  }
#if defined(_OPENMP)
#pragma omp parallel num_threads(threads)
#endif
  for (int k = 0; k < 40; ++k) {
#if defined(_OPENMP)
#pragma omp single
#endif
    {
      g = damped_neighbours(x);
#if defined(_OPENMP)
      team = omp_get_num_threads();
#endif
    }
    mixer.mix(x, g);
#if defined(_OPENMP)
#pragma omp single
#endif
    x = g;
  }
  EXPECT_GT(mixer.kept(), 0);  // the history was in use: the sums were computed
  return x;
}

TEST(Anderson, TheMixIsTheSameBitForBitOnAnyNumberOfThreads) {
  // The passes are shared among the threads in chunks fixed by the vector's length, and each
  // sum is added chunk by chunk in order: one, two or three threads, or no team at all, give
  // the same iterates to the last bit.
  CDSHEAR_SKIP_IF_ONE_PROCESSOR();
  int team = 0;
  const std::vector<double> alone = mixed_by_a_team(0, team);
  const std::vector<double> one = mixed_by_a_team(1, team);
  EXPECT_EQ(one, alone);
  for (const int threads : {2, 3}) {
    const std::vector<double> shared = mixed_by_a_team(threads, team);
#if defined(_OPENMP)
    EXPECT_EQ(team, threads);
#endif
    EXPECT_EQ(shared, alone) << threads << " threads";
  }
  // And the mix did its work: 40 plain maps leave a far larger residual.
  std::vector<double> plain(alone.size(), 0.0);
  for (int k = 0; k < 40; ++k) plain = damped_neighbours(plain);
  EXPECT_LT(map_residual(alone), 0.1 * map_residual(plain));  // measured: 0.012 against 0.45
}

}  // namespace
}  // namespace cdshear
