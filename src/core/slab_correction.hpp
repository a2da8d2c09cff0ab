// Slab correction: a coarse correction of the Gauss-Seidel iterate across the height of a tall
// packing (docs/performance.md, "Slab correction"; docs/step-error.md, "Tall cells").
//
// Why. A Gauss-Seidel sweep carries a change of force a few contacts further, so the force
// profile over the height of a tall packing relaxes over hundreds of sweeps. On system 7 (200 d
// tall) in its slow phase, a step stopped by the convergence criterion after 120 sweeps carried
// across some band boundaries 80% less vertical force than the same step solved to round-off, and
// the runs lost 7% of their force-carrying contacts against tightly solved ones.
//
// What. The nodes are the bands of the coloured order (SolverBody::band: slabs four diameters
// tall). Every force-carrying row of a slab or boundary group is scaled,
//   R_c <- (1 + s_c) R_c,   s_c = (s_i + s_j) / 2,
// with i and j the bands of its two bodies (a wall takes its disk's band). A scaled impulse stays
// in its Coulomb cone (s_c >= kLowestScale > -1) and an open row stays open. The s solve the
// Petrov-Galerkin system: for every band j, the force-weighted mean of the biased normal
// velocities of the rows it scales vanishes after the correction,
//   r_j(s) = sum_c w_jc R_n,c (u_n,c(s) + gap_c / dt) = 0,   w_jc = weight of s_j in s_c,
// and u_n is linear in s (the bodies' velocities follow the impulses, v = v_free + M^-1 H^T R):
//   A s = -r(0),  A_jk = sum_c w_jc R_n,c n_c . (dv_a,k - dv_b,k),
//   dv_body,k = M^-1 (sum of w_kc' P_c' over the rows c' of that body, P the impulse vector on it).
// u_n has no rotational part (a normal passes through disk centres; walls do not turn), so A needs
// the bodies' translations only. A body's rows reach its own band and the two next to it, so A
// is banded, |j - k| <= 2; it is solved by LAPACK's dgbsv (partial pivoting: A is not symmetric).
//
// Fixed points. At a solution of the step every closed row has u_n + gap/dt = 0 and every open
// one R_n = 0: r = 0, s = 0, and the correction changes nothing. Where the step has several
// solutions (rigid frictional contacts need not have one only), the corrected iteration may end
// on another one than plain Gauss-Seidel: docs/accuracy.md compares run averages, not step
// solutions.
//
// Passes (slab_correction.cpp): (1) gather: each force-carrying row adds its impulse, torque and
// normal ("test") vector to its bodies' slots (one per neighbouring band) and w R_n gap/dt to
// its group's share of r; (2) the bodies, chunk by chunk, add test . M^-1 force to A and test . v
// to r (the velocity part of r: summed over the bodies it is the sum over the rows of
// w R_n u_n); (3) one thread solves; (4) the bodies move by M^-1 times their slots weighted by
// s; (5) the rows are scaled. The solver runs pass 1 inside the sweep before the correction
// (gather_row after each row's update: the same calls in the same order as gather_rows) and,
// when the Anderson mix follows, pass 5 inside the mix's gather (scale_row): two passes over
// the rows fewer per correction.
//
// Threads. apply(), gather_rows and apply_gathered are called by every thread of the solver's
// team at once (or by one thread outside any parallel region), like AndersonMixer::mix, and
// gather_row by the solver's parallel sweep: passes over rows go group by group, phase by phase
// (groups of a phase share no body, so no two threads write one body's slots), passes over
// bodies in chunks of kChunk bodies whatever the thread count, each chunk's sums added in chunk
// order: the same result on any number of threads. r's velocity part is summed from absolute
// velocities (test . v per body), its rows' part from relative ones: the same r, but at a
// solution it cancels to a round-off some H/d times larger than the rows' sum of R_n (u_n +
// gap/dt) gave, still far below any tolerance.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "solver_rows.hpp"
#include "vec2.hpp"

namespace cdshear {

/// The solver runs the slab correction only in packings of at least this many bands of four
/// largest diameters (L_y >= 80 d: systems 5 to 7). Below, it has nothing to correct: on system 1
/// (5 bands) the same averages with it and without it, and no sweep saved (docs/accuracy.md).
inline constexpr std::size_t kSlabCorrectionMinBands = 20;

/// Where the slab correction finds the solver's rows, groups and bands.
struct SlabLayout {
  const std::vector<std::size_t>* group_start = nullptr;           ///< rows of group g
  const std::vector<std::vector<std::uint32_t>>* awake = nullptr;  ///< rows each group sweeps
  const std::vector<SolverPhase>* phases = nullptr;  ///< slab and boundary groups, by phase
  std::size_t bands = 0;
  /// Band of each solver body whose rows are corrected (a wall: its disks' band), or kNoNode.
  const std::vector<std::uint32_t>* node_of_body = nullptr;
};

class SlabCorrection {
 public:
  /// Band of a body outside the correction (a wall touching several bands).
  static constexpr std::uint32_t kNoNode = 0xffffffffu;
  /// Bodies per chunk of the assembly pass.
  static constexpr std::size_t kChunk = 256;
  /// Bounds of a scale s_c: an impulse is at most doubled, at least halved, by one correction.
  static constexpr double kLowestScale = -0.5, kHighestScale = 1.0;
  /// Diagonals of the banded matrix A kept per row j: A(j, j + d - 2), d = 0..4.
  static constexpr int kDiagonals = 5;
  /// Per chunk and band in chunk_matrix_: A's five diagonals, then the share of r from the
  /// bodies' velocities (test . v).
  static constexpr int kChunkEntries = kDiagonals + 1;

  /// Sizes the scratch for `bodies` bodies and the layout's groups and bands. One thread, once
  /// per step, before any gathering or apply() of that step.
  void reset(std::size_t bodies, const SlabLayout& layout);

  /// Scales the rows' impulses as above and moves their bodies accordingly: gather_rows, then
  /// apply_gathered. Called by every thread of a team (or one thread alone, see above). Returns
  /// false, changing nothing, when the system is singular or has no solution in floating point.
  bool apply(std::vector<SolverRow>& rows, std::vector<SolverBody>& bodies) {
    gather_rows(rows);
    return apply_gathered(rows, bodies);
  }

  /// One group's share of r while its rows are gathered (pass 1).
  struct GroupGather {
    double rhs_low = 0.0, rhs_high = 0.0;  ///< for its lowest band and the one above
    std::uint32_t low = kNoNode;           ///< its lowest band (kNoNode: no force-carrying row)
  };

  /// Pass 1 for one row whose impulse is final for this correction: its impulse, torque and
  /// normal ("test") vector into its bodies' slots, and w R_n gap/dt into the group's share of
  /// r (the velocity part of r, sum of w R_n u_n, is taken from the slots by the bodies, pass 2).
  /// A row without normal impulse, or with a body outside the correction, adds nothing. The
  /// solver calls it from the sweep before a correction, right after each row's update (the
  /// row's impulse is final once the sweep has visited it): the same calls in the same order as
  /// gather_rows, so the same sums, without a pass of its own over the rows. Inline: it runs in
  /// the solver's hot loop.
  [[gnu::always_inline]] void gather_row(const SolverRow& r, GroupGather& group) {
    if (r.impulse_n == 0.0) return;
    const std::uint32_t na = node_of_[r.body_a], nb = node_of_[r.body_b];
    if (na == kNoNode || nb == kNoNode) return;
    if (group.low == kNoNode) group.low = std::min(na, nb);
    const Vec2 n = r.normal;
    const Vec2 force{r.impulse_n * n.x - r.impulse_t * n.y, r.impulse_n * n.y + r.impulse_t * n.x};
    const Vec2 test{r.impulse_n * n.x, r.impulse_n * n.y};
    const double torque_a = r.lever_a * r.impulse_t, torque_b = r.lever_b * r.impulse_t;
    const double power = r.impulse_n * r.bias_n;
    if (na == nb) {  // most rows: the whole row to its one band (weight 1, nothing to scale)
      add_share(r, na, na, nb, force, test, torque_a, torque_b, power, group);
      return;
    }
    // A row across a boundary: half to each band.
    const Vec2 half_force = 0.5 * force, half_test = 0.5 * test;
    const double half_ta = 0.5 * torque_a, half_tb = 0.5 * torque_b, half_power = 0.5 * power;
    add_share(r, na, na, nb, half_force, half_test, half_ta, half_tb, half_power, group);
    add_share(r, nb, na, nb, half_force, half_test, half_ta, half_tb, half_power, group);
  }

  /// Stores group g's share once gather_row has seen all its awake rows (the thread that
  /// gathered them).
  void finish_group(std::size_t g, const GroupGather& group) {
    group_rhs_[2 * g] = group.rhs_low;
    group_rhs_[2 * g + 1] = group.rhs_high;
    group_low_[g] = group.low;
  }

  /// Pass 1 on its own: gather_row over every awake row of the slab and boundary groups, group
  /// by group, phase by phase. Called by every thread of a team (or one thread alone).
  void gather_rows(const std::vector<SolverRow>& rows);

  /// Passes 2 to 5, once every group's rows are gathered (gather_rows, or the solver's sweep).
  /// Called by every thread of a team (or one thread alone). False as apply(). With
  /// `scale_rows` false it stops before pass 5 and the caller scales the same rows, each with
  /// scale_row, before anything reads them (the solver, in its gather of the impulses for the
  /// Anderson mix that follows the correction: one pass over the rows fewer).
  bool apply_gathered(std::vector<SolverRow>& rows, std::vector<SolverBody>& bodies,
                      bool scale_rows = true);

  /// Pass 5 for one awake row of a slab or boundary group, after a successful apply_gathered:
  /// R <- (1 + (s_a + s_b) / 2) R; a row without normal impulse, or with a body outside the
  /// correction, stays as it is.
  void scale_row(SolverRow& r) const {
    if (r.impulse_n == 0.0) return;
    const std::uint32_t na = node_of_[r.body_a], nb = node_of_[r.body_b];
    if (na == kNoNode || nb == kNoNode) return;
    const double scale = 1.0 + 0.5 * (scale_[na + 1] + scale_[nb + 1]);
    r.impulse_n *= scale;
    r.impulse_t *= scale;
  }

  /// The scales of the last apply() or apply_gathered(), one per band (for tests).
  std::vector<double> scales() const { return {scale_.begin() + 1, scale_.end() - 1}; }

 private:
  /// Pass 2: A and r's velocity part, chunk by chunk of bodies (every thread of the team).
  void add_body_sums(const std::vector<SolverBody>& bodies);
  /// Pass 3 of apply_gathered(), on one thread: r from the groups' and then the chunks' shares,
  /// A from the chunks' shares (clearing them), then s, bounded. False when dgbsv finds A
  /// singular or s is not finite.
  bool solve();
  /// Pass 4: the bodies follow the scaled impulses, their slots' marks cleared (every thread;
  /// ends on the barrier of its loop).
  void move_bodies(std::vector<SolverBody>& bodies);
  /// Pass 5: each thread scales the awake rows of its groups (no barrier).
  void scale_gathered_rows(std::vector<SolverRow>& rows);

  /// What the rows of one body add to the correction, for the bands next to its own (slot 0:
  /// band - 1, slot 1: its band, slot 2: band + 1): the impulse and torque its rows apply to it,
  /// weighted by that band's share in their scale, and the impulse's normal components only
  /// (test).
  struct BodySlots {
    std::array<Vec2, 3> force{}, test{};
    std::array<double, 3> torque{};
  };

  /// A row's share (force, test, torques, power) added to the slots of band `node` of both its
  /// bodies (na, nb their bands): node - band + 1 is 0, 1 or 2, since a row joins bodies of the
  /// same or neighbouring bands. A slot's first row in this correction starts it from zero and
  /// marks it (pass 4 leaves the slots as they are and clears the marks only: clearing 120 bytes
  /// per body there cost more than this test, most on two threads).
  [[gnu::always_inline]] void add_share(const SolverRow& r, std::uint32_t node, std::uint32_t na,
                                        std::uint32_t nb, Vec2 force, Vec2 test, double torque_a,
                                        double torque_b, double power, GroupGather& group) {
    const std::size_t slot_a = node + 1 - na, slot_b = node + 1 - nb;
    BodySlots& sa = start_slot(r.body_a, slot_a);
    BodySlots& sb = start_slot(r.body_b, slot_b);
    sa.force[slot_a] += force;
    sa.test[slot_a] += test;
    sa.torque[slot_a] += torque_a;
    sb.force[slot_b] -= force;
    sb.test[slot_b] -= test;
    sb.torque[slot_b] += torque_b;
    (node == group.low ? group.rhs_low : group.rhs_high) += power;
  }
  [[gnu::always_inline]] BodySlots& start_slot(std::uint32_t body, std::size_t slot) {
    std::uint8_t& used = used_slots_[body];
    BodySlots& s = slots_[body];
    if ((used >> slot & 1u) == 0) {
      s.force[slot] = s.test[slot] = Vec2{};
      s.torque[slot] = 0.0;
      used |= static_cast<std::uint8_t>(1u << slot);
    }
    return s;
  }

  SlabLayout layout_;
  const std::uint32_t* node_of_ = nullptr;  // layout_.node_of_body's data
  std::size_t bodies_ = 0, chunks_ = 0;
  std::vector<BodySlots> slots_;
  /// Per body: bit p set when a row added to slot p in this correction (pass 1 sets it and
  /// starts the slot from zero, pass 4 clears it). Only marked slots hold this correction's
  /// sums: passes 2 and 4 read only those (most bodies use one or two of the three, and the
  /// slots, 120 bytes a body, are most of those passes' memory traffic).
  std::vector<std::uint8_t> used_slots_;
  std::vector<double> group_rhs_;         // per group: its share of r for its low and high band
  std::vector<std::uint32_t> group_low_;  // per group: its lowest band (kNoNode: no share)
  std::vector<double> chunk_matrix_;      // per chunk: bands x kChunkEntries shares of A and r
  std::vector<double> band_matrix_;       // A in LAPACK's band storage (ldab = 7)
  std::vector<std::int32_t> pivots_;      // dgbsv's row swaps (lapack_int, 32 bits)
  /// 0, then s per band (the solution), then 0: band b's at b + 1, and pass 4 reads a slot's
  /// band b + p - 1 at b + p without a test for the bands that do not exist.
  std::vector<double> scale_;
  bool solved_ = false;  // decision of the one-thread step, read by every thread
};

}  // namespace cdshear
