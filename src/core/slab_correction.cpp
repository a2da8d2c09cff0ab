#include "slab_correction.hpp"

#include <algorithm>
#include <cmath>
#include <span>
#include <type_traits>
#include <utility>

#include <lapacke.h>

#include "nlgs_solver.hpp"

namespace cdshear {

static_assert(std::is_same_v<lapack_int, std::int32_t>, "SlabCorrection::pivots_ is 32-bit");

namespace {

/// Calls f(std::integral_constant<std::size_t, p>) for the slots p = 0, 1, 2: the loop over a
/// body's slots unrolled, each call seeing its slot as a compile-time constant.
template <class F>
[[gnu::always_inline]] inline void each_slot(F&& f) {
  [&]<std::size_t... P>(std::index_sequence<P...>) {
    (f(std::integral_constant<std::size_t, P>{}), ...);
  }
  (std::make_index_sequence<3>{});
}

/// One row of pass 2's window: the sums of the chunk matrix's row B + p - 1 that the slot p of
/// a band-B body adds to, held in registers while consecutive bodies share B: A(B + p - 1,
/// B + q - 1) for q = 0, 1, 2 (at entry q + 2 - p of the row: its diagonals) and the row's
/// share of r. Separate scalars, not an array, so that the compiler keeps them in registers.
struct WindowRow {
  double a0 = 0.0, a1 = 0.0, a2 = 0.0, r = 0.0;

  /// Loads row B + p - 1 (`row` is B + p, offset by one); a row outside [0, bands) is not
  /// loaded: no slot of a band-B body reaches it, so its sums here only ever add zeros.
  [[gnu::always_inline]] void load(const double* m, std::size_t row, std::size_t p,
                                   std::size_t bands) {
    if (row < 1 || row > bands) return;
    const double* e = m + (row - 1) * SlabCorrection::kChunkEntries + 2 - p;
    a0 = e[0];
    a1 = e[1];
    a2 = e[2];
    r = m[(row - 1) * SlabCorrection::kChunkEntries + SlabCorrection::kDiagonals];
  }
  [[gnu::always_inline]] void store(double* m, std::size_t row, std::size_t p,
                                    std::size_t bands) const {
    if (row < 1 || row > bands) return;
    double* e = m + (row - 1) * SlabCorrection::kChunkEntries + 2 - p;
    e[0] = a0;
    e[1] = a1;
    e[2] = a2;
    m[(row - 1) * SlabCorrection::kChunkEntries + SlabCorrection::kDiagonals] = r;
  }
  /// A slot's terms: its test vector against the body's velocity and its three moved forces.
  [[gnu::always_inline]] void add(Vec2 test, Vec2 velocity, Vec2 moved0, Vec2 moved1, Vec2 moved2) {
    r += dot(test, velocity);
    a0 += dot(test, moved0);
    a1 += dot(test, moved1);
    a2 += dot(test, moved2);
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
  scale_.assign(layout.bands + 2, 0.0);
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
  add_body_sums(bodies);  // pass 2
  // 3. On one thread: add the shares in order, solve A s = -r, bound s.
#if defined(_OPENMP)
#pragma omp single nowait
#endif
  solved_ = solve();
  team_barrier();
  move_bodies(bodies);  // pass 4
  if (!solved_) return false;
  if (!scale_rows) return true;  // the caller scales them (pass 4's loop ended on a barrier)
  scale_gathered_rows(rows);     // pass 5
  team_barrier();                // the next sweep reads any row
  return true;
}

void SlabCorrection::add_body_sums(const std::vector<SolverBody>& bodies) {
  const std::size_t bands = layout_.bands;
  // 2. A and r's velocity part, chunk by chunk of bodies: body k adds test_p . M^-1 force_q to
  //    A(band_p, band_q) for its slots p and q (band_p = its band + p - 1), and test_p . v_k to
  //    r(band_p): summed over the bodies, test . v is the sum over the rows of w R_n u_n (a
  //    row's test vector is +R_n n on a and -R_n n on b, and u_n = (v_a - v_b) . n).
#if defined(_OPENMP)
#pragma omp for schedule(static) nowait
#endif
  for (std::size_t chunk = 0; chunk < chunks_; ++chunk) {
    double* m = &chunk_matrix_[chunk * bands * kChunkEntries];
    const std::size_t begin = chunk * kChunk, end = std::min(bodies_, begin + kChunk);
    // The sums of the three rows around one band B, in registers while the bodies have band B
    // (runs of bodies share a band: they are numbered slab by slab). Added in memory, each
    // body's term waited for the last body's store of the same entry to be read back; in
    // registers the chain is one addition per body. Loaded from and stored back to the chunk's
    // matrix when B changes: the same additions in the same order, so the same sums.
    WindowRow below, own, above;  // rows B - 1, B and B + 1
    std::size_t window_band = kNoNode;
    const auto store_window = [&] {
      below.store(m, window_band, 0, bands);
      own.store(m, window_band + 1, 1, bands);
      above.store(m, window_band + 2, 2, bands);
    };
    for (std::size_t k = begin; k < end; ++k) {
      const unsigned used = used_slots_[k];
      if (used == 0) continue;  // no row: every slot is zero (so is the body's band's term)
      const std::size_t band = node_of_[k];
      if (band != window_band) {
        if (window_band != kNoNode) store_window();
        window_band = band;
        below.load(m, band, 0, bands);
        own.load(m, band + 1, 1, bands);
        above.load(m, band + 2, 2, bands);
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
      const Vec2 moved0 = (used & 1u) != 0 ? hadamard(inv_mass, s.force[0]) : Vec2{};
      const Vec2 moved1 = (used & 2u) != 0 ? hadamard(inv_mass, s.force[1]) : Vec2{};
      const Vec2 moved2 = (used & 4u) != 0 ? hadamard(inv_mass, s.force[2]) : Vec2{};
      if ((used & 1u) != 0) below.add(s.test[0], velocity, moved0, moved1, moved2);
      if ((used & 2u) != 0) own.add(s.test[1], velocity, moved0, moved1, moved2);
      if ((used & 4u) != 0) above.add(s.test[2], velocity, moved0, moved1, moved2);
    }
    if (window_band != kNoNode) store_window();
  }
  team_barrier();
}

void SlabCorrection::move_bodies(std::vector<SolverBody>& bodies) {
  // 4. The bodies follow the scaled impulses (sum over slots of s_band M^-1 impulse; the same
  //    as applying each row's change), and their slots' marks are cleared for the next
  //    correction.
  {
    // The addresses and the decision in locals: the marks are bytes, which may alias anything
    // for the compiler, so read through the members they were loaded again after each mark.
    const bool solved = solved_;
    const std::size_t body_count = bodies_;
    std::uint8_t* const marks = used_slots_.data();
    const std::uint32_t* const node_of = node_of_;
    const BodySlots* const slots = slots_.data();
    const double* const scales = scale_.data();
    SolverBody* const body_data = bodies.data();
#if defined(_OPENMP)
#pragma omp for schedule(static) nowait
#endif
    for (std::size_t k = 0; k < body_count; ++k) {
      const unsigned used = marks[k];
      if (used == 0) continue;  // no row: nothing to move
      if (solved) {
        // Every slot, a slot no row reached taken as zero (its stale sums masked, its band's
        // scale read from the padding when the band does not exist): adding the zero of an
        // empty slot changes neither sum (pass 2's argument: they start at +0), so these are
        // the sums of the slot-skipping loop they replaced, without its branches.
        const BodySlots& s = slots[k];
        const double* scale = scales + node_of[k];  // scale[p]: band + p - 1's
        Vec2 impulse{};
        double torque = 0.0;
        each_slot([&](auto p) {
          const bool reached = (used >> p & 1u) != 0;
          const Vec2 force = reached ? s.force[p] : Vec2{};
          const double turn = reached ? s.torque[p] : 0.0;
          impulse += scale[p] * force;
          torque += scale[p] * turn;
        });
        SolverBody& body = body_data[k];
        body.velocity += hadamard(body.inv_mass, impulse);
        body.omega += body.inv_inertia * torque;
      }
      marks[k] = 0;  // the slots themselves are reset by their next first row (pass 1)
    }
  }
  team_barrier();
}

void SlabCorrection::scale_gathered_rows(std::vector<SolverRow>& rows) {
  // 5. The rows' impulses, scaled.
  // Each thread its share of every phase's groups (for_each_own_group): each row is scaled once,
  // so the split does not change the result.
  const std::size_t serial_group = layout_.group_start->size() - 2;
  for_each_own_group(*layout_.phases, serial_group, team_place(), [&](std::size_t g) {
    if (group_low_[g] == kNoNode) return;  // no row to scale (or the serial group)
    for (const std::uint32_t i : (*layout_.awake)[g]) scale_row(rows[i]);
  });
}

bool SlabCorrection::solve() {
  const std::size_t bands = layout_.bands;
  // r: its gap part summed group by group in group order, then its velocity part chunk by chunk
  // (below); the right-hand side -r, overwritten by s.
  const std::span<double> x(scale_.data() + 1, bands);  // between scale_'s two zeros
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
  return true;
}

}  // namespace cdshear
