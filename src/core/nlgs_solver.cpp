#include "nlgs_solver.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "local_solve.hpp"
#include "random_shuffle.hpp"
#include "threads.hpp"
#include "velocity_residual.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace cdshear {

namespace {

/// One row and its Delassus entries (delassus_entries, solver_rows.hpp) from a contact.
///
/// `step_scale` is the over-relaxation factor omega (1: plain Gauss-Seidel): the decoupled rows
/// store omega / w_nn and omega / w_tt, the factors of their one-stage over-relaxed update
/// (update_row), computed here once per step instead of in every update. omega x (1 / w) is
/// the product the update formed before, so the update is the same bit for bit; with omega = 1
/// the product is 1 / w itself.
///
/// `compliance` is SolverOptions::normal_compliance, kappa: the normal inverse is that of w_nn
/// (1 + kappa), the diagonal of the compliant problem (update_row); w_nn (1 + 0) is w_nn.
void fill_row(SolverRow& row, DelassusEntries& w, const Contact& c, const SolverBody& a,
              const SolverBody& b, double inv_dt, double step_scale, double compliance) {
  row.body_a = static_cast<std::uint32_t>(c.key.body_a);
  row.body_b = static_cast<std::uint32_t>(c.key.body_b);
  row.normal = c.normal;
  row.lever_a = c.lever_a;
  row.lever_b = c.lever_b;
  row.bias_n = c.gap * inv_dt;
  row.friction = c.friction;
  row.impulse_n = c.impulse_n;
  row.impulse_t = c.impulse_t;
  w = delassus_entries(c, a, b);
  w.compliance_n = compliance * w.w_nn;
  row.inv_w_nn = step_scale * (1.0 / (w.w_nn * (1.0 + compliance)));
  row.inv_w_tt = w.w_nt == 0.0 ? step_scale * (1.0 / w.w_tt) : kCoupledRow;
}

/// Adds up a group's convergence figures (docs/model.md section 3, item 5): the counts during a
/// sweep, and the sums of |dR| and |R| afterwards from the stored squares (sum_group_lengths), in
/// the order of the updates. The two square roots of a row are taken together in one packed
/// instruction where the machine has one (SSE2, every x86-64). Square roots are correctly rounded
/// either way: same sums.
class TallyAccumulator {
 public:
  void count(bool carries, bool converged) {
    carrying_ += static_cast<std::size_t>(carries);
    converged_ += static_cast<std::size_t>(carries && converged);
  }
#if defined(__SSE2__)
  void add_lengths(double change2, double force2) {
    sums_ = _mm_add_pd(sums_, _mm_sqrt_pd(_mm_set_pd(force2, change2)));
  }
  SweepTally tally() const {
    return {converged_, carrying_, _mm_cvtsd_f64(sums_),
            _mm_cvtsd_f64(_mm_unpackhi_pd(sums_, sums_))};
  }

 private:
  __m128d sums_ = _mm_setzero_pd();  // (sum |dR|, sum |R|)
#else
  void add_lengths(double change2, double force2) {
    change_ += std::sqrt(change2);
    force_ += std::sqrt(force2);
  }
  SweepTally tally() const {
    return {converged_, carrying_, change_, force_};
  }

 private:
  double change_ = 0.0, force_ = 0.0;
#endif
  std::size_t converged_ = 0, carrying_ = 0;
};

/// One Gauss-Seidel update of row r: solve its local problem with every other impulse fixed,
/// apply the change to the two bodies, count it in the tally and store the squares of |dR| and
/// |R| in `lengths2` ((0, 0) for a row that stays open: adding sqrt(0) to a sum changes nothing,
/// so a sum over every visited row is the sum over the updated ones).
///
/// Common case, w_nt = 0 (every disk-disk contact, and a wall contact whenever the wall's
/// inverse mass is isotropic or aligned with the contact, as for the flat walls of the shear
/// cell): the 2x2 problem decouples (local_solve.hpp, cases 1-3 with w_nt = 0) into
///   R_n = max(0, R_n - (u_n + gap/dt) / w_nn),  R_t = clamp(R_t - u_t / w_tt, -mu R_n, mu R_n),
/// where u is the current relative velocity (this row's old impulse included): the sticking
/// impulse -W^-1 b written as a correction of the old one, so no b is formed and no branch taken
/// (decoupled_update).
/// Coupled rows (w_nt != 0, a wall free along a direction oblique to the contact; marked by
/// inv_w_tt = kCoupledRow, so the test reads a value the update loads anyway) go through the
/// general case analysis of solve_local.
///
/// Normal compliance (SolverOptions::normal_compliance, kappa; c = kappa w_nn): the condition is
/// u_n + gap/dt + c R_n >= 0, so the local problem's normal diagonal is w_nn + c and its normal
/// velocity u_n + gap/dt + c R_n (R_n the old impulse). The decoupled update is then
///   R_n - omega (u_n + gap/dt + c R_n) / (w_nn + c)
///     = (1 - omega kappa / (1 + kappa)) R_n - omega (u_n + gap/dt) / ((1 + kappa) w_nn),
/// the rigid update of the old impulse scaled by `keep_n` (SolverWorkspace::keep_n) with the
/// inverse fill_row stores; at kappa = 0, keep_n = 1 and the update is the rigid one bit for bit.
///
/// Relaxation (a template parameter, one sweep loop each): the update moves omega times as far
/// as the exact local solution and is projected back on the cone (projected SOR).
///   kNone (omega = 1): plain Gauss-Seidel, its own arithmetic (R + 1 (R_GS - R) is not always
///     R_GS in floating point).
///   kOver (omega > 1): decoupled rows in one stage, the steps scaled by omega
///     (local_solve.hpp, decoupled_update: the same impulse as relaxing the exact update and
///     projecting, in exact arithmetic, with a chain of dependent operations from a row's
///     two velocities to their new values a third shorter: 9 to 13% less time per sweep). Coupled
///     rows: the exact solution, then relaxed and projected.
/// omega is in [1, 2) (SolverOptions::relaxation): under-relaxation never paid
/// (docs/performance.md). Forced inline: with several sweep loops (relaxation, gathering or not)
/// g++ 12 called it out of line, and a step of system 7 took 8% longer.
enum class Relaxation { kNone, kOver };

template <Relaxation kRelax>
[[gnu::always_inline]] inline void update_row(SolverRow& r, const DelassusEntries& w,
                                              SolverBody* bodies, double alpha, double omega,
                                              double keep_n, TallyAccumulator& tally,
                                              std::array<double, 2>& lengths2) {
  SolverBody& a = bodies[r.body_a];
  SolverBody& b = bodies[r.body_b];
  const double dvx = a.velocity.x - b.velocity.x;
  const double dvy = a.velocity.y - b.velocity.y;
  const double u_n = dvx * r.normal.x + dvy * r.normal.y;
  const double u_t =
      dvy * r.normal.x - dvx * r.normal.y + r.lever_a * a.omega + r.lever_b * b.omega;
  // An open contact that stays open: R = 0 and the biased normal velocity is separating. The
  // update below would give R = 0 again, change nothing and count nothing; skip it. Half of the
  // candidates or more are in this case in a dense packing (gap below the margin, not touching).
  if (r.impulse_n == 0.0 && r.impulse_t == 0.0 && u_n + r.bias_n >= 0.0) {
    lengths2 = {0.0, 0.0};
    return;
  }
  const LocalImpulse old{r.impulse_n, r.impulse_t};
  LocalImpulse next;
  if (r.inv_w_tt != kCoupledRow) [[likely]] {
    // kOver: the row's inverses are scaled by omega already (fill_row), so decoupled_update's
    // own factor is 1 (1 x (omega / w) is omega / w exactly) and this is the one-stage
    // over-relaxed update. kNone: plain Gauss-Seidel.
    // The old R_n scaled only in a compliant step: a select, not a product by 1, so that the
    // compiler cannot fuse the product into the update's multiply-add and a rigid step keeps
    // its rounding bit for bit.
    LocalImpulse start = old;
    if (keep_n != 1.0) start.n = keep_n * old.n;
    next = decoupled_update(start, u_n + r.bias_n, u_t, r.inv_w_nn, r.inv_w_tt, r.friction);
  } else {
    // b with the rigid entries (u less the row's own share W R); the compliance adds c to the
    // normal diagonal only.
    LocalProblem p;
    p.w_nn = w.w_nn + w.compliance_n;
    p.w_nt = w.w_nt;
    p.w_tt = w.w_tt;
    p.b_n = u_n - (w.w_nn * r.impulse_n + w.w_nt * r.impulse_t) + r.bias_n;
    p.b_t = u_t - (w.w_nt * r.impulse_n + w.w_tt * r.impulse_t);
    p.mu = r.friction;
    const LocalSolution s = solve_local(p);
    next = {s.r_n, s.r_t};
    if constexpr (kRelax != Relaxation::kNone)
      next = relax_and_project(old, next, omega, r.friction);
  }
  const double r_n = next.n, r_t = next.t;
  const double dn = r_n - r.impulse_n, dt = r_t - r.impulse_t;
  apply_row_impulse(r, a, b, dn, dt);
  r.impulse_n = r_n;
  r.impulse_t = r_t;

  // Only contacts that carry force (before or after this update) take part in the count: idle
  // candidates (R = 0 staying 0) would otherwise pass for free, and the criterion would depend on
  // the contact margin.
  const double change2 = dn * dn + dt * dt;
  const double force2 = r_n * r_n + r_t * r_t;
  tally.count(r_n > 0.0 || dn != 0.0, change2 <= alpha * force2);
  lengths2 = {change2, force2};
}

/// The first thread's stopwatch for SolverProfile: each lap adds the time since the last one to
/// a stage. Off (no clock read) unless the options ask for a profile and this is that thread.
class StageClock {
 public:
  explicit StageClock(bool on) : on_(on) {
    if (on_) last_ = std::chrono::steady_clock::now();
  }
  void lap(double& stage_seconds) {
    if (!on_) return;
    const auto now = std::chrono::steady_clock::now();
    stage_seconds += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }

 private:
  bool on_;
  std::chrono::steady_clock::time_point last_;
};

/// Markers of SolverWorkspace::wall_band: no contact yet, contacts in several bands.
constexpr std::uint32_t kNoBand = 0xffffffffu;
constexpr std::uint32_t kManyBands = 0xfffffffeu;

/// Random order: the rows' visit order, in one serial group (no phases).
void order_rows_serially(std::size_t nc, const SolverOptions& options, std::uint64_t step,
                         SolverWorkspace& ws) {
  auto& order = ws.order;
  order.resize(nc);
  std::iota(order.begin(), order.end(), 0u);
  shuffle_rows(order.data(), nc, options.seed, RandomStream::kContactOrder, step, 0);
  ws.phases.clear();
  ws.group_start.assign({0, nc});
}

/// The coloured order's groups and phases (nlgs_solver.hpp). Every disk has a band
/// (SolverBody::band: slabs of height, fixed by the geometry, not by the thread count). A
/// contact goes to
///   - the slab of its band when both disks are in the same band: slabs share no disk, so all
///     slabs are solved at once (phase 1);
///   - the boundary between bands s and s + 1 when its disks are in neighbouring bands: the
///     boundaries s and s + 2 share no disk, so the even boundaries are solved at once (phase 2),
///     then the odd ones (phase 3);
///   - a wall contact goes to the slab of its disk when all the contacts of that wall are in
///     that one band (a wall is shared by all its contacts);
///   - the serial group otherwise (a wall touching several bands, or a contact spanning more
///     than two bands), solved last by one thread.
/// Each group's contacts are then shuffled on their own (shuffle_group), so that every row sees
/// the same velocities whatever the thread count, and the convergence sums are added group by
/// group in group order: the result does not depend on the thread count.
///
/// Every pass is shared by the team (solve_contacts, arrange_coloured_rows), each thread taking
/// its share (share_of) of the bodies or contacts, with the threads' findings merged in thread
/// order on one thread: the bands and the walls' bands (coloured_groups_share, then
/// coloured_groups_merge), each contact's group counted per thread (coloured_group_of), and a
/// stable counting sort by group whose offsets give each thread's contacts their places after
/// those of the threads before it (coloured_groups_end), as one thread would place them.
struct ColouredGroups {
  std::size_t bands = 1, even = 0, boundaries = 0, serial = 0;
};

/// A wall's band as its contacts are seen: kNoBand, then its contacts' one band, or kManyBands.
std::uint32_t merge_wall_band(std::uint32_t seen, std::uint32_t band) {
  return seen == kNoBand || seen == band ? band : band == kNoBand ? seen : kManyBands;
}

/// Thread p's share of the bands: its disks' largest band into ws.team_max_band[p.thread].
void coloured_bands_share(const std::vector<SolverBody>& bodies, std::size_t first_wall,
                          TeamPlace p, SolverWorkspace& ws) {
  const Share my_disks = share_of(std::min(first_wall, bodies.size()), p);
  std::uint32_t max_band = 0;
  for (std::size_t i = my_disks.first; i < my_disks.last; ++i)
    max_band = std::max(max_band, bodies[i].band);
  ws.team_max_band[p.thread] = max_band;
}

/// On one thread, after every coloured_bands_share: the bands of the disks (the largest, plus
/// one), and every thread's row of ws.team_band_reached cleared for them.
std::size_t coloured_bands_merge(std::size_t team, SolverWorkspace& ws) {
  std::size_t bands = 1;
  for (std::size_t t = 0; t < team; ++t)
    bands = std::max<std::size_t>(bands, ws.team_max_band[t] + std::size_t{1});
  ws.team_band_reached.assign(team * bands, 0);
  return bands;
}

/// Thread p's share of the contacts' bands: the bands its contacts' disks are in, marked in its
/// row of ws.team_band_reached (disk_bands per thread), and its contacts' walls' bands into its
/// row of ws.team_wall_band.
void coloured_groups_share(const std::vector<Contact>& contacts,
                           const std::vector<SolverBody>& bodies, std::size_t first_wall,
                           std::size_t disk_bands, TeamPlace p, SolverWorkspace& ws) {
  const std::size_t walls = bodies.size() - std::min(first_wall, bodies.size());
  std::uint32_t* wall_band = ws.team_wall_band.data() + p.thread * walls;
  std::fill_n(wall_band, walls, kNoBand);
  std::uint8_t* reached = ws.team_band_reached.data() + p.thread * disk_bands;
  const Share my_contacts = share_of(contacts.size(), p);
  for (std::size_t i = my_contacts.first; i < my_contacts.last; ++i) {
    const Contact& c = contacts[i];
    const auto b = static_cast<std::size_t>(c.key.body_b);
    const std::uint32_t band_a = bodies[static_cast<std::size_t>(c.key.body_a)].band;
    reached[band_a] = 1;
    if (b < first_wall) {
      reached[bodies[b].band] = 1;
    } else {
      std::uint32_t& wb = wall_band[b - first_wall];
      wb = merge_wall_band(wb, band_a);
    }
  }
}

/// On one thread, after every coloured_groups_share: the bands the contacts reach, numbered
/// from the bottom (ws.band_rank: a disk's band is counted by its rank among them), the groups,
/// and each wall's band (its rank). Bands no contact reaches are left out: a dense packing
/// reaches every band, so its ranks are its bands and nothing changes; a dilated cell (the
/// study's fastest walls push them to tens of times the nominal height apart) has hundreds of
/// empty bands, which would each make two empty groups that every pass of the set-up goes
/// through. Consecutive ranks need not be neighbouring bands: groups of one phase still share no
/// disk (slab k holds ranks k, boundary k ranks k and k + 1), and a row still joins bodies of
/// one rank or of two consecutive ones (the slab correction's banded matrix).
/// A wall whose contacts all have their disk in one band belongs to that band's slab (the
/// bottom wall to the lowest slab, the top wall to the highest, in a shear cell): no other group
/// touches it. A wall touching disks of several bands goes to the serial group.
ColouredGroups coloured_groups_merge(std::size_t walls, std::size_t disk_bands, std::size_t team,
                                     SolverWorkspace& ws) {
  ws.band_rank.resize(disk_bands);
  std::uint32_t reached = 0;
  for (std::size_t band = 0; band < disk_bands; ++band) {
    bool any = false;
    for (std::size_t t = 0; t < team; ++t) any = any || ws.team_band_reached[t * disk_bands + band];
    ws.band_rank[band] = reached;
    reached += static_cast<std::uint32_t>(any);
  }
  ColouredGroups cg;
  cg.bands = std::max<std::size_t>(reached, 1);
  // Group ids: slabs [0, bands), even boundaries, odd boundaries, then the serial group.
  cg.boundaries = cg.bands - 1;
  cg.even = (cg.boundaries + 1) / 2;
  cg.serial = cg.bands + cg.boundaries;
  ws.wall_band.assign(walls, kNoBand);
  for (std::size_t t = 0; t < team; ++t)
    for (std::size_t w = 0; w < walls; ++w)
      ws.wall_band[w] = merge_wall_band(ws.wall_band[w], ws.team_wall_band[t * walls + w]);
  for (std::uint32_t& band : ws.wall_band)
    if (band < disk_bands) band = ws.band_rank[band];
  return cg;
}

std::uint32_t coloured_group_of(const Contact& c, const std::vector<SolverBody>& bodies,
                                std::size_t first_wall, const ColouredGroups& cg,
                                const SolverWorkspace& ws) {
  const auto b = static_cast<std::size_t>(c.key.body_b);
  std::size_t g;
  if (b >= first_wall) {
    const std::uint32_t band = ws.wall_band[b - first_wall];
    g = band < cg.bands ? band : cg.serial;
  } else {
    // Every candidate group formed, then chosen by selects (conditional moves, no branch):
    // about a quarter of system 1's contacts cross a band boundary, in no order a predictor
    // can learn.
    const std::size_t band_a = ws.band_rank[bodies[static_cast<std::size_t>(c.key.body_a)].band];
    const std::size_t band_b = ws.band_rank[bodies[b].band];
    const std::size_t low = std::min(band_a, band_b);
    const std::size_t boundary = cg.bands + low / 2 + (low % 2) * cg.even;
    const std::size_t across = std::max(band_a, band_b) == low + 1 ? boundary : cg.serial;
    g = band_a == band_b ? band_a : across;
  }
  return static_cast<std::uint32_t>(g);
}

/// On one thread, once every thread has counted its contacts of each group (ws.team_count, team
/// rows of serial + 1 groups): the groups' starts, each thread's count turned into the place of
/// its first contact of that group (after the group's contacts of the threads before it: a
/// stable sort, as one thread counting all contacts would give), and the phases.
void coloured_groups_end(const ColouredGroups& cg, std::size_t team, SolverWorkspace& ws) {
  const std::size_t groups = cg.serial + 1;
  auto& start = ws.group_start;
  start.assign(groups + 1, 0);
  for (std::size_t g = 0; g < groups; ++g) {
    std::size_t next = start[g];
    for (std::size_t t = 0; t < team; ++t) {
      const std::size_t count = ws.team_count[t * groups + g];
      ws.team_count[t * groups + g] = next;
      next += count;
    }
    start[g + 1] = next;
  }
  ws.order.resize(start[groups]);
  ws.phases.clear();
  ws.phases.push_back({0, cg.bands});
  if (cg.even > 0) ws.phases.push_back({cg.bands, cg.bands + cg.even});
  if (cg.boundaries > cg.even) ws.phases.push_back({cg.bands + cg.even, cg.serial});
}

/// Shuffles group g's contacts, with a generator of its own keyed on (seed, step, g + 1): the
/// same draw whichever thread does it (counter 0 is the random order's shuffle of all contacts).
void shuffle_group(std::size_t g, const SolverOptions& options, std::uint64_t step,
                   SolverWorkspace& ws) {
  shuffle_rows(ws.order.data() + ws.group_start[g], ws.group_start[g + 1] - ws.group_start[g],
               options.seed, RandomStream::kContactOrder, step, g + 1);
}

/// Updates the awake rows of group g. kGather: the sweep before a slab correction, which gathers
/// each row once updated (its impulse is then final for the correction: SlabCorrection::
/// gather_row), so that the correction makes no pass of its own over the rows to gather them.
template <Relaxation kRelax, bool kGather>
void sweep_rows(std::size_t g, SolverWorkspace& ws, std::vector<SolverBody>& bodies, double alpha,
                double omega, TallyAccumulator& tally) {
  SlabCorrection::GroupGather gathered;
  // The arrays' addresses in locals: read through the vectors, g++ 12 loaded them again for
  // every row (0.99 of the time per update on system 7 this way: docs/performance.md).
  SolverRow* const rows = ws.rows.data();
  const DelassusEntries* const delassus = ws.delassus.data();
  SolverBody* const body = bodies.data();
  std::array<double, 2>* const lengths2 = ws.row_lengths2.data();
  const double keep_n = ws.keep_n;
  for (const std::uint32_t i : ws.awake[g]) {
    update_row<kRelax>(rows[i], delassus[i], body, alpha, omega, keep_n, tally, lengths2[i]);
    if constexpr (kGather) ws.slab_correction.gather_row(rows[i], gathered);
  }
  if constexpr (kGather) ws.slab_correction.finish_group(g, gathered);
}

/// Updates the awake rows of group g and stores its counts in tallies[g] (the sums stay 0 until
/// sum_group_lengths); `gather`: for the slab correction that follows the sweep (a slab or
/// boundary group only, never the serial one).
void sweep_group(std::size_t g, SolverWorkspace& ws, std::vector<SolverBody>& bodies, double alpha,
                 double omega, SweepTally* tallies, bool gather = false) {
  TallyAccumulator tally;
  const auto sweep = [&]<Relaxation kRelax>() {
    if (gather)
      sweep_rows<kRelax, true>(g, ws, bodies, alpha, omega, tally);
    else
      sweep_rows<kRelax, false>(g, ws, bodies, alpha, omega, tally);
  };
  if (omega == 1.0)
    sweep.template operator()<Relaxation::kNone>();
  else
    sweep.template operator()<Relaxation::kOver>();
  tallies[g] = tally.tally();
}

/// The sums of |dR| and |R| of group g's last sweep, into tallies[g]: the square roots of the
/// stored squares, added in the order the sweep updated the rows, so the same sums as adding
/// them during the sweep. Taken only in the sweeps whose decision needs them: a square root per
/// update was about 6% of a sweep (cdshear_bench, 500 disks), and most sweeps of a step are
/// decided by the count of converged contacts alone.
void sum_group_lengths(std::size_t g, const SolverWorkspace& ws, SweepTally* tallies) {
  TallyAccumulator sums;
  for (const std::uint32_t i : ws.awake[g])
    sums.add_lengths(ws.row_lengths2[i][0], ws.row_lengths2[i][1]);
  const SweepTally t = sums.tally();
  tallies[g].sum_change = t.sum_change;
  tallies[g].sum_force = t.sum_force;
}

/// u_n + gap/dt of a row (a SolverRow or a DormantRow) in the current velocities: >= 0 means it
/// stays open at R = 0.
template <class Row>
inline double biased_normal_velocity(const Row& r, const std::vector<SolverBody>& bodies) {
  const SolverBody& a = bodies[r.body_a];
  const SolverBody& b = bodies[r.body_b];
  return (a.velocity.x - b.velocity.x) * r.normal.x + (a.velocity.y - b.velocity.y) * r.normal.y +
         r.bias_n;
}

/// u_n + gap/dt and u_t of a row in the current velocities (contact_velocity's, read from a row;
/// update_row computes the same inline).
inline ContactVelocity row_velocity(const SolverRow& r, const std::vector<SolverBody>& bodies) {
  const SolverBody& a = bodies[r.body_a];
  const SolverBody& b = bodies[r.body_b];
  const double dvx = a.velocity.x - b.velocity.x, dvy = a.velocity.y - b.velocity.y;
  return {dvx * r.normal.x + dvy * r.normal.y + r.bias_n,
          dvy * r.normal.x - dvx * r.normal.y + r.lever_a * a.omega + r.lever_b * b.omega};
}

/// Sweeps between two looks at the dormant rows (nlgs_solver.hpp).
constexpr int kDormantCheckInterval = 8;

/// Wakes every dormant row of group g that would now close (its update would give R > 0): it
/// joins the end of the group's awake rows, and the last dormant row takes its place in the
/// list. Returns how many woke.
std::size_t wake_closing_rows(std::size_t g, SolverWorkspace& ws,
                              const std::vector<SolverBody>& bodies) {
  auto& dormant = ws.dormant_of_group[g];
  std::size_t woken = 0;
  for (std::size_t k = 0; k < dormant.size();) {
    if (biased_normal_velocity(dormant[k], bodies) < 0.0) {
      ws.awake[g].push_back(dormant[k].row);
      dormant[k] = dormant.back();
      dormant.pop_back();
      ++woken;
    } else {
      ++k;
    }
  }
  return woken;
}

}  // namespace

const char* contact_order_name(ContactOrder order) {
  return kContactOrderNames[static_cast<int>(order)];
}

bool contact_order_from_name(std::string_view name, ContactOrder& order) {
  for (int k = 0; k < static_cast<int>(std::size(kContactOrderNames)); ++k) {
    if (name == kContactOrderNames[k]) {
      order = static_cast<ContactOrder>(k);
      return true;
    }
  }
  return false;
}

namespace {

/// Whether a solve that stops short of the criterion goes on with relaxation 1
/// (SolverOptions::plain_finish): only an over-relaxed one, and never with alpha 0, which asks for
/// exactly max_sweeps sweeps (a criterion never met).
bool finishes_plain(const SolverOptions& o) {
  return o.plain_finish && o.relaxation > 1.0 && o.alpha > 0.0;
}

/// One call of solve_contacts as an object: what its phases share (every member is shared by the
/// team's threads), and the phases as member functions in the order a step runs them. Each phase
/// is called by every thread of the team unless it says otherwise; the work-sharing constructs
/// inside (omp for, omp single, and those of AndersonMixer::mix and the slab correction) bind to
/// whatever team calls it, each `nowait` and followed by team_barrier() where one is needed.
class ContactSolve {
 public:
  ContactSolve(std::vector<Contact>& contacts, std::vector<SolverBody>& all_bodies,
               std::size_t first_wall, double dt, const SolverOptions& options, std::uint64_t step,
               SolverWorkspace& ws)
      : contacts(contacts),
        all_bodies(all_bodies),
        first_wall(first_wall),
        options(options),
        step(step),
        ws(ws),
        nc(contacts.size()),
        coloured(options.order == ContactOrder::kColoured),
        // Coloured order: the sweeps work on a copy of the bodies the rows touch, numbered in
        // the order the rows first use them. A slab's rows are contiguous, so its bodies are
        // too, and two threads solving two slabs write to different cache lines (with the bodies
        // in their own numbering, neighbours in space are scattered in memory and the threads'
        // writes to shared cache lines serialise them). The arithmetic is the same, so are the
        // results.
        bodies(coloured ? ws.local_bodies : all_bodies),
        // Threads: only for the coloured order (the others are one serial group), and only with
        // enough rows to share. Their number does not change the result
        // (coloured_groups_begin). More threads than processors would only wait for each other
        // at every phase.
        threads(coloured ? threads_for(nc, options.min_rows_per_thread, options.threads) : 1),
        rows(ws.rows),
        inv_dt(1.0 / dt),
        // Slab correction (slab_correction.hpp); whether the packing has the bands for it is
        // known once the groups are (coloured_groups_begin sets cg.bands), read after a barrier.
        // Not with a compliance: its target is the rigid condition.
        slab_period(asks_for_slab_correction(options) ? options.slab_correction_period : 0),
        walls(all_bodies.size() - std::min(first_wall, all_bodies.size())),
        // Anderson acceleration mixes the rows awake at the start (the others are open and
        // separating: their impulse stays 0 unless they wake, and then the sweeps alone solve
        // them).
        accelerate(options.anderson_depth > 0),
        plain_period(std::max(options.anderson_period, 1)) {}

  /// The whole solve: the team (one parallel region per step), then the report.
  SolverReport run() {
    if (nc == 0) return report;
    ws.keep_n =
        1.0 - options.relaxation * options.normal_compliance / (1.0 + options.normal_compliance);
    set_up();
#if defined(_OPENMP)
    if (threads > 1) {
      SpinBarrier barrier;
#pragma omp parallel num_threads(threads)
      {
        const SpinBarrierScope scope(barrier);
        solve_rows();
      }
    } else {
      solve_rows();
    }
#else
    solve_rows();
#endif
    report.active_contacts = active_contacts;
    return report;
  }

 private:
  /// What one thread keeps across the sweeps. After a sweep every thread adds the groups'
  /// tallies itself (the same sums in the same order: the same decision on every thread), so
  /// that no thread waits for another to decide whether to stop; only the first thread writes
  /// the report.
  struct SweepState {
    TeamPlace place;
    bool first_thread = false;
    bool slab_corrections = false;
    int period = 1;  ///< sweeps between two Anderson mixes
    bool any_dormant = false;
    double residual = 0.0;        ///< of the last sweep whose sums were taken
    bool refused = false;         ///< the residual test refused to stop after this sweep
    StageClock* clock = nullptr;  ///< this thread's (SolverOptions::profile)
  };

  /// Whether the serial group (the last) has rows: an empty one (no rows, so none dormant either)
  /// is left out of the sweeps and of the tallies' sums (each_tallied_group), as the groups
  /// without awake rows are.
  bool serial_group_has_rows() const {
    return ws.group_start[groups - 1] < ws.group_start[groups];
  }

  bool corrects_slabs() const {
    return slab_period > 0 && cg.bands >= kSlabCorrectionMinBands;
  }

  /// Set-up on the calling thread, before the team starts: the rows' storage, the serial order
  /// (random order), the team's scratch (coloured order).
  void set_up() {
    rows.resize(nc);
    ws.delassus.resize(nc);
    ws.row_lengths2.resize(nc);
    ws.team_moved_rows.resize(static_cast<std::size_t>(threads));
    if (!coloured) {
      order_rows_serially(nc, options, step, ws);
      size_group_scratch();
    }
    if (coloured) {  // per-thread scratch, sized for the team before it starts
      const auto team = static_cast<std::size_t>(threads);
      ws.team_max_band.resize(team);
      ws.team_wall_band.resize(team * walls);
      ws.team_new_bodies.resize(team);
      ws.team_body_offset.resize(team + 1);
      ws.local_of.resize(all_bodies.size());
      // A new stamp per call marks this call's uses (renumbering); the stamps restart from zero
      // when the bodies or the team change, or after 2^32 - 1 calls.
      if (ws.team_seen.size() != team * all_bodies.size() || ws.seen_stamp == 0xffffffffu) {
        ws.team_seen.assign(team * all_bodies.size(), 0);
        ws.seen_stamp = 0;
      }
      ++ws.seen_stamp;
    }
  }

  /// Sizes the per-group scratch once the groups are known (on one thread).
  void size_group_scratch() {
    groups = ws.group_start.size() - 1;
    report.colours = ws.phases.size();
    ws.group_tallies.resize(2 * groups);  // two sweeps' worth: see solve_rows
    ws.woken_of_group.resize(groups);
    ws.awake.resize(groups);
    ws.dormant_of_group.resize(groups);
  }

  /// Ordering (coloured order): the groups, the shuffle inside each group and the renumbered
  /// bodies, on every thread of the team: each pass over bodies, contacts or groups is shared,
  /// and what one thread must do between them (merging the threads' findings in thread order)
  /// is over groups, walls or threads only.
  void arrange_coloured_rows() {
    const TeamPlace place = team_place();
    const Share my_contacts = share_of(nc, place);
    coloured_bands_share(all_bodies, first_wall, place, ws);
    team_barrier();
#if defined(_OPENMP)
#pragma omp single nowait
#endif
    disk_bands = coloured_bands_merge(place.size, ws);
    team_barrier();
    coloured_groups_share(contacts, all_bodies, first_wall, disk_bands, place, ws);
    team_barrier();
#if defined(_OPENMP)
#pragma omp single nowait
#endif
    {
      cg = coloured_groups_merge(walls, disk_bands, place.size, ws);
      ws.group_of.resize(nc);
      ws.team_count.assign(place.size * (cg.serial + 1), 0);
    }
    team_barrier();
    // Each contact's group, counted by the thread that finds it.
    {
      std::size_t* count = ws.team_count.data() + place.thread * (cg.serial + 1);
      for (std::size_t i = my_contacts.first; i < my_contacts.last; ++i) {
        const std::uint32_t g = coloured_group_of(contacts[i], all_bodies, first_wall, cg, ws);
        ws.group_of[i] = g;
        ++count[g];
      }
    }
    team_barrier();
#if defined(_OPENMP)
#pragma omp single nowait
#endif
    {
      coloured_groups_end(cg, place.size, ws);
      size_group_scratch();
    }
    team_barrier();
    // Each thread places its contacts, in contact order, from its offsets in each group.
    {
      std::size_t* next = ws.team_count.data() + place.thread * (cg.serial + 1);
      for (std::size_t i = my_contacts.first; i < my_contacts.last; ++i)
        ws.order[next[ws.group_of[i]]++] = static_cast<std::uint32_t>(i);
    }
    team_barrier();
    each_own_group(place, [&](std::size_t g) { shuffle_group(g, options, step, ws); });
    team_barrier();
    renumber_bodies(place, my_contacts);
  }

  /// Ordering (coloured order), the second part: the bodies the rows touch, numbered in the
  /// order the rows first use them (row i's body a before its body b), copied to the local
  /// bodies (with their slab-correction band). Each thread lists the bodies its share of the
  /// rows uses, in the order of their first use there (its own stamps mark those seen), then
  /// drops those that a thread before it uses too (read in that thread's stamps): the lists
  /// joined in thread order are the order of first use over all rows. No thread writes where
  /// another reads or writes (atomic minima of a shared array, tried first, cost more than the
  /// serial loop: the bodies' global numbers are scattered in space, so both threads wrote to the
  /// same cache lines).
  void renumber_bodies(const TeamPlace& place, const Share& my_contacts) {
    {
      const std::uint32_t stamp = ws.seen_stamp;
      const std::size_t body_count = all_bodies.size();
      std::uint32_t* seen = ws.team_seen.data() + place.thread * body_count;
      auto& mine = ws.team_new_bodies[place.thread];
      // Without a branch: each body is written at the list's end, which moves on only if the
      // body was new. Whether it is new is a coin toss in a shuffled order (a disk has about four
      // contacts), and the mispredicted branch cost about 2% of a system-1 step.
      mine.resize(2 * (my_contacts.last - my_contacts.first));
      std::size_t listed = 0;
      for (std::size_t i = my_contacts.first; i < my_contacts.last; ++i) {
        const Contact& c = contacts[ws.order[i]];
        for (const std::int32_t key : {c.key.body_a, c.key.body_b}) {
          const auto body = static_cast<std::size_t>(key);
          const bool fresh = seen[body] != stamp;
          seen[body] = stamp;
          mine[listed] = static_cast<std::uint32_t>(body);
          listed += fresh;
        }
      }
      mine.resize(listed);
      team_barrier();
      if (place.thread > 0) {
        std::erase_if(mine, [&](std::uint32_t body) {
          for (std::size_t t = 0; t < place.thread; ++t)
            if (ws.team_seen[t * body_count + body] == stamp) return true;
          return false;
        });
      }
      team_barrier();
    }
#if defined(_OPENMP)
#pragma omp single nowait
#endif
    {
      ws.team_body_offset[0] = 0;
      for (std::size_t t = 0; t < place.size; ++t)
        ws.team_body_offset[t + 1] = ws.team_body_offset[t] + ws.team_new_bodies[t].size();
      const std::size_t touched = ws.team_body_offset[place.size];
      ws.local_bodies.resize(touched);
      ws.global_of.resize(touched);
      if (corrects_slabs()) ws.node_of_body.resize(touched);
    }
    team_barrier();
    {
      const auto& mine = ws.team_new_bodies[place.thread];
      std::size_t k = ws.team_body_offset[place.thread];
      for (const std::uint32_t body : mine) {
        ws.local_of[body] = static_cast<std::uint32_t>(k);
        ws.local_bodies[k] = all_bodies[body];
        ws.global_of[k] = body;
        if (corrects_slabs()) {
          // The slab correction's band of each local body: a disk's own (its rank), a wall's that
          // of its disks if they are all in one band (then its rows are in that slab's group).
          const std::uint32_t band = body < first_wall ? ws.band_rank[all_bodies[body].band]
                                                       : ws.wall_band[body - first_wall];
          ws.node_of_body[k] = band < cg.bands ? band : SlabCorrection::kNoNode;
        }
        ++k;
      }
    }
    team_barrier();  // prepare_rows reads any body's local number
  }

  /// Runs `for_group(g)` over every group, phase by phase, then the serial group: groups of a
  /// phase share no body, so each body meets the groups' changes in group order, as one thread
  /// going through the rows in order would.
  template <class ForGroup>
  void each_group_by_phase(const ForGroup& for_group) {
    for_each_phased_group(ws.phases, for_group);
    if (team_place().thread == 0) for_group(groups - 1);  // its owner (for_each_own_group)
    team_barrier();
  }

  /// Runs `for_group(g)` over the groups thread `place` takes in the passes over every group at
  /// once (for_each_own_group: the same groups as in the sweeps), with no barrier.
  template <class ForGroup>
  void each_own_group(const TeamPlace& place, const ForGroup& for_group) const {
    for_each_own_group(ws.phases, groups - 1, place, for_group);
  }

  /// On one thread: the phased groups with awake rows (ws.busy_groups), phase by phase, each
  /// phase's in group order. Only these do anything in a sweep or in the passes between sweeps:
  /// a group without awake rows updates nothing, and its tallies are zeros, which add nothing
  /// to sums of non-negative terms (a sum that starts at +0 stays the same bit for bit), so
  /// that leaving it out changes no result. A dense flow has every group busy; a dilute one
  /// (a cell the walls have pushed to tens of times its height, at the study's fastest walls)
  /// has hundreds of bands with a few awake rows between them, and there the pass over every
  /// group cost more than the sweeps' updates. Rows only wake within a step, so the list only
  /// grows: it is made again after a look that woke a group's first row.
  void list_busy_groups() {
    ws.busy_groups.clear();
    ws.busy_phase_start.assign(1, 0);
    for (const SolverPhase& phase : ws.phases) {
      for (std::size_t g = phase.first_group; g < phase.last_group; ++g)
        if (!ws.awake[g].empty()) ws.busy_groups.push_back(static_cast<std::uint32_t>(g));
      ws.busy_phase_start.push_back(ws.busy_groups.size());
    }
  }

  /// The places in ws.busy_groups of the busy groups of phase p that thread `place` takes: its
  /// share_of them (the split of the sweeps and of every pass between them).
  Share busy_share(std::size_t p, const TeamPlace& place) const {
    const std::size_t first = ws.busy_phase_start[p];
    const Share mine = share_of(ws.busy_phase_start[p + 1] - first, place);
    return {first + mine.first, first + mine.last};
  }

  /// Runs `for_group(g)` over the busy groups thread `place` takes (busy_share), then the serial
  /// group on the first thread if it has rows; with a barrier after each phase if
  /// `phase_barriers` (the groups' changes to the bodies then meet each body in group order) and
  /// none otherwise.
  template <class ForGroup>
  void each_busy_group(const TeamPlace& place, bool phase_barriers,
                       const ForGroup& for_group) const {
    for (std::size_t p = 0; p + 1 < ws.busy_phase_start.size(); ++p) {
      const Share mine = busy_share(p, place);
      for (std::size_t k = mine.first; k < mine.last; ++k) for_group(ws.busy_groups[k]);
      if (phase_barriers) team_barrier();
    }
    if (serial_group_has_rows() && place.thread == 0) for_group(groups - 1);
    if (phase_barriers) team_barrier();
  }

  /// Calls `add(g)` for every busy group, then the serial group if it has rows: in group order,
  /// as the sums of the tallies are taken (on every thread).
  template <class Add>
  void each_tallied_group(const Add& add) const {
    for (const std::uint32_t g : ws.busy_groups) add(g);
    if (serial_group_has_rows()) add(groups - 1);
  }

  /// Set-up of the rows: the rows in visit order (the sweeps then read them front to back) and
  /// their Delassus entries, then the warm start (apply the carried-over impulses), then the
  /// dormant rows.
  void prepare_rows() {
    const TeamPlace place = team_place();
    each_own_group(place, [&](std::size_t g) {
      for (std::size_t i = ws.group_start[g]; i < ws.group_start[g + 1]; ++i) {
        const Contact& c = contacts[ws.order[i]];
        const auto global_a = static_cast<std::size_t>(c.key.body_a);
        const auto global_b = static_cast<std::size_t>(c.key.body_b);
        const std::size_t ia = coloured ? ws.local_of[global_a] : global_a;
        const std::size_t ib = coloured ? ws.local_of[global_b] : global_b;
        // The decoupled rows' factors carry the over-relaxation and the compliance.
        fill_row(rows[i], ws.delassus[i], c, bodies[ia], bodies[ib], inv_dt, options.relaxation,
                 options.normal_compliance);
        rows[i].body_a = static_cast<std::uint32_t>(ia);
        rows[i].body_b = static_cast<std::uint32_t>(ib);
      }
    });
    team_barrier();
    each_group_by_phase([&](std::size_t g) {
      for (std::size_t i = ws.group_start[g]; i < ws.group_start[g + 1]; ++i) {
        const SolverRow& r = rows[i];
        apply_row_impulse(r, bodies[r.body_a], bodies[r.body_b], r.impulse_n, r.impulse_t);
      }
    });
    // Dormant rows: open (R = 0) and separating (u_n + gap/dt > 0) once the warm start is
    // applied. The sweeps leave them out; every kDormantCheckInterval sweeps, and before the
    // sweeps stop, those that would now close are woken (nlgs_solver.hpp).
    // Without a branch: each row is written at the end of both lists, and the list it belongs
    // to moves on. About half of the rows are dormant, in no pattern a predictor can learn, and
    // the mispredicted branch cost about 1% of a system-1 step.
    each_own_group(place, [&](std::size_t g) {
      const std::size_t first = ws.group_start[g], last = ws.group_start[g + 1];
      auto& awake = ws.awake[g];
      auto& dormant = ws.dormant_of_group[g];
      awake.resize(last - first);
      dormant.resize(last - first);
      std::size_t awake_count = 0, dormant_count = 0;
      for (std::size_t i = first; i < last; ++i) {
        const SolverRow& r = rows[i];
        const bool open = (r.impulse_n == 0.0) & (r.impulse_t == 0.0);
        const bool sleeps = options.skip_dormant & open & (biased_normal_velocity(r, bodies) > 0.0);
        awake[awake_count] = static_cast<std::uint32_t>(i);
        dormant[dormant_count] = {static_cast<std::uint32_t>(i), r.body_a, r.body_b, r.normal,
                                  r.bias_n};
        awake_count += !sleeps;
        dormant_count += sleeps;
      }
      awake.resize(awake_count);
      dormant.resize(dormant_count);
      // Already in that order (no awake row, or the awake ones first: the listing is in row
      // order), as most groups of a dilute cell are: nothing to move.
      const bool in_order = awake_count == 0 || awake[awake_count - 1] == first + awake_count - 1;
      if (dormant_count > 0 && !in_order) put_awake_rows_first(place, first, last, awake, dormant);
    });
    team_barrier();
  }

  /// Moves group [first, last)'s awake rows to its front, in the order the sweeps visit them, and
  /// its dormant rows after them: a sweep then streams through its rows without the dormant ones'
  /// cache lines between them. The rows keep their contact (ws.order) and Delassus entries; the
  /// visit order, and so every result, is unchanged.
  void put_awake_rows_first(const TeamPlace& place, std::size_t first, std::size_t last,
                            std::vector<std::uint32_t>& awake, std::vector<DormantRow>& dormant) {
    SolverWorkspace::MovedRows& moved = ws.team_moved_rows[place.thread];
    auto& moved_rows = moved.rows;
    auto& moved_delassus = moved.delassus;
    auto& moved_order = moved.order;
    const std::size_t n = last - first;
    moved_rows.resize(n);
    moved_delassus.resize(n);
    moved_order.resize(n);
    std::size_t k = 0;
    const auto move = [&](std::uint32_t i) {
      moved_rows[k] = rows[i];
      moved_delassus[k] = ws.delassus[i];
      moved_order[k] = ws.order[i];
      return static_cast<std::uint32_t>(first + k++);
    };
    for (std::uint32_t& i : awake) i = move(i);
    for (DormantRow& d : dormant) d.row = move(d.row);
    std::copy(moved_rows.begin(), moved_rows.end(),
              rows.begin() + static_cast<std::ptrdiff_t>(first));
    std::copy(moved_delassus.begin(), moved_delassus.end(),
              ws.delassus.begin() + static_cast<std::ptrdiff_t>(first));
    std::copy(moved_order.begin(), moved_order.end(),
              ws.order.begin() + static_cast<std::ptrdiff_t>(first));
  }

  /// Acceleration: the impulses of the mixed rows into v (the loop is shared; v has its size
  /// already). scale_rows: right after a slab correction that left its pass 5 to this gather,
  /// every awake row of the slab and boundary groups is scaled first (SlabCorrection::scale_row):
  /// the mixed ones here, the ones woken since the start (not mixed) by their group's thread. The
  /// serial group's rows are not scaled (pass 5 leaves them: the correction moved no body for
  /// them).
  void gather_mixed_impulses(std::vector<double>& v, bool scale_rows) {
    const std::size_t phased_groups = groups - 1;  // all but the serial group
    each_busy_group(team_place(), false, [&](std::size_t g) {
      const bool scale_here = scale_rows && g < phased_groups;
      if (scale_here) {
        const std::size_t mixed_here = ws.anderson_group_start[g + 1] - ws.anderson_group_start[g];
        for (std::size_t k = mixed_here; k < ws.awake[g].size(); ++k)
          ws.slab_correction.scale_row(rows[ws.awake[g][k]]);
      }
      for (std::size_t k = ws.anderson_group_start[g]; k < ws.anderson_group_start[g + 1]; ++k) {
        SolverRow& r = rows[ws.anderson_rows[k]];
        if (scale_here) ws.slab_correction.scale_row(r);
        v[2 * k] = r.impulse_n;
        v[2 * k + 1] = r.impulse_t;
      }
    });
    team_barrier();  // the mix reads v
  }

  /// Acceleration: the mixed impulses of group g's rows, projected on the Signorini-Coulomb set;
  /// the bodies follow through the change of each impulse (applied phase by phase,
  /// each_busy_group: bit for bit what one thread going through the rows would give).
  void apply_mixed_impulses(std::size_t g) {
    for (std::size_t k = ws.anderson_group_start[g]; k < ws.anderson_group_start[g + 1]; ++k) {
      SolverRow& r = rows[ws.anderson_rows[k]];
      const double r_n = std::max(0.0, ws.anderson_g[2 * k]);
      const double limit = r.friction * r_n;
      const double r_t = std::clamp(ws.anderson_g[2 * k + 1], -limit, limit);
      apply_row_impulse(r, bodies[r.body_a], bodies[r.body_b], r_n - r.impulse_n,
                        r_t - r.impulse_t);
      r.impulse_n = r_n;
      r.impulse_t = r_t;
      ws.anderson_x[2 * k] = r_n;
      ws.anderson_x[2 * k + 1] = r_t;
    }
  }

  /// On one thread of the team, once the rows are prepared: how many rows are dormant, and the
  /// rows the mix works on.
  void count_dormant_and_list_mixed_rows() {
    std::size_t dormant = 0;
    for (std::size_t g = 0; g < groups; ++g) dormant += ws.dormant_of_group[g].size();
    report.dormant_contacts = dormant;
    if (!accelerate) return;
    ws.anderson_rows.clear();
    ws.anderson_group_start.assign(1, 0);
    for (std::size_t g = 0; g < groups; ++g) {
      ws.anderson_rows.insert(ws.anderson_rows.end(), ws.awake[g].begin(), ws.awake[g].end());
      ws.anderson_group_start.push_back(ws.anderson_rows.size());
    }
    ws.anderson.reset(2 * ws.anderson_rows.size(), options.anderson_depth);
    ws.anderson_x.resize(2 * ws.anderson_rows.size());
    ws.anderson_g.resize(2 * ws.anderson_rows.size());
  }

  /// The solve on every thread of the team: ordering and set-up, the sweeps until the criterion
  /// holds or the cap, the write-back. One thread calls it outside any parallel region: a team
  /// of one (`if (false)`) would still end every construct with a barrier that makes a system
  /// call (futex wake), two to seven per sweep.
  void solve_rows() {
    StageClock clock(options.profile && team_place().thread == 0);
    SweepState st = begin_sweeps();
    st.clock = &clock;
    clock.lap(report.profile.set_up);
    for (int sweep = 1; sweep <= options.max_sweeps; ++sweep)
      if (sweep_once(sweep, st)) break;
    write_back();
    clock.lap(report.profile.write_back);
  }

  /// Ordering and set-up, then what the sweeps need: the dormant rows counted, the mixed rows
  /// listed, the slab correction reset, this thread's SweepState.
  SweepState begin_sweeps() {
    SweepState st;
    st.place = team_place();
    st.first_thread = st.place.thread == 0;
    if (coloured) arrange_coloured_rows();
    prepare_rows();
#if defined(_OPENMP)
#pragma omp single nowait
#endif
    {
      count_dormant_and_list_mixed_rows();
      list_busy_groups();
      if (corrects_slabs())
        ws.slab_correction.reset(
            bodies.size(), {&ws.group_start, &ws.awake, &ws.phases, cg.bands, &ws.node_of_body});
    }
    team_barrier();
    st.slab_corrections = corrects_slabs();
    st.period =
        st.slab_corrections ? kMixPeriodFactorWithSlabCorrection * plain_period : plain_period;
    if (accelerate) gather_mixed_impulses(ws.anderson_x, false);
    st.any_dormant = report.dormant_contacts > 0;
    if (st.first_thread) report.threads = static_cast<int>(st.place.size);
    return st;
  }

  /// One sweep and what follows it: the convergence test, the dormant rows' look, the report,
  /// then (if the step goes on) the slab correction and the Anderson mix. True when done. A
  /// thread may start the next sweep while another is still adding, so the tallies of
  /// consecutive sweeps go to the two halves of group_tallies in turn (a thread can be at most
  /// one barrier ahead of another).
  bool sweep_once(int sweep, SweepState& st) {
    SweepTally* tallies = ws.group_tallies.data() + (sweep % 2) * groups;
    // Neither correction nor mix after the last sweep: a step ends on a sweep's result. The
    // sweep before a correction gathers its rows for it (dropped if the sweep ends the step:
    // the next step's reset clears it).
    const bool corrects =
        st.slab_corrections && sweep % slab_period == 0 && sweep < options.max_sweeps;
    sweep_groups(tallies, corrects, st);
    double converged_fraction = 1.0;
    bool done = test_convergence(sweep, tallies, st, converged_fraction);
    const std::size_t woken = wake_dormant_rows(sweep, done, st);
    done = done && woken == 0;
    st.clock->lap(report.profile.convergence);
    if (st.first_thread) {
      report.sweeps = sweep;
      report.converged_fraction = converged_fraction;
      report.residual = st.residual;
      report.woken_contacts += woken;
      if (!done && sweep == options.max_sweeps) report.hit_cap = true;
    }
    if (done) return true;  // a gathering for a correction is dropped (the next reset clears it)
    if (st.refused && finishes_plain(options)) {
      // The changes are small but the contact laws not met: over-relaxed updates circling a
      // solution, which plain ones end sooner (solve_contacts goes on with them).
      if (st.first_thread) report.hit_cap = true;
      return true;
    }
    correct_and_mix(sweep, corrects, st);
    return false;
  }

  /// Sweeps: every busy group of every phase (the groups of a phase in parallel), then the
  /// serial group.
  void sweep_groups(SweepTally* tallies, bool corrects, const SweepState& st) {
    // Each thread its share of each phase's busy groups (each_busy_group), then the phase's
    // barrier, the wait timed apart from the work.
    for (std::size_t p = 0; p + 1 < ws.busy_phase_start.size(); ++p) {
      const Share mine = busy_share(p, st.place);
      for (std::size_t k = mine.first; k < mine.last; ++k)
        sweep_group(ws.busy_groups[k], ws, bodies, options.alpha, options.relaxation, tallies,
                    corrects);
      st.clock->lap(report.profile.sweeps);
      team_barrier();
      st.clock->lap(report.profile.phase_waits);
    }
    if (serial_group_has_rows()) {
      if (st.first_thread)  // the thread that owns the serial group (for_each_own_group)
        sweep_group(groups - 1, ws, bodies, options.alpha, options.relaxation, tallies);
      st.clock->lap(report.profile.sweeps);
      team_barrier();
      st.clock->lap(report.profile.phase_waits);
    }
  }

  /// Convergence test (nlgs_solver.hpp): the share of converged force-carrying rows, and the
  /// relative change of the forces against alpha. The sums of |dR| and |R| (square roots) only
  /// where the decision or the report needs them: the count half of the criterion met, or the
  /// last sweep allowed. Every thread decides the same.
  bool test_convergence(int sweep, SweepTally* tallies, SweepState& st,
                        double& converged_fraction) {
    std::size_t converged = 0, carrying = 0;
    each_tallied_group([&](std::size_t g) {
      converged += tallies[g].converged;
      carrying += tallies[g].carrying;
    });
    converged_fraction =
        carrying > 0 ? static_cast<double>(converged) / static_cast<double>(carrying) : 1.0;
    const bool fraction_met = converged_fraction >= options.converged_fraction;
    bool done = false;
    if (fraction_met || sweep == options.max_sweeps) {
      each_busy_group(st.place, false, [&](std::size_t g) { sum_group_lengths(g, ws, tallies); });
      team_barrier();
      double sum_change = 0.0, sum_force = 0.0;
      each_tallied_group([&](std::size_t g) {
        sum_change += tallies[g].sum_change;
        sum_force += tallies[g].sum_force;
      });
      if (sum_force > 0.0) {
        const double ratio = sum_change / sum_force;
        st.residual = ratio * ratio;
      } else {
        // Every force vanished in this sweep: each |dR| is the |R| it had, a relative change
        // of 1 measured against the forces before. (It was infinity, which the step took for
        // a blow-up: a packing whose last contacts all opened in a capped step stopped there.)
        st.residual = sum_change > 0.0 ? 1.0 : 0.0;
      }
      // alpha bounds the square (the residual is the change squared)
      done = fraction_met && st.residual <= options.alpha;
    }
    if (done && options.residual_tolerance > 0.0 && !meets_residual_tolerance(tallies, st)) {
      done = false;
      st.refused = true;
      if (st.first_thread) {
        ++report.residual_refusals;
        if (report.first_refusal_sweep == 0) report.first_refusal_sweep = sweep;
      }
    }
    return done;
  }

  /// The stop test's second part (SolverOptions::residual_tolerance): the root mean square of
  /// e dt over the force-carrying rows, each thread its groups' sums, added in group order.
  /// Dormant rows carry no force and are not counted, as in the step's check.
  bool meets_residual_tolerance(SweepTally* tallies, const SweepState& st) {
    each_busy_group(st.place, false, [&](std::size_t g) {
      double sum2 = 0.0;
      std::size_t carrying = 0;
      for (const std::uint32_t i : ws.awake[g]) {
        const SolverRow& r = rows[i];
        if (!(r.impulse_n > 0.0)) continue;
        const auto [u_n, u_t] = row_velocity(r, bodies);
        sum2 += contact_law_violation2(u_n + ws.delassus[i].compliance_n * r.impulse_n, u_t,
                                       r.impulse_n, r.impulse_t, r.friction);
        ++carrying;
      }
      tallies[g].violation2 = sum2;
      tallies[g].carrying_rows = carrying;
    });
    team_barrier();
    double sum2 = 0.0;
    std::size_t carrying = 0;
    each_tallied_group([&](std::size_t g) {
      sum2 += tallies[g].violation2;
      carrying += tallies[g].carrying_rows;
    });
    if (carrying == 0) return true;
    const double tolerance = options.residual_tolerance * inv_dt;  // on e [length/time]
    return sum2 <= tolerance * tolerance * static_cast<double>(carrying);
  }

  /// The dormant rows' look (every kDormantCheckInterval sweeps, before the last one allowed,
  /// and before the sweeps stop): those that would now close wake. Returns how many woke.
  std::size_t wake_dormant_rows(int sweep, bool done, const SweepState& st) {
    std::size_t woken = 0;
    if (st.any_dormant &&
        (done || sweep % kDormantCheckInterval == 0 || sweep + 1 == options.max_sweeps)) {
      each_own_group(st.place, [&](std::size_t g) {
        ws.woken_of_group[g] = wake_closing_rows(g, ws, bodies);
      });
      team_barrier();
      bool newly_busy = false;  // a phased group whose first rows woke (the same on every thread)
      for (std::size_t g = 0; g < groups; ++g) {
        woken += ws.woken_of_group[g];
        newly_busy |= g + 1 < groups && ws.woken_of_group[g] > 0 &&
                      ws.woken_of_group[g] == ws.awake[g].size();
      }
      if (newly_busy) {
#if defined(_OPENMP)
#pragma omp single nowait
#endif
        list_busy_groups();
        team_barrier();
      }
    }
    return woken;
  }

  /// Between two sweeps: the slab correction (its rows gathered by the sweep before) and the
  /// Anderson mix of the last images, every pass shared among the threads. A correction followed
  /// by a mix leaves the scaling of the rows to the mix's gather.
  void correct_and_mix(int sweep, bool corrects, const SweepState& st) {
    const bool mixes = accelerate && sweep % st.period == 0 && sweep < options.max_sweeps;
    const bool corrected = corrects && ws.slab_correction.apply_gathered(rows, bodies, !mixes);
    st.clock->lap(report.profile.correction);
    if (corrected && st.first_thread) ++report.slab_corrections;
    if (mixes && st.first_thread) ++report.anderson_mixes;
    const bool scale_in_gather = corrected && mixes;
    if (mixes) {
      gather_mixed_impulses(ws.anderson_g, scale_in_gather);
      ws.anderson.mix(ws.anderson_x, ws.anderson_g);
      each_busy_group(team_place(), true, [this](std::size_t g) { apply_mixed_impulses(g); });
      st.clock->lap(report.profile.mix);
    }
  }

  /// Write-back: the impulses back to the contacts (each row has its own contact), counting the
  /// active ones on the way: each thread its own rows, then one atomic add (an integer sum: the
  /// same in any order). Then the velocities back to the bodies (coloured order: each local body
  /// has its own body).
  void write_back() {
    int active_here = 0;
    each_own_group(team_place(), [&](std::size_t g) {
      for (std::size_t i = ws.group_start[g]; i < ws.group_start[g + 1]; ++i) {
        Contact& c = contacts[ws.order[i]];
        c.impulse_n = rows[i].impulse_n;
        c.impulse_t = rows[i].impulse_t;
        active_here += rows[i].impulse_n > 0.0;
      }
    });
#if defined(_OPENMP)
#pragma omp atomic
#endif
    active_contacts += active_here;
    if (coloured) {
#if defined(_OPENMP)
#pragma omp for schedule(static) nowait  // the region's end is the barrier
#endif
      for (std::size_t k = 0; k < ws.global_of.size(); ++k)
        all_bodies[ws.global_of[k]] = ws.local_bodies[k];
    }
  }

  // The call's inputs.
  std::vector<Contact>& contacts;
  std::vector<SolverBody>& all_bodies;
  const std::size_t first_wall;
  const SolverOptions& options;
  const std::uint64_t step;
  SolverWorkspace& ws;
  // Shared by the phases.
  SolverReport report;
  const std::size_t nc;
  const bool coloured;
  std::vector<SolverBody>& bodies;
  const int threads;
  std::vector<SolverRow>& rows;
  const double inv_dt;
  const int slab_period;
  const std::size_t walls;
  const bool accelerate;
  const int plain_period;
  std::size_t groups = 1;  ///< the last one is the serial group; set before any thread reads it
  ColouredGroups cg;
  std::size_t disk_bands = 1;  ///< the disks' bands (coloured order), reached or not
  int active_contacts = 0;     ///< rows with R_n > 0 at the end, counted by the write-back
};

}  // namespace

SolverReport solve_contacts(std::vector<Contact>& contacts, std::vector<SolverBody>& all_bodies,
                            std::size_t first_wall, double dt, const SolverOptions& options,
                            std::uint64_t step, SolverWorkspace& workspace) {
  // The over-relaxed update is the one-stage form of local_solve.hpp, exact for omega >= 1 only.
  if (!(options.relaxation >= 1.0 && options.relaxation < 2.0))
    throw std::invalid_argument("solver relaxation must be in [1, 2), got " +
                                std::to_string(options.relaxation));
  if (!(options.normal_compliance >= 0.0 && options.normal_compliance < kNormalComplianceBound))
    throw std::invalid_argument("solver normal compliance must be in [0, 1), got " +
                                std::to_string(options.normal_compliance));
  SolverReport report =
      ContactSolve(contacts, all_bodies, first_wall, dt, options, step, workspace).run();
  if (!report.hit_cap || !finishes_plain(options)) return report;

  // Plain finish. Projected over-relaxed updates of frictional contacts can cycle without
  // meeting the criterion (system 1 at V = 0.05: a fifth of the steps at the cap of 200, the
  // worst RMS contact-law violation among them 30 times the other steps' worst), where plain
  // Gauss-Seidel updates from the same impulses end most of them within tens of sweeps. The same
  // for a step whose changes met alpha while its contact-law violation did not meet
  // residual_tolerance: from the same states, the plain updates took a third of the sweeps that
  // over-relaxed ones took after the refusal (tests/test_plain_finish.cpp). The bodies go back
  // to their free velocities (the impulses taken off again, contact by contact in a fixed order:
  // the same on any thread count), and the solve starts again with relaxation 1, warm-started
  // from the impulses reached.
  for (const Contact& c : contacts)
    apply_contact_impulse(c, all_bodies, -c.impulse_n, -c.impulse_t);
  SolverOptions plain = options;
  plain.relaxation = 1.0;
  SolverReport finish =
      ContactSolve(contacts, all_bodies, first_wall, dt, plain, step, workspace).run();
  finish.finished_plain = true;
  finish.sweeps += report.sweeps;
  finish.dormant_contacts += report.dormant_contacts;
  finish.woken_contacts += report.woken_contacts;
  finish.slab_corrections += report.slab_corrections;
  finish.anderson_mixes += report.anderson_mixes;
  finish.residual_refusals += report.residual_refusals;
  if (report.first_refusal_sweep > 0)
    finish.first_refusal_sweep = report.first_refusal_sweep;
  else if (finish.first_refusal_sweep > 0)
    finish.first_refusal_sweep += report.sweeps;
  finish.profile += report.profile;
  return finish;
}

}  // namespace cdshear
