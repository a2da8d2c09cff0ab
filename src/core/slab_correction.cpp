#include "slab_correction.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>

#include <lapacke.h>

#include "nlgs_solver.hpp"

namespace cdshear {

static_assert(std::is_same_v<lapack_int, std::int32_t>, "SlabCorrection::pivots_ is 32-bit");

void SlabCorrection::reset(std::size_t bodies, const SlabLayout& layout) {
  layout_ = layout;
  const std::size_t groups = layout.group_start->size() - 1;
  // Every apply() leaves the slots' marks and the chunk matrices zero (a slot is started from
  // zero by its first row): cleared here only when their size changes.
  if (slots_.size() != bodies) {
    slots_.assign(bodies, BodySlots{});
    used_slots_.assign(bodies, 0);
  }
  bodies_ = bodies;
  chunks_ = (bodies + kChunk - 1) / kChunk;
  const std::size_t matrix = chunks_ * layout.bands * kDiagonals;
  if (chunk_matrix_.size() != matrix) chunk_matrix_.assign(matrix, 0.0);
  group_rhs_.assign(2 * groups, 0.0);
  group_low_.assign(groups, kNoNode);  // the serial group keeps it: no phase writes it
  scale_.assign(layout.bands, 0.0);
}

bool SlabCorrection::apply(std::vector<SolverRow>& rows, std::vector<SolverBody>& bodies) {
  const std::vector<std::uint32_t>& node_of = *layout_.node_of_body;
  const std::size_t bands = layout_.bands;

  // A slot's first row in this correction starts it from zero and marks it (pass 4 leaves the
  // slots as they are and clears the marks only: clearing 120 bytes per body there cost more
  // than this test, most on two threads).
  const auto start_slot = [&](std::uint32_t body, std::size_t slot) {
    std::uint8_t& used = used_slots_[body];
    if ((used >> slot & 1u) != 0) return;
    BodySlots& s = slots_[body];
    s.force[slot] = s.test[slot] = Vec2{};
    s.torque[slot] = 0.0;
    used |= static_cast<std::uint8_t>(1u << slot);
  };

  // 1. The rows: each body's impulse, torque and test vector per neighbouring band, and each
  //    group's share of r (for its lowest band and the one above), group by group.
  for_each_phased_group(*layout_.phases, [&](std::size_t g) {
    double rhs_low = 0.0, rhs_high = 0.0;
    std::uint32_t low = kNoNode;
    for (const std::uint32_t i : (*layout_.awake)[g]) {
      const SolverRow& r = rows[i];
      if (r.impulse_n == 0.0) continue;
      const std::uint32_t na = node_of[r.body_a], nb = node_of[r.body_b];
      if (na == kNoNode || nb == kNoNode) continue;
      if (low == kNoNode) low = std::min(na, nb);
      const SolverBody& a = bodies[r.body_a];
      const SolverBody& b = bodies[r.body_b];
      const Vec2 n = r.normal;
      const Vec2 force{r.impulse_n * n.x - r.impulse_t * n.y,
                       r.impulse_n * n.y + r.impulse_t * n.x};
      const Vec2 test{r.impulse_n * n.x, r.impulse_n * n.y};
      const double torque_a = r.lever_a * r.impulse_t, torque_b = r.lever_b * r.impulse_t;
      const double u_n = (a.velocity.x - b.velocity.x) * n.x + (a.velocity.y - b.velocity.y) * n.y;
      const double power = r.impulse_n * (u_n + r.bias_n);
      BodySlots& sa = slots_[r.body_a];
      BodySlots& sb = slots_[r.body_b];
      // The row's share (f, t, torques, power) added to the slots of band `node` of both bodies:
      // node - band + 1 is 0, 1 or 2, since a row joins bodies of the same or neighbouring bands.
      // Forced inline: g++ 12 called it out of line, and this pass ran 5% of a step slower
      // (farm-bench, 5 pairs, system 7 at t = 820, one thread).
      const auto add = [&](std::uint32_t node, Vec2 f, Vec2 t, double ta, double tb, double p)
          __attribute__((always_inline)) {
        const std::size_t slot_a = node + 1 - na, slot_b = node + 1 - nb;
        start_slot(r.body_a, slot_a);
        start_slot(r.body_b, slot_b);
        sa.force[slot_a] += f;
        sa.test[slot_a] += t;
        sa.torque[slot_a] += ta;
        sb.force[slot_b] -= f;
        sb.test[slot_b] -= t;
        sb.torque[slot_b] += tb;
        (node == low ? rhs_low : rhs_high) += p;
      };
      if (na == nb) {  // most rows: the whole row to its one band (weight 1, nothing to scale)
        add(na, force, test, torque_a, torque_b, power);
        continue;
      }
      // A row across a boundary: half to each band.
      const Vec2 half_force = 0.5 * force, half_test = 0.5 * test;
      const double half_ta = 0.5 * torque_a, half_tb = 0.5 * torque_b, half_power = 0.5 * power;
      add(na, half_force, half_test, half_ta, half_tb, half_power);
      add(nb, half_force, half_test, half_ta, half_tb, half_power);
    }
    group_rhs_[2 * g] = rhs_low;
    group_rhs_[2 * g + 1] = rhs_high;
    group_low_[g] = low;  // kNoNode: nothing to add
  });

  // 2. A, chunk by chunk of bodies: body k adds test_p . M^-1 force_q to A(band_p, band_q) for
  //    its slots p and q (band_p = its band + p - 1).
#if defined(_OPENMP)
#pragma omp for schedule(static)
#endif
  for (std::size_t chunk = 0; chunk < chunks_; ++chunk) {
    double* m = &chunk_matrix_[chunk * bands * kDiagonals];
    const std::size_t begin = chunk * kChunk, end = std::min(bodies_, begin + kChunk);
    for (std::size_t k = begin; k < end; ++k) {
      const unsigned used = used_slots_[k];
      if (used == 0) continue;  // no row: every slot is zero (so is the body's band's term)
      const std::uint32_t band = node_of[k];
      const BodySlots& s = slots_[k];
      const Vec2 inv_mass = bodies[k].inv_mass;
      // The slots a row added to, p from first to last (a slot no row reached is zero, and so
      // is its band's term), and of those the ones whose sums are not zero: a term with an
      // empty test or force vector is a zero, and adding a zero changes no sum (A's zero
      // entries are skipped whatever their sign). Most disks have rows in one or two slots
      // (near one boundary of their slab at most): 1 or 4 products instead of 9. A slot's
      // band exists: a row joins bodies of the same or neighbouring bands.
      std::array<std::size_t, 3> tests{}, forces{};
      std::array<Vec2, 3> moved{};
      std::size_t n_tests = 0, n_forces = 0;
      for (std::size_t p = 0; p < 3; ++p) {
        if ((used >> p & 1u) == 0) continue;
        if (s.test[p].x != 0.0 || s.test[p].y != 0.0) tests[n_tests++] = p;
        if (s.force[p].x != 0.0 || s.force[p].y != 0.0) {
          moved[p] = hadamard(inv_mass, s.force[p]);
          forces[n_forces++] = p;
        }
      }
      for (std::size_t i = 0; i < n_tests; ++i) {
        const std::size_t p = tests[i];
        double* row = m + (band + p - 1) * kDiagonals;
        for (std::size_t j = 0; j < n_forces; ++j) {
          const std::size_t q = forces[j];
          row[q + 2 - p] += dot(s.test[p], moved[q]);
        }
      }
    }
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
    const std::uint32_t band = node_of[k];
    const BodySlots& s = slots_[k];
    if (solved_) {
      Vec2 impulse{};
      double torque = 0.0;
      for (std::size_t p = 0; p < 3; ++p) {
        // A slot no row reached, or whose sums are zero, adds zeros (as in pass 2).
        if ((used >> p & 1u) == 0) continue;
        if (s.force[p].x == 0.0 && s.force[p].y == 0.0 && s.torque[p] == 0.0) continue;
        const double scale = scale_[band + p - 1];
        impulse += scale * s.force[p];
        torque += scale * s.torque[p];
      }
      SolverBody& body = bodies[k];
      body.velocity += hadamard(body.inv_mass, impulse);
      body.omega += body.inv_inertia * torque;
    }
    used_slots_[k] = 0;  // the slots themselves are reset by their next first row (pass 1)
  }
  if (!solved_) return false;

  // 5. The rows' impulses, scaled.
  // Each thread its consecutive groups with an equal share of the rows (groups_share): an omp
  // for over the groups gave the first thread nearly all the slabs.
  const Share mine = groups_share(*layout_.group_start, team_place());
  for (std::size_t g = mine.first; g < mine.last; ++g) {
    if (group_low_[g] == kNoNode) continue;  // no row to scale (or the serial group)
    for (const std::uint32_t i : (*layout_.awake)[g]) {
      SolverRow& r = rows[i];
      if (r.impulse_n == 0.0) continue;
      const std::uint32_t na = node_of[r.body_a], nb = node_of[r.body_b];
      if (na == kNoNode || nb == kNoNode) continue;
      const double scale = 1.0 + 0.5 * (scale_[na] + scale_[nb]);
      r.impulse_n *= scale;
      r.impulse_t *= scale;
    }
  }
  team_barrier();  // the next sweep reads any row
  return true;
}

bool SlabCorrection::solve() {
  const std::size_t bands = layout_.bands;
  // r, summed group by group in group order; the right-hand side -r, overwritten by s.
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
    double* m = &chunk_matrix_[chunk * bands * kDiagonals];
    for (std::size_t i = 0; i < bands; ++i) {
      for (std::size_t d = 0; d < kDiagonals; ++d) {
        double& v = m[i * kDiagonals + d];
        if (v == 0.0) continue;
        at(i, i + d - 2) += v;  // d = j - i + 2; a nonzero share has 0 <= j < bands
        v = 0.0;
      }
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
