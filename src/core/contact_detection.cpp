#include "contact_detection.hpp"

#include <algorithm>
#include <cmath>

#include "threads.hpp"

namespace cdshear {

double wall_gap(const World& world, std::size_t i, const Wall& w) {
  return dot(world.disks.position[i] - w.point, w.normal) - world.disks.radius[i];
}

namespace {

/// Fills `out` with what `list_run(first, last, part)` appends for runs of consecutive disks
/// [first, last) covering [0, n), one run per thread of a team of `team`, joined in run order:
/// whatever list_run lists in disk order comes out as one thread listing [0, n) would give it,
/// wherever the runs are cut. Run t starts at disk run_start(t, size) (0 for t = 0, n for
/// t = size, never decreasing). `parts` and `offsets` are scratch kept between calls.
template <typename T, typename RunStart, typename ListRun>
void list_in_runs(int team, std::size_t n, std::vector<std::vector<T>>& parts,
                  std::vector<std::size_t>& offsets, std::vector<T>& out, const RunStart& run_start,
                  const ListRun& list_run) {
  if (team == 1) {
    out.clear();
    list_run(0, n, out);
    return;
  }
  // With a team, `out` is not cleared: resizing it from its last size constructs only the
  // elements it gains (clearing it first made one thread construct every element, 1.2 MB of
  // writes per step on system 7, before the team overwrote them all).
#if defined(_OPENMP)
  parts.resize(static_cast<std::size_t>(team));
  offsets.resize(static_cast<std::size_t>(team) + 1);
#pragma omp parallel num_threads(team)
  {
    // Plain variables, not a structured binding: clang 14 rejects one used inside `omp single`.
    const TeamPlace place = team_place();
    const std::size_t t = place.thread, size = place.size;
    // The thread lists into a vector of its own, moved out of `parts` and back: the headers of
    // parts[0] and parts[1] share a cache line, so appending to them in place made every
    // append of one thread take the line from the other (false sharing: each thread then
    // listed its half in more time than one thread took for all).
    std::vector<T> part = std::move(parts[t]);
    part.clear();
    list_run(run_start(t, size), run_start(t + 1, size), part);
    parts[t] = std::move(part);
#pragma omp barrier
#pragma omp single
    {
      offsets[0] = 0;
      for (std::size_t k = 0; k < size; ++k) offsets[k + 1] = offsets[k] + parts[k].size();
      out.resize(offsets[size]);
    }
    std::copy(parts[t].begin(), parts[t].end(),
              out.begin() + static_cast<std::ptrdiff_t>(offsets[t]));
  }
#else
  (void)parts;  // team is 1 without OpenMP
  (void)offsets;
  (void)run_start;
#endif
}

}  // namespace

bool ContactDetector::neighbours_cover(const World& world, double margin) const {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  if (built_reach_ < margin || built_position_.size() != n ||
      built_periodic_ != world.domain.periodic_x || built_length_x_ != world.domain.length_x)
    return false;
  // Every pair closer than the margin now was closer than margin + 2 max displacement at the
  // build; that is within the list's reach while 2 max displacement <= built_reach - margin.
  const double allowed = 0.5 * (built_reach_ - margin);
  const double allowed2 = allowed * allowed;
  const double lx = world.domain.length_x;
  for (std::size_t i = 0; i < n; ++i) {
    if (d.radius[i] != built_radius_[i]) return false;
    double dx = d.position[i].x - built_position_[i].x;
    if (world.domain.periodic_x && std::abs(dx) > 0.5 * lx) dx -= lx * std::nearbyint(dx / lx);
    const double dy = d.position[i].y - built_position_[i].y;
    if (!(dx * dx + dy * dy <= allowed2)) return false;  // NaN too: rebuild
  }
  return true;
}

void ContactDetector::list_neighbours(const World& world, double reach, std::size_t first,
                                      std::size_t last, std::vector<std::int32_t>& out) {
  const Disks& d = world.disks;
  for (std::size_t i = first; i < last; ++i) {
    const std::size_t begin = out.size();  // the partners of disk i: out[begin, end)
    cells_.for_each_neighbour_above(world, i, [&](std::int32_t j, std::int32_t, Vec2 delta) {
      const double cutoff = d.radius[i] + d.radius[j] + reach;
      if (length_squared(delta) < cutoff * cutoff) out.push_back(j);
    });
    // A disk is visited once per i (one image: the nearest), so sorting by j gives the
    // (j, image) order of the keys.
    std::sort(out.begin() + static_cast<std::ptrdiff_t>(begin), out.end());
    start_[i + 1] = out.size() - begin;  // a count for now; the caller adds them up
  }
}

void ContactDetector::build_neighbours(const World& world, double margin, int team) {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  const double largest_diameter = 2.0 * max_radius(world);
  const double reach = margin + kSkinPerDiameter * largest_diameter;
  cells_.build(world, std::max(largest_diameter + reach, 1e-12));
  start_.assign(n + 1, 0);
  const auto equal_runs = [n](std::size_t t, std::size_t size) {
    return share_of(n, {t, size}).first;
  };
  list_in_runs(team, n, parts_neighbours_, part_offset_, neighbours_, equal_runs,
               [&](std::size_t first, std::size_t last, std::vector<std::int32_t>& out) {
                 list_neighbours(world, reach, first, last, out);
               });
  for (std::size_t i = 0; i < n; ++i) start_[i + 1] += start_[i];  // counts -> offsets
  built_position_ = d.position;
  built_radius_ = d.radius;
  built_reach_ = reach;
  built_length_x_ = world.domain.length_x;
  built_periodic_ = world.domain.periodic_x;
  ++builds_;
}

void ContactDetector::list_candidates(const World& world, double margin, std::size_t first,
                                      std::size_t last, std::vector<Contact>& out) const {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  const double lx = world.domain.length_x;
  for (std::size_t i = first; i < last; ++i) {
    // Disk-disk candidates with j > i, in ascending j (the nearest image of each).
    const Vec2 pi = d.position[i];
    for (std::size_t k = start_[i]; k < start_[i + 1]; ++k) {
      const std::int32_t j = neighbours_[k];
      Vec2 delta = d.position[j] - pi;
      const double shift = world.domain.periods_in(delta.x);
      delta.x -= shift * lx;
      const double cutoff = d.radius[i] + d.radius[j] + margin;
      const double dist2 = length_squared(delta);
      if (!(dist2 < cutoff * cutoff)) continue;
      const double dist = centre_distance(dist2);
      Contact& c = out.emplace_back();  // filled in place (a local copied in was 112 bytes more)
      c.key = {static_cast<std::int32_t>(i), j, -static_cast<std::int32_t>(shift)};
      // Normal from b (= j) to a (= i): -delta / |delta|.
      c.normal = dist > 0.0 ? (-1.0 / dist) * delta : Vec2{0.0, 1.0};
      c.gap = dist - d.radius[i] - d.radius[j];
      // One contact point for both disks, in the middle of the gap (or overlap): then R on a and
      // -R on b act at the same point and conserve angular momentum. Taking each disk's own
      // surface point (-r_a n and +r_b n, which are `gap` apart) would add a spurious couple
      // gap * R_t whenever a contact carries friction before it has closed.
      const double half_gap = 0.5 * c.gap;
      c.lever_a = -(d.radius[i] + half_gap);
      c.lever_b = -(d.radius[j] + half_gap);
      c.friction = world.friction_disk_disk;
    }
    // Disk-wall candidates, walls numbered after the disks.
    for (std::size_t w = 0; w < world.walls.size(); ++w) {
      const Wall& wall = world.walls[w];
      const double gap = wall_gap(world, i, wall);
      if (gap >= margin) continue;
      Contact& c = out.emplace_back();
      c.key = {static_cast<std::int32_t>(i), static_cast<std::int32_t>(n + w), 0};
      c.normal = wall.normal;
      c.lever_a = -d.radius[i];
      c.lever_b = 0.0;
      c.gap = gap;
      c.friction = wall.friction;
    }
  }
}

void carry_impulses(const std::vector<Contact>& previous, std::vector<Contact>& fresh) {
  if (fresh.empty()) return;
  // Both are sorted by key: start at the first previous key not below the run's first.
  const auto by_key = [](const Contact& c, const ContactKey& key) { return c.key < key; };
  auto p = std::lower_bound(previous.begin(), previous.end(), fresh.front().key, by_key);
  for (Contact& c : fresh) {
    while (p != previous.end() && p->key < c.key) ++p;
    if (p != previous.end() && p->key == c.key) {
      c.impulse_n = p->impulse_n;
      c.impulse_t = p->impulse_t;
    }
  }
}

void ContactDetector::detect(const World& world, double margin, std::vector<Contact>& contacts,
                             int threads) {
  const std::size_t n = world.disks.size();
  const int team = threads_for(n, kMinDisksPerThread, threads);
  if (!neighbours_cover(world, margin)) build_neighbours(world, margin, team);
  // A candidate's key starts with its disk, so each run of disks is a run of keys: each thread
  // warm-starts its own run.
  // Each pair is listed by its lower disk, so disk i has about (n - i) / n of its neighbours to
  // test when the numbers are scattered in space: runs of equal disk counts gave the first
  // thread three times the second's pairs. The runs are cut at equal shares of the neighbour
  // list instead (start_ is its prefix sum by disk).
  const auto equal_pairs = [&](std::size_t t, std::size_t size) {
    return weighted_share_of(start_, {t, size}).first;
  };
  list_in_runs(team, n, parts_, part_offset_, fresh_, equal_pairs,
               [&](std::size_t first, std::size_t last, std::vector<Contact>& out) {
                 list_candidates(world, margin, first, last, out);
                 carry_impulses(contacts, out);
               });
  contacts.swap(fresh_);
}

}  // namespace cdshear
