#include "slab_correction.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>

#include <lapacke.h>

#include "nlgs_solver.hpp"

namespace cdshear {

static_assert(std::is_same_v<lapack_int, std::int32_t>, "SlabCorrection::pivots_ is 32-bit");

namespace {

/// Calls f(std::integral_constant<std::size_t, p>) for the slots p = 0, 1, 2: each call sees
/// its slot as a constant, so arrays indexed by slots stay in registers.
template <class F>
[[gnu::always_inline]] inline void each_slot(F&& f) {
  [&]<std::size_t... P>(std::index_sequence<P...>) {
    (f(std::integral_constant<std::size_t, P>{}), ...);
  }
  (std::make_index_sequence<3>{});
}

/// Pass 2's sums of the chunk matrix's rows B - 1, B and B + 1 (the bands of a band-B body's
/// slots p = 0, 1, 2), held while consecutive bodies share B: a[p][q] is A(B + p - 1,
/// B + q - 1), at entry q + 2 - p of row B + p - 1 (its diagonals), r[p] that row's share of r.
/// Rows outside [0, bands) are neither loaded nor stored: no slot of a band-B body reaches them,
/// so their sums here only ever add zeros.
struct BandWindow {
  std::array<std::array<double, 3>, 3> a{};
  std::array<double, 3> r{};

  [[gnu::always_inline]] void load(const double* m, std::uint32_t band, std::size_t bands) {
    each_slot([&](auto p) {
      const std::size_t row = band + p;  // row band + p - 1, offset by one
      if (row < 1 || row > bands) return;
      const double* entries = m + (row - 1) * SlabCorrection::kChunkEntries;
      r[p] = entries[SlabCorrection::kDiagonals];
      each_slot([&](auto q) { a[p][q] = entries[q + 2 - p]; });
    });
  }
  [[gnu::always_inline]] void store(double* m, std::uint32_t band, std::size_t bands) const {
    each_slot([&](auto p) {
      const std::size_t row = band + p;
      if (row < 1 || row > bands) return;
      double* entries = m + (row - 1) * SlabCorrection::kChunkEntries;
      entries[SlabCorrection::kDiagonals] = r[p];
      each_slot([&](auto q) { entries[q + 2 - p] = a[p][q]; });
    });
  }
};

}  // namespace

void SlabCorrection::reset(std::size_t bodies, const SlabLayout& layout) {
  layout_ = layout;
  node_of_ = layout.node_of_body->data();
  const std::size_t groups = layout.group_start->size() - 1;
  // Every apply_gathered() leaves the slots' marks and the chunk matrices zero (a slot is
  // started from zero by its first row). The marks are cleared here too: the solver gathers in
  // the sweep before a correction, and when that sweep ends the step there is no correction.
  if (slots_.size() != bodies) slots_.assign(bodies, BodySlots{});
  used_slots_.assign(bodies, 0);
  bodies_ = bodies;
  chunks_ = (bodies + kChunk - 1) / kChunk;
  const std::size_t matrix = chunks_ * layout.bands * kChunkEntries;
  if (chunk_matrix_.size() != matrix) chunk_matrix_.assign(matrix, 0.0);
  group_rhs_.assign(2 * groups, 0.0);
  group_low_.assign(groups, kNoNode);  // the serial group keeps it: no phase writes it
  scale_.assign(layout.bands, 0.0);
}

void SlabCorrection::gather_rows(const std::vector<SolverRow>& rows) {
  // 1. The rows: each body's impulse, torque and test vector per neighbouring band, and each
  //    group's share of r's gap part (for its lowest band and the one above), group by group.
  for_each_phased_group(*layout_.phases, [&](std::size_t g) {
    GroupGather group;
    for (const std::uint32_t i : (*layout_.awake)[g]) gather_row(rows[i], group);
    finish_group(g, group);
  });
}

bool SlabCorrection::apply_gathered(std::vector<SolverRow>& rows, std::vector<SolverBody>& bodies,
                                    bool scale_rows) {
  const std::size_t bands = layout_.bands;

  // 2. A and r's velocity part, chunk by chunk of bodies: body k adds test_p . M^-1 force_q to
  //    A(band_p, band_q) for its slots p and q (band_p = its band + p - 1), and test_p . v_k to
  //    r(band_p): summed over the bodies, test . v is the sum over the rows of w R_n u_n (a
  //    row's test vector is +R_n n on a and -R_n n on b, and u_n = (v_a - v_b) . n).
#if defined(_OPENMP)
#pragma omp for schedule(static)
#endif
  for (std::size_t chunk = 0; chunk < chunks_; ++chunk) {
    double* m = &chunk_matrix_[chunk * bands * kChunkEntries];
    const std::size_t begin = chunk * kChunk, end = std::min(bodies_, begin + kChunk);
    // The sums of the three rows around one band B, in registers while the bodies have band B
    // (runs of bodies share a band: they are numbered slab by slab). Added in memory, each
    // body's term waited for the last body's store of the same entry to be read back; in
    // registers the chain is one addition per body. Loaded from and stored back to the chunk's
    // matrix when B changes: the same additions in the same order, so the same sums.
    BandWindow window;
    std::uint32_t window_band = kNoNode;
    for (std::size_t k = begin; k < end; ++k) {
      const unsigned used = used_slots_[k];
      if (used == 0) continue;  // no row: every slot is zero (so is the body's band's term)
      const std::uint32_t band = node_of_[k];
      if (band != window_band) {
        if (window_band != kNoNode) window.store(m, window_band, bands);
        window.load(m, band, bands);
        window_band = band;
      }
      const BodySlots& s = slots_[k];
      const Vec2 inv_mass = bodies[k].inv_mass;
      const Vec2 velocity = bodies[k].velocity;
      // Every slot a row added to, each test against every force, a slot no row reached
      // taken as zero. A term with an empty test or force vector is a zero (of either sign),
      // and adding a zero to a sum that is not -0 changes nothing: a sum starts at +0 and a
      // sum of finite numbers in round-to-nearest is -0 only when every term is, so these
      // sums are those of the zero-skipping loops they replaced (1 to 4 products for most
      // disks, which use one or two of their three slots; here 3 or 6, without the memory).
      // A slot's band exists: a row joins bodies of the same or neighbouring bands.
      std::array<Vec2, 3> moved;
      each_slot([&](auto q) {
        moved[q] = (used >> q & 1u) != 0 ? hadamard(inv_mass, s.force[q]) : Vec2{};
      });
      each_slot([&](auto p) {
        if ((used >> p & 1u) == 0) return;
        const Vec2 test = s.test[p];
        window.r[p] += dot(test, velocity);
        each_slot([&](auto q) { window.a[p][q] += dot(test, moved[q]); });
      });
    }
    if (window_band != kNoNode) window.store(m, window_band, bands);
  }

  // 3. On one thread: add the shares in order, solve A s = -r, bound s.
#if defined(_OPENMP)
#pragma omp single
#endif
  solved_ = solve();

  // 4. The bodies follow the scaled impulses (sum over slots of s_band M^-1 impulse; the same
  //    as applying each row's change), and their slots' marks are cleared for the next
  //    correction.
#if defined(_OPENMP)
#pragma omp for schedule(static)
#endif
  for (std::size_t k = 0; k < bodies_; ++k) {
    const unsigned used = used_slots_[k];
    if (used == 0) continue;  // no row: nothing to move
    const std::uint32_t band = node_of_[k];
    if (solved_) {
      // Every slot, a slot no row reached taken as zero (its stale sums masked, its band's
      // scale read from the padding when the band does not exist): adding the zero of an
      // empty slot changes neither sum (pass 2's argument: they start at +0), so these are
      // the sums of the slot-skipping loop they replaced, without its branches.
      const BodySlots& s = slots_[k];
      const double* scale = scale_padded_.data() + band;  // scale[p]: band + p - 1's
      Vec2 impulse{};
      double torque = 0.0;
      each_slot([&](auto p) {
        const bool reached = (used >> p & 1u) != 0;
        const Vec2 force = reached ? s.force[p] : Vec2{};
        const double turn = reached ? s.torque[p] : 0.0;
        impulse += scale[p] * force;
        torque += scale[p] * turn;
      });
      SolverBody& body = bodies[k];
      body.velocity += hadamard(body.inv_mass, impulse);
      body.omega += body.inv_inertia * torque;
    }
    used_slots_[k] = 0;  // the slots themselves are reset by their next first row (pass 1)
  }
  if (!solved_) return false;

  if (!scale_rows) return true;  // the caller scales them (pass 4's loop ended on a barrier)

  // 5. The rows' impulses, scaled.
  // Each thread its consecutive groups with an equal share of the rows (groups_share): an omp
  // for over the groups gave the first thread nearly all the slabs.
  const Share mine = groups_share(*layout_.group_start, team_place());
  for (std::size_t g = mine.first; g < mine.last; ++g) {
    if (group_low_[g] == kNoNode) continue;  // no row to scale (or the serial group)
    for (const std::uint32_t i : (*layout_.awake)[g]) scale_row(rows[i]);
  }
  team_barrier();  // the next sweep reads any row
  return true;
}

bool SlabCorrection::solve() {
  const std::size_t bands = layout_.bands;
  // r: its gap part summed group by group in group order, then its velocity part chunk by chunk
  // (below); the right-hand side -r, overwritten by s.
  std::vector<double>& x = scale_;
  std::fill(x.begin(), x.end(), 0.0);
  for (std::size_t g = 0; g < group_low_.size(); ++g) {
    const std::uint32_t low = group_low_[g];
    if (low == kNoNode) continue;
    x[low] -= group_rhs_[2 * g];
    if (low + 1 < bands) x[low + 1] -= group_rhs_[2 * g + 1];
  }
  // A in LAPACK's band storage: A(i, j) at (kl + ku + i - j) + j ldab, with kl = ku = 2 and
  // ldab = 2 kl + ku + 1 (dgbsv keeps kl rows above for the fill-in of its row swaps).
  constexpr int kl = 2, ku = 2, ldab = 2 * kl + ku + 1;
  band_matrix_.assign(static_cast<std::size_t>(ldab) * bands, 0.0);
  const auto at = [&](std::size_t i, std::size_t j) -> double& {
    return band_matrix_[static_cast<std::size_t>(kl + ku) + i - j + j * ldab];
  };
  for (std::size_t chunk = 0; chunk < chunks_; ++chunk) {
    double* m = &chunk_matrix_[chunk * bands * kChunkEntries];
    for (std::size_t i = 0; i < bands; ++i) {
      for (std::size_t d = 0; d < kDiagonals; ++d) {
        double& v = m[i * kChunkEntries + d];
        if (v == 0.0) continue;
        at(i, i + d - 2) += v;  // d = j - i + 2; a nonzero share has 0 <= j < bands
        v = 0.0;
      }
      double& r = m[i * kChunkEntries + kDiagonals];
      x[i] -= r;
      r = 0.0;
    }
  }
  // A band without force-carrying rows has an empty row and column: s = 0 there.
  for (std::size_t i = 0; i < bands; ++i) {
    bool empty = true;
    for (std::size_t j = i >= 2 ? i - 2 : 0; j <= i + 2 && j < bands; ++j)
      empty = empty && at(i, j) == 0.0;
    if (empty) {
      at(i, i) = 1.0;
      x[i] = 0.0;
    }
  }
  pivots_.resize(bands);
  const lapack_int info = LAPACKE_dgbsv(LAPACK_COL_MAJOR, static_cast<lapack_int>(bands), kl, ku, 1,
                                        band_matrix_.data(), ldab, pivots_.data(), x.data(),
                                        static_cast<lapack_int>(bands));
  bool finite = info == 0;
  for (const double v : x) finite = finite && std::isfinite(v);
  if (!finite) {
    std::fill(x.begin(), x.end(), 0.0);
    return false;
  }
  for (double& v : x) v = std::clamp(v, kLowestScale, kHighestScale);
  scale_padded_.assign(bands + 2, 0.0);
  std::copy(x.begin(), x.end(), scale_padded_.begin() + 1);
  return true;
}

}  // namespace cdshear
