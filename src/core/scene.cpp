#include "scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <unordered_map>

#include "cell_list.hpp"
#include "random.hpp"

namespace cdshear {
namespace {

/// %g formatting (std::to_string prints 1e-9 as 0.000000).
std::string short_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string indexed(const std::string& base, std::size_t i, const std::string& field) {
  return base + "[" + std::to_string(i) + "]." + field;
}

/// Grid of already placed disks for random sequential addition (x columns wrap when periodic).
class PlacementGrid {
 public:
  PlacementGrid(const World& world, double cell) : world_(world) {
    periodic_ = world.domain.periodic_x;
    lx_ = world.domain.length_x;
    columns_ = periodic_ ? std::max(1, static_cast<int>(std::floor(lx_ / cell))) : 0;
    cell_w_ = periodic_ ? lx_ / columns_ : cell;
    cell_h_ = cell;
    for (std::size_t i = 0; i < world.disks.size(); ++i) insert(i);
  }
  void insert(std::size_t i) {
    const auto [x, y] = coords(world_.disks.position[i]);
    cells_[pack(x, y)].push_back(i);
  }
  bool fits(Vec2 p, double r) const {
    const auto [cx, cy] = coords(p);
    int seen[3];
    int n_seen = 0;
    for (int dx = -1; dx <= 1; ++dx) {
      int x = cx + dx;
      if (periodic_) {
        x = (x + columns_) % columns_;
        if (std::find(seen, seen + n_seen, x) != seen + n_seen) continue;
        seen[n_seen++] = x;
      }
      for (int dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(pack(x, cy + dy));
        if (it == cells_.end()) continue;
        for (const std::size_t j : it->second) {
          const Vec2 delta = world_.domain.minimum_image(world_.disks.position[j] - p);
          const double rr = r + world_.disks.radius[j];
          if (length_squared(delta) < rr * rr) return false;
        }
      }
    }
    return true;
  }

 private:
  std::pair<int, int> coords(Vec2 p) const {
    int x = static_cast<int>(std::floor(p.x / cell_w_));
    if (periodic_) x = ((x % columns_) + columns_) % columns_;
    return {x, static_cast<int>(std::floor(p.y / cell_h_))};
  }
  static std::int64_t pack(int x, int y) {
    return (static_cast<std::int64_t>(x) << 32) ^ static_cast<std::uint32_t>(y);
  }
  const World& world_;
  bool periodic_ = false;
  double lx_ = 0.0, cell_w_ = 1.0, cell_h_ = 1.0;
  int columns_ = 0;
  std::unordered_map<std::int64_t, std::vector<std::size_t>> cells_;
};

/// The walls that leave no room in a group's region: every point of it behind the wall or within
/// the smallest radius of it (a wall whose normal points away from the disks' side, the usual
/// slip), as advice for the placement's failure; nullopt when no wall does.
std::optional<std::string> walls_excluding(const std::vector<Wall>& walls,
                                           const RandomDisksSpec& spec) {
  std::string names;
  for (const Wall& w : walls) {
    const Vec2 n = (1.0 / length(w.normal)) * w.normal;
    // The region's corner furthest in front of the wall.
    const Vec2 front{n.x > 0.0 ? spec.region_max.x : spec.region_min.x,
                     n.y > 0.0 ? spec.region_max.y : spec.region_min.y};
    if (dot(front - w.point, n) < 0.5 * spec.diameter_min)
      names += (names.empty() ? "'" : ", '") + w.name + "' (normal (" + short_number(w.normal.x) +
               ", " + short_number(w.normal.y) + "))";
  }
  if (names.empty()) return std::nullopt;
  return "the region lies wholly behind wall " + names +
         ": a wall's normal points to the side the disks may fill; check its sign";
}

void place_random(World& world, const RandomDisksSpec& spec, std::size_t group, double density,
                  const std::atomic<bool>* cancel) {
  const std::string base = "random_disks";
  const double cell = std::max(spec.diameter_max, 2.0 * max_radius(world));
  const bool periodic = world.domain.periodic_x;
  const double lx = world.domain.length_x;
  PlacementGrid grid(world, cell);
  for (std::size_t k = 0; k < spec.count; ++k) {
    if (cancel != nullptr && cancel->load(std::memory_order_relaxed)) throw PlacementCancelled();
    CounterRandom size_rng(spec.seed, RandomStream::kDiameters, k);
    const double r = 0.5 * size_rng.uniform(spec.diameter_min, spec.diameter_max);
    CounterRandom rng(spec.seed, RandomStream::kPlacement, k);
    // In a periodic domain a region spanning the whole period may be used edge to edge.
    const bool full_period = periodic && spec.region_max.x - spec.region_min.x >= lx;
    const double x_lo = full_period ? 0.0 : spec.region_min.x + r;
    const double x_hi = full_period ? lx : spec.region_max.x - r;
    const double y_lo = spec.region_min.y + r, y_hi = spec.region_max.y - r;
    if (x_hi <= x_lo || y_hi <= y_lo)
      throw SceneError(indexed(base, group, "region_max"),
                       "the region (region_min to region_max) is smaller than a disk of "
                       "diameter " +
                           short_number(2 * r));
    bool placed = false;
    for (int attempt = 0; attempt < spec.max_attempts_per_disk && !placed; ++attempt) {
      Vec2 p{rng.uniform(x_lo, x_hi), rng.uniform(y_lo, y_hi)};
      if (periodic) p.x -= lx * std::floor(p.x / lx);
      if (!grid.fits(p, r)) continue;
      bool clear_of_walls = true;
      for (const Wall& w : world.walls) clear_of_walls &= dot(p - w.point, w.normal) >= r;
      if (!clear_of_walls) continue;
      grid.insert(world.disks.add(p, r, density));
      placed = true;
    }
    if (!placed)
      throw SceneError(
          indexed(base, group, "count"),
          "could place only " + std::to_string(k) + " of " + std::to_string(spec.count) +
              " disks without overlap; " +
              walls_excluding(world.walls, spec).value_or("enlarge the region or lower the count"));
  }
}

/// An overlap above `tolerance` found without listing every pair, when some square cell two
/// largest radii wide holds more disk centres than can lie there without one: the largest overlap
/// among the first of them, or none. The full search lists every pair within reach, and disks
/// piled on one point (a packing written with every position 0) made it n^2 pairs: 22 GB for
/// 20 000 disks. Pigeonhole: centres pairwise at least d = 2 r_min - tolerance apart are the
/// centres of disjoint disks of diameter d inside the cell grown by d / 2 on each side, so at most
/// (h + d)^2 / (pi d^2 / 4) of them lie in a cell of side h; any one more than that, taken from one
/// cell, holds a pair closer than d, whose overlap r_i + r_j - distance exceeds the tolerance.
/// (Direct distances, periodic images aside: an image is never further than the direct one.)
std::optional<OverlapReport> overlap_in_a_crowded_cell(const World& world, double tolerance) {
  const std::size_t n = world.disks.size();
  if (n < 2) return std::nullopt;
  const auto [r_min, r_max] =
      std::minmax_element(world.disks.radius.begin(), world.disks.radius.end());
  const double d = 2.0 * *r_min - tolerance;
  const double h = 2.0 * *r_max;
  if (!(d > 0.0) || !(h > 0.0)) return std::nullopt;
  const double most = (h + d) * (h + d) / (std::numbers::pi * d * d / 4.0);
  if (!(most < 1e6)) return std::nullopt;  // tiny disks beside large ones: no useful bound
  const auto fit = static_cast<std::size_t>(most);
  std::vector<std::pair<std::pair<std::int64_t, std::int64_t>, std::uint32_t>> cells(n);
  // Binned by sorting, not with CellList, whose grid spans the disks' bounding box (a stray disk
  // far away would make it as large). Cells beyond +-1e15 widths (and non-finite positions) are
  // joined into one: a cell crowded only by that join is passed over below.
  const auto cell_of = [h](double x) {
    const double c = std::floor(x / h);
    return std::isfinite(c) ? static_cast<std::int64_t>(std::clamp(c, -1e15, 1e15)) : 0;
  };
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 p = world.disks.position[i];
    cells[i] = {{cell_of(p.x), cell_of(p.y)}, static_cast<std::uint32_t>(i)};
  }
  std::sort(cells.begin(), cells.end());
  for (std::size_t first = 0; first < n;) {
    std::size_t last = first;
    while (last < n && cells[last].first == cells[first].first) ++last;
    if (last - first > fit) {
      OverlapReport worst;
      for (std::size_t a = first; a <= first + fit; ++a)
        for (std::size_t b = a + 1; b <= first + fit; ++b) {
          const std::size_t i = cells[a].second, j = cells[b].second;
          const double overlap = world.disks.radius[i] + world.disks.radius[j] -
                                 length(world.disks.position[i] - world.disks.position[j]);
          if (overlap > worst.overlap) worst = {overlap, i, j};
        }
      if (worst.overlap > tolerance) return worst;
    }
    first = last;
  }
  return std::nullopt;
}

}  // namespace

std::string disk_mass_problem(double density, double radius) {
  const double mass = density * std::numbers::pi * radius * radius;
  const double inertia = 0.5 * mass * radius * radius;
  if (std::isnormal(mass) && std::isnormal(inertia)) return "";
  return "radius " + short_number(radius) + " at density " + short_number(density) +
         " gives a mass of " + short_number(mass) + " and a moment of inertia of " +
         short_number(inertia) + ", outside the range of normal floating-point numbers";
}

std::string body_mass_problem(double mass) {
  if (mass > 0.0 && std::isnormal(mass) && std::isnormal(1.0 / mass)) return "";
  return "must be > 0 with an inverse that is a normal floating-point number (between about "
         "2.2e-308 and 4.5e307), got " +
         short_number(mass);
}

void validate_scene(const SceneDefinition& s) {
  if (s.domain.periodic_x && !(s.domain.length_x > 0.0))
    throw SceneError("domain.length_x", "must be > 0 when domain.periodic_x is true");
  if (!(s.density > 0.0)) throw SceneError("material.density", "must be > 0");
  if (!(s.friction_disk_disk >= 0.0))
    throw SceneError("material.friction_disk_disk", "must be >= 0");
  for (std::size_t i = 0; i < s.walls.size(); ++i) {
    const Wall& w = s.walls[i];
    // The normal is divided by its length: a length whose inverse overflows would make it NaN.
    if (const double n = length(w.normal);
        !(n > 0.0) || !std::isfinite(1.0 / n) || !std::isfinite(n))
      throw SceneError(indexed("walls", i, "normal"),
                       n == 0.0 ? "is zero"
                                : "must have a finite length whose inverse is finite, got length " +
                                      short_number(n));
    // A disk's periodic images meet no wall: one across the period would let them through it.
    if (s.domain.periodic_x && w.normal.x != 0.0)
      throw SceneError(indexed("walls", i, "normal"),
                       "must be along y ([0, 1] or [0, -1]) where x is periodic: a wall across "
                       "the period does not hold the disks' periodic images",
                       "domain.periodic_x");
    if (!(w.friction >= 0.0)) throw SceneError(indexed("walls", i, "friction"), "must be >= 0");
    const bool free = w.mode_x == AxisMode::kFree || w.mode_y == AxisMode::kFree;
    if (const std::string why = body_mass_problem(w.mass); free && !why.empty())
      throw SceneError(indexed("walls", i, "mass"), why + " for a wall free along an axis");
  }
  for (std::size_t i = 0; i < s.disks.size(); ++i) {
    if (!(s.disks[i].radius > 0.0)) throw SceneError(indexed("disks", i, "radius"), "must be > 0");
    if (const std::string why = disk_mass_problem(s.density, s.disks[i].radius); !why.empty())
      throw SceneError(indexed("disks", i, "radius"), why, "material.density");
  }
  double largest_diameter = 0.0;
  for (const DiskSpec& d : s.disks) largest_diameter = std::max(largest_diameter, 2 * d.radius);
  for (std::size_t i = 0; i < s.random_disks.size(); ++i) {
    const RandomDisksSpec& r = s.random_disks[i];
    if (!(r.diameter_min > 0.0))
      throw SceneError(indexed("random_disks", i, "diameter_min"), "must be > 0");
    if (!(r.diameter_max >= r.diameter_min))
      throw SceneError(indexed("random_disks", i, "diameter_max"), "must be >= diameter_min");
    for (const double diameter : {r.diameter_min, r.diameter_max})
      if (const std::string why = disk_mass_problem(s.density, 0.5 * diameter); !why.empty())
        throw SceneError(indexed("random_disks", i,
                                 diameter == r.diameter_min ? "diameter_min" : "diameter_max"),
                         why, "material.density");
    if (!(r.region_max.x > r.region_min.x) || !(r.region_max.y > r.region_min.y))
      throw SceneError(indexed("random_disks", i, "region_max"),
                       "must exceed region_min on both axes");
    if (!std::isfinite(r.region_max.x - r.region_min.x) ||
        !std::isfinite(r.region_max.y - r.region_min.y))
      throw SceneError(indexed("random_disks", i, "region_max"),
                       "the region's width and height must be finite numbers (region_max - "
                       "region_min overflows)");
    largest_diameter = std::max(largest_diameter, r.diameter_max);
  }
  if (s.domain.periodic_x && s.domain.length_x < 3.0 * largest_diameter)
    throw SceneError("domain.length_x", "period " + short_number(s.domain.length_x) +
                                            " is shorter than 3 largest diameters (3 x " +
                                            short_number(largest_diameter) +
                                            "); contacts would be ambiguous");
}

World build_world(const SceneDefinition& s, const std::atomic<bool>* cancel) {
  validate_scene(s);
  World world;
  world.domain = s.domain;
  world.body_force = s.gravity;
  world.friction_disk_disk = s.friction_disk_disk;
  world.walls = s.walls;
  for (Wall& w : world.walls) {
    w.normal = (1.0 / length(w.normal)) * w.normal;
    if (w.mode_x == AxisMode::kFixed) w.velocity.x = 0.0;
    if (w.mode_y == AxisMode::kFixed) w.velocity.y = 0.0;
  }
  for (const DiskSpec& d : s.disks) {
    const std::size_t i = world.disks.add(d.position, d.radius, s.density);
    world.disks.velocity[i] = d.velocity;
    world.disks.omega[i] = d.omega;
  }
  wrap_positions(world);
  const std::optional<OverlapReport> crowded =
      overlap_in_a_crowded_cell(world, s.overlap_tolerance);
  const OverlapReport given = crowded ? *crowded : largest_overlap(world);
  if (given.overlap > s.overlap_tolerance) {
    const std::size_t n = world.disks.size();
    auto name = [&](std::size_t b) {
      return b < n ? "disk " + std::to_string(b) : "wall '" + world.walls[b - n].name + "'";
    };
    throw SceneError("disks", name(given.body_a) + " and " + name(given.body_b) + " overlap by " +
                                  short_number(given.overlap) + " (tolerance " +
                                  short_number(s.overlap_tolerance) + ")");
  }
  for (std::size_t g = 0; g < s.random_disks.size(); ++g)
    place_random(world, s.random_disks[g], g, s.density, cancel);
  return world;
}

OverlapReport largest_overlap(const World& world) {
  OverlapReport worst;
  const std::size_t n = world.disks.size();
  if (n == 0) return worst;
  ContactDetector detector;
  std::vector<Contact> candidates;
  detector.detect(world, 0.0, candidates);
  for (const Contact& c : candidates) {
    const double overlap = current_overlap(world, c);
    if (overlap > worst.overlap)
      worst = {overlap, static_cast<std::size_t>(c.key.body_a),
               static_cast<std::size_t>(c.key.body_b)};
  }
  return worst;
}

}  // namespace cdshear
