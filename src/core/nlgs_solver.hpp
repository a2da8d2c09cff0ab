// Nonlinear Gauss-Seidel (NLGS) solver of the Contact Dynamics step (Moreau-Jean), docs/model.md
// section 3.
//
// A function of (contacts, bodies, dt, options) that returns a report. Bodies carry the free
// end-of-step velocities on entry (previous velocities plus dt times external accelerations) and
// the end-of-step velocities on exit; contacts carry warm-start impulses on entry and the
// solution on exit.
//
// Each sweep visits every contact once and solves its 2x2 problem exactly (local_solve.hpp) with
// the other impulses held fixed. Orders (model.md section 3, item 4, "random or colour-ordered"):
//   - random:     a shuffle of the contacts, seeded by (seed, step), the same in every sweep;
//   - coloured:   the contacts grouped by where they are: the packing is cut into slabs of
//                 height (bands; those no contact reaches are left out, and the others
//                 numbered in order from the bottom: a dilated cell has hundreds of empty ones);
//                 first the contacts inside each slab, all slabs at once (no two
//                 share a disk; a wall whose contacts are all in one slab goes with it), then
//                 those across every second slab boundary, then across the others, then what is
//                 left (a wall touching several slabs) on one thread. Each group is shuffled on
//                 its own, seeded by (seed, step, group): a uniformly random order inside every
//                 group, as a shuffle of all contacts would give. Groups of one phase are
//                 independent, so several threads solve them at once, and the result is the same
//                 whatever the number of threads (the convergence sums are added group by group,
//                 in order, by every thread, each of which then takes the same decision).
// Anderson acceleration (options.anderson_depth > 0, anderson.hpp): every anderson_period sweeps
// the impulses of the rows awake at the start become the Anderson mix of the last sweeps'
// results, projected on the Signorini-Coulomb set; never after the last sweep. Same fixed points.
// The mix's passes are shared among the threads (its sums are added in chunks fixed by the
// vector's length, anderson.hpp), and the mixed impulses are applied phase by phase like a
// sweep: the result is the same on any number of threads. So are the rows' set-up, the warm start
// (applied phase by phase too) and the copy-back of the impulses.
// Slab correction (options.slab_correction_period > 0, coloured order, rigid contacts, packings
// of at least kSlabCorrectionMinBands bands, slab_correction.hpp): every slab_correction_period
// sweeps, before any mix of that sweep and never after the last, the force-carrying rows of each
// band are rescaled so that the bands' force-weighted mean normal-velocity errors vanish together:
// the force profile over the height, which the sweeps relax over thousands of sweeps in a tall
// packing, in one banded solve. Same fixed points, same
// result on any number of threads. In the steps where it runs, the Anderson mix runs every
// 2 anderson_period sweeps (kMixPeriodFactorWithSlabCorrection).
// Body velocities are kept equal to free velocity + M^-1 H^T R at all times, so that a contact's
// free velocity is its current relative velocity minus W times its current impulse: a contact
// update costs O(1).
//
// Dormant contacts (options.skip_dormant): a candidate that carries no impulse after the warm start
// and whose gap is opening or closing too slowly to close within the step (u_n + gap/dt > 0) is
// left out of the sweeps: its update would give R = 0 and change nothing. Every 8 sweeps, and
// whenever the sweeps are about to stop (criterion met, or one sweep before the cap), the dormant
// contacts are looked at again and those that would now close join their group's sweeps. In dense
// packings about half of the candidates are dormant; the result is that of sweeping them all,
// unless a dormant contact closes and opens again between two looks (then it is a Gauss-Seidel
// iterate of its own, within the same tolerance).
//
// Convergence (model.md section 3, item 5): after each sweep, with dR_k the change of contact k's
// impulse during that sweep, stop when both
//   - |dR_k|^2 <= alpha |R_k|^2 for at least `converged_fraction` of the force-carrying contacts
//     (R_k != 0 before or after the sweep; idle candidates are not counted), and
//   - (sum_k |dR_k| / sum_k |R_k|)^2 <= alpha  (the mean force; true when every R_k is zero),
// and, if residual_tolerance > 0, the force-carrying rows' root mean square contact-law violation
// over the step (e dt) is at most residual_tolerance,
// or when `max_sweeps` is reached. With relaxation > 1 and `plain_finish`, a step at the cap, or
// one whose first two parts held while the residual test did not, then goes on with relaxation 1
// for up to `max_sweeps` more (reported as finished_plain), and only a step that meets the
// criterion in neither is reported as hit_cap. The last change underestimates the error left 30
// to 300 times (Gauss-Seidel contracts the error by 0.97 to 0.999 per sweep on dense packings:
// docs/step-error.md, which measures the error itself).
#pragma once

#include <array>
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "anderson.hpp"
#include "contact.hpp"
#include "slab_correction.hpp"
#include "solver_rows.hpp"
#include "threads.hpp"
#include "vec2.hpp"

namespace cdshear {

enum class ContactOrder { kRandom, kColoured };

/// "random", "coloured": the names in case and scene files.
const char* contact_order_name(ContactOrder order);
/// The order of that name; false when there is none.
bool contact_order_from_name(std::string_view name, ContactOrder& order);
inline constexpr const char* kContactOrderNames[] = {"random", "coloured"};

struct SolverOptions {
  double alpha = 1e-6;              ///< tolerance on the squared relative force change
  double converged_fraction = 0.9;  ///< share of contacts that must meet the tolerance
  int max_sweeps = 200;             ///< cap on sweeps per step
  ContactOrder order = ContactOrder::kRandom;
  std::uint64_t seed = 1;     ///< keys the shuffle of the random and coloured orders
  int threads = 1;            ///< threads for the coloured order (the others use one); >= 1
  bool skip_dormant = false;  ///< leave dormant contacts out of the sweeps (see above)
  /// Projected over-relaxation of each update, in [1, 2): R <- proj(R + omega (R_GS - R)), with
  /// R_GS the exact local solution and proj the Signorini-Coulomb projection. 1 is plain
  /// Gauss-Seidel (and takes exactly its code path); docs/performance.md, "Over-relaxation".
  double relaxation = 1.0;
  /// Contacts per thread below which fewer threads are used (a barrier then costs more than the
  /// work it shares). No effect on the results.
  std::size_t min_rows_per_thread = 1500;
  /// Anderson acceleration of the sweeps (anderson.hpp): 0 = off, else the number of past
  /// differences mixed. Every `anderson_period` sweeps, the impulses become the Anderson mix of
  /// the last images, projected on the Signorini-Coulomb set (docs/performance.md).
  int anderson_depth = 0;
  int anderson_period = 1;
  /// Slab correction (slab_correction.hpp), coloured order only, in packings of at least
  /// kSlabCorrectionMinBands bands: every this many sweeps, the impulses of each band are
  /// rescaled so that the bands' mean normal velocity errors vanish together. 0 = off. Same
  /// fixed points (docs/performance.md, "Slab correction").
  int slab_correction_period = 0;
  /// Normal compliance kappa >= 0, a fraction of each contact's w_nn (the Delassus diagonal):
  /// the step solves 0 <= R_n _|_ u_n + gap/dt + kappa w_nn R_n >= 0 instead of the rigid
  /// Signorini condition (kappa = 0), so a contact carrying R_n ends the step overlapping by
  /// kappa w_nn R_n dt, and the tangential law is Coulomb's as before. It bounds the Delassus
  /// operator's smallest eigenvalues from below by about kappa w_nn: the impulse patterns that
  /// barely move the grains (a rigid step's soft, poorly defined directions) become well
  /// defined and the sweeps converge on them (docs/performance.md, "Normal compliance"). With
  /// kappa > 0 the slab correction does not run (its target is the rigid condition); the
  /// active-set refinement solves the compliant laws (active_set_solve.hpp).
  double normal_compliance = 0.0;
  /// Active-set Newton iterations after the sweeps (active_set_solve.hpp; 0: off): each solves
  /// the step's linear system for the statuses the sweeps found, by a sparse LU factorisation,
  /// and is kept only where it lowers the natural-map residual. Applied by ContactDynamics::step.
  int newton_iterations = 0;
  /// Largest contact-law violation over the step at which the sweeps may stop [length]: when
  /// the criterion above holds, the root mean square over the force-carrying contacts of e dt
  /// (e the velocity residual of velocity_residual.hpp: interpenetration, separation of a
  /// closed contact, slip of a sticking one) must also be at most this, or the sweeps go on.
  /// 0: no such test. Steps at the cap are reported as before. The shear phase sets it from the
  /// wall speed (shear_case.hpp, default_residual_tolerance).
  double residual_tolerance = 0.0;
  /// A solve with relaxation > 1 that reaches max_sweeps without meeting the criterion, or whose
  /// change criterion holds while residual_tolerance does not, goes on from where it stands with
  /// relaxation 1 (plain Gauss-Seidel updates; the mix and the slab correction as before) for up
  /// to max_sweeps more sweeps: over-relaxed projected updates can cycle in a frictional step,
  /// which the plain ones then end (docs/performance.md, "Plain finish"). false: stop at the cap.
  /// Never with alpha 0 (exactly max_sweeps sweeps).
  bool plain_finish = true;
  /// Time the first thread's stages into SolverReport::profile (two clock reads per stage and
  /// sweep phase; no effect on the results). `cdshear_bench --profile`.
  bool profile = false;
  /// Record each refinement iteration into ActiveSetReport::history (no effect on the results).
  /// `cdshear_bench --newton-history`.
  bool newton_history = false;
};

/// Whether the options ask for the slab correction: the coloured order only (the others have no
/// bands) and rigid contacts only (its target is the rigid condition u_n + gap/dt = 0), and then,
/// in each step, only in packings of kSlabCorrectionMinBands bands or more.
inline bool asks_for_slab_correction(const SolverOptions& o) {
  return o.order == ContactOrder::kColoured && o.slab_correction_period > 0 &&
         o.normal_compliance == 0.0;
}

/// SolverOptions::normal_compliance is below this: at kappa = 1 a contact is as compliant as
/// its two bodies are mobile, far from a rigid contact.
inline constexpr double kNormalComplianceBound = 1.0;

/// Largest SolverOptions::newton_iterations.
inline constexpr int kMaxNewtonIterations = 50;

/// Largest SolverOptions::anderson_depth.
inline constexpr int kMaxAndersonDepth = AndersonMixer::kMaxDepth;

/// In the steps where the slab correction runs, the Anderson mix runs every this many times
/// anderson_period sweeps: with the correction, a tall cell's steps need fewer sweeps when the
/// mix runs less often (6 to 10% fewer on system 5 with the mix every 8 sweeps instead of 4, the
/// same averages over five seeds: docs/accuracy.md, "Defaults and what they guarantee").
inline constexpr int kMixPeriodFactorWithSlabCorrection = 2;

/// Where the first thread of a solve spent its time [s], filled when SolverOptions::profile is
/// set. The stages add up to that thread's time in solve_contacts but the set-up before the team
/// starts (sizing scratch); on more than one thread, `phase_waits` is its wait for the others at
/// the end of each sweep phase, and the other stages hold their own barriers' waits.
struct SolverProfile {
  double set_up = 0.0;       ///< ordering, rows, warm start, dormant rows, the mixed rows listed
  double sweeps = 0.0;       ///< the thread's share of the sweeps' phases and the serial group
  double phase_waits = 0.0;  ///< at the barrier ending each phase
  double convergence = 0.0;  ///< the convergence test and the looks at the dormant rows
  double correction = 0.0;   ///< slab corrections
  double mix = 0.0;          ///< Anderson mixes: gather, mix, apply
  double write_back = 0.0;   ///< impulses and velocities back to the contacts and bodies

  double total() const {
    return set_up + sweeps + phase_waits + convergence + correction + mix + write_back;
  }
  SolverProfile& operator+=(const SolverProfile& o) {
    set_up += o.set_up;
    sweeps += o.sweeps;
    phase_waits += o.phase_waits;
    convergence += o.convergence;
    correction += o.correction;
    mix += o.mix;
    write_back += o.write_back;
    return *this;
  }
};

struct SolverReport {
  int sweeps = 0;        ///< over-relaxed and plain-finish sweeps together
  bool hit_cap = false;  ///< the criterion not met after the last sweep allowed
  /// stopped over-relaxed (at max_sweeps, or held back by residual_tolerance) and went on with
  /// relaxation 1
  bool finished_plain = false;
  /// (sum |dR| / sum |R|)^2 of the last sweep; 1 when every force vanished in it (sum |R| = 0
  /// after a change: the whole force changed)
  double residual = 0.0;
  double converged_fraction = 1.0;  ///< share of force-carrying contacts meeting it, last sweep
  int active_contacts = 0;          ///< contacts with R_n > 0 at the end
  std::size_t colours = 0;          ///< parallel phases of a coloured sweep (0 for the others)
  /// Open and separating at the start: left out of sweeps; and the dormant ones that started to
  /// close and were woken. A plain finish adds its own start's to the first solve's.
  std::size_t dormant_contacts = 0;
  std::size_t woken_contacts = 0;
  int slab_corrections = 0;   ///< slab corrections applied (solved and scaled)
  int anderson_mixes = 0;     ///< Anderson mix passes, restarts included
  int residual_refusals = 0;  ///< sweeps whose criterion held but not residual_tolerance
  /// Sweeps done when the residual test first refused to stop (0: never refused); the sweeps
  /// after it are what the test cost the step.
  int first_refusal_sweep = 0;
  int threads = 1;        ///< threads used
  SolverProfile profile;  ///< options.profile only
};

/// What one group of rows adds to the convergence test. The sums are filled only in the sweeps
/// whose decision needs them (solve_contacts: they cost a square root per update).
struct SweepTally {
  std::size_t converged = 0, carrying = 0;
  double sum_change = 0.0, sum_force = 0.0;  ///< sums of |dR| and |R|
  double violation2 = 0.0;        ///< sum of e^2 over the force-carrying rows (residual test)
  std::size_t carrying_rows = 0;  ///< their count
};

/// A dormant row as the looks at it read it (solve_contacts wakes those that would close): its
/// row, and the fields of the row that its biased normal velocity needs, copied out when it goes
/// dormant, so that a look streams through 40 bytes per dormant row instead of the lines of the
/// rows, where the dormant ones sit among the awake.
struct DormantRow {
  std::uint32_t row = 0;
  std::uint32_t body_a = 0, body_b = 0;
  Vec2 normal;
  double bias_n = 0.0;
};

/// Reusable scratch memory, so that a step allocates nothing once warmed up.
struct SolverWorkspace {
  std::vector<std::uint32_t> order;  ///< row i solves contacts[order[i]]
  std::vector<SolverRow> rows;
  std::vector<DelassusEntries> delassus;  ///< of rows[i], read by coupled rows only
  /// The factor of a decoupled row's old R_n in its update, 1 - omega kappa / (1 + kappa)
  /// (update_row; 1 for a rigid step), set by each solve.
  double keep_n = 1.0;
  std::vector<std::size_t> group_start;  ///< rows of group g: [group_start[g], group_start[g+1])
  std::vector<SolverPhase> phases;       ///< parallel phases; the last group is solved after
  /// One per group and sweep, added in group order; consecutive sweeps use the two halves in
  /// turn (solve_contacts).
  std::vector<SweepTally> group_tallies;
  /// (|dR|^2, |R|^2) of each row's update in the last sweep, by row (0, 0 for a row that stayed
  /// open): their square roots are summed only when the convergence test needs the sums.
  std::vector<std::array<double, 2>> row_lengths2;
  AndersonMixer anderson;                         ///< options.anderson_depth > 0
  std::vector<std::uint32_t> anderson_rows;       ///< the rows it mixes: those awake at the start
  std::vector<std::size_t> anderson_group_start;  ///< group g's: [start[g], start[g + 1])
  std::vector<double> anderson_x, anderson_g;     ///< their (R_n, R_t) before and after a period
  std::vector<std::vector<std::uint32_t>> awake;  ///< rows each group's sweeps visit
  std::vector<std::vector<DormantRow>> dormant_of_group;  ///< rows left out of the sweeps
  std::vector<std::size_t> woken_of_group;                ///< rows each group woke at the last look
  /// The phased groups with awake rows, phase by phase and in group order within each, and
  /// where each phase starts in that list: what a sweep visits (ContactSolve::list_busy_groups).
  std::vector<std::uint32_t> busy_groups;
  std::vector<std::size_t> busy_phase_start;
  std::vector<std::uint32_t> group_of;   ///< group of each contact (coloured order)
  std::vector<std::uint32_t> wall_band;  ///< band of every contact of each wall, if only one
  /// Coloured order: the bodies the rows touch, renumbered in the order the rows first use them
  /// (each slab's bodies side by side in memory), and the map back to `bodies`.
  std::vector<SolverBody> local_bodies;
  std::vector<std::uint32_t> local_of;   ///< body -> its local index (touched bodies only)
  std::vector<std::uint32_t> global_of;  ///< local index -> body
  /// Per thread of the team, for the shared passes of the coloured order's set-up: the largest
  /// band of its disks, its contacts' walls' bands (walls per thread), its contacts' count per
  /// group then their first places (groups per thread), the bodies first used in its rows and
  /// where their local numbers start.
  std::vector<std::uint32_t> team_max_band;
  std::vector<std::uint32_t> team_wall_band;
  /// Per thread and band: whether its contacts reach the band (a disk of theirs is in it); then
  /// each band's number among the bands reached (band_rank), from the bottom.
  std::vector<std::uint8_t> team_band_reached;
  std::vector<std::uint32_t> band_rank;
  std::vector<std::size_t> team_count;
  std::vector<std::vector<std::uint32_t>> team_new_bodies;
  std::vector<std::size_t> team_body_offset;
  /// Per thread and body, the last call's stamp in which the thread's rows used the body.
  std::vector<std::uint32_t> team_seen;
  std::uint32_t seen_stamp = 0;
  /// Per thread of the team: a group's rows, Delassus entries and contacts while they are put in
  /// their awake-first order (ContactSolve::put_awake_rows_first).
  struct MovedRows {
    std::vector<SolverRow> rows;
    std::vector<DelassusEntries> delassus;
    std::vector<std::uint32_t> order;
  };
  std::vector<MovedRows> team_moved_rows;
  /// Slab correction (options.slab_correction_period > 0): its scratch, and the band of each
  /// local body (a wall: its disks' band, or SlabCorrection::kNoNode if they are in several).
  SlabCorrection slab_correction;
  std::vector<std::uint32_t> node_of_body;
};

/// Solves the contact problem of one step. Bodies from `first_wall` on are walls (shared by many
/// contacts). `step` keys the random order (with options.seed).
SolverReport solve_contacts(std::vector<Contact>& contacts, std::vector<SolverBody>& bodies,
                            std::size_t first_wall, double dt, const SolverOptions& options,
                            std::uint64_t step, SolverWorkspace& workspace);

}  // namespace cdshear
