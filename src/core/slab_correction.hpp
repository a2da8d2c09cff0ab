// Slab correction: a coarse correction of the Gauss-Seidel iterate across the height of a tall
// packing (docs/performance.md, "Slab correction"; docs/accuracy.md, seventh pass).
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
// Threads. apply() is called by every thread of the solver's team at once (or by one thread
// outside any parallel region), like AndersonMixer::mix: passes over rows go group by group,
// phase by phase (groups of a phase share no body), passes over bodies in chunks of kChunk
// bodies whatever the thread count, each chunk's sums added in chunk order: the same result on
// any number of threads.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "vec2.hpp"

namespace cdshear {

struct SolverBody;
struct SolverRow;
struct SolverPhase;

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

  /// Sizes the scratch for `bodies` bodies and the layout's groups and bands. One thread, once
  /// per step, before any apply() of that step.
  void reset(std::size_t bodies, const SlabLayout& layout);

  /// Scales the rows' impulses as above and moves their bodies accordingly. Called by every
  /// thread of a team (or one thread alone, see above). Returns false, changing nothing, when
  /// the system is singular or has no solution in floating point.
  bool apply(std::vector<SolverRow>& rows, std::vector<SolverBody>& bodies);

  /// The scales of the last apply(), one per band (for tests).
  const std::vector<double>& scales() const { return scale_; }

 private:
  /// Step 3 of apply(), on one thread: r from the groups' shares, A from the chunks' shares
  /// (clearing them), then s. False when dgbsv finds A singular or s is not finite.
  bool solve();

  /// What the rows of one body add to the correction, for the bands next to its own (slot 0:
  /// band - 1, slot 1: its band, slot 2: band + 1): the impulse and torque its rows apply to it,
  /// weighted by that band's share in their scale, and the impulse's normal components only
  /// (test).
  struct BodySlots {
    std::array<Vec2, 3> force{}, test{};
    std::array<double, 3> torque{};
  };
  /// Diagonals of the banded matrix A kept per row j: A(j, j + d - 2), d = 0..4.
  static constexpr int kDiagonals = 5;

  SlabLayout layout_;
  std::size_t bodies_ = 0, chunks_ = 0;
  std::vector<BodySlots> slots_;
  /// Per body: bit p set when a row added to slot p in this correction (pass 1 sets it and
  /// starts the slot from zero, pass 4 clears it). Only marked slots hold this correction's
  /// sums: passes 2 and 4 read only those (most bodies use one or two of the three, and the
  /// slots, 120 bytes a body, are most of those passes' memory traffic).
  std::vector<std::uint8_t> used_slots_;
  std::vector<double> group_rhs_;         // per group: its share of r for its low and high band
  std::vector<std::uint32_t> group_low_;  // per group: its lowest band (kNoNode: no share)
  std::vector<double> chunk_matrix_;      // per chunk: bands x kDiagonals shares of A
  std::vector<double> band_matrix_;       // A in LAPACK's band storage (ldab = 7)
  std::vector<std::int32_t> pivots_;      // dgbsv's row swaps (lapack_int, 32 bits)
  std::vector<double> scale_;             // s per band (the solution)
  bool solved_ = false;                   // decision of the one-thread step, read by every thread
};

}  // namespace cdshear
