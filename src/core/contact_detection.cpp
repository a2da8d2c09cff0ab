#include "contact_detection.hpp"

#include <algorithm>
#include <cmath>

namespace cdshear {

double wall_gap(const World& world, std::size_t i, const Wall& w) {
  return dot(world.disks.position[i] - w.point, w.normal) - world.disks.radius[i];
}

void ContactDetector::detect(const World& world, double margin, std::vector<Contact>& contacts) {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  const double reach = 2.0 * max_radius(world) + margin;
  cells_.build(world, std::max(reach, 1e-12));
  fresh_.clear();

  for (std::size_t i = 0; i < n; ++i) {
    // Disk-disk candidates with j > i, in ascending (j, image) order.
    around_.clear();
    cells_.for_each_neighbour_above(world, i, [&](std::int32_t j, std::int32_t image, Vec2 delta) {
      const double cutoff = d.radius[i] + d.radius[j] + margin;
      if (length_squared(delta) < cutoff * cutoff) around_.push_back({j, image, delta});
    });
    std::sort(around_.begin(), around_.end(), [](const Candidate& a, const Candidate& b) {
      return a.j != b.j ? a.j < b.j : a.image < b.image;
    });
    for (const Candidate& c : around_) {
      const double dist = length(c.delta);
      Contact k;
      k.key = {static_cast<std::int32_t>(i), c.j, c.image};
      // Normal from b (= j) to a (= i): -delta / |delta|.
      k.normal = dist > 0.0 ? (-1.0 / dist) * c.delta : Vec2{0.0, 1.0};
      k.tangent = perp(k.normal);
      k.gap = dist - d.radius[i] - d.radius[c.j];
      // One contact point for both disks, in the middle of the gap (or overlap): then R on a and
      // -R on b act at the same point and conserve angular momentum. Taking each disk's own
      // surface point (-r_a n and +r_b n, which are `gap` apart) would add a spurious couple
      // gap * R_t whenever a contact carries friction before it has closed.
      const double half_gap = 0.5 * k.gap;
      k.arm_a = -(d.radius[i] + half_gap) * k.normal;
      k.lever_a = -(d.radius[i] + half_gap);
      k.lever_b = -(d.radius[c.j] + half_gap);
      k.friction = world.friction_disk_disk;
      fresh_.push_back(k);
    }
    // Disk-wall candidates, walls numbered after the disks.
    for (std::size_t w = 0; w < world.walls.size(); ++w) {
      const Wall& wall = world.walls[w];
      const double gap = wall_gap(world, i, wall);
      if (gap >= margin) continue;
      Contact k;
      k.key = {static_cast<std::int32_t>(i), static_cast<std::int32_t>(n + w), 0};
      k.normal = wall.normal;
      k.tangent = perp(wall.normal);
      k.arm_a = -d.radius[i] * k.normal;
      k.lever_a = -d.radius[i];
      k.lever_b = 0.0;
      k.gap = gap;
      k.friction = wall.friction;
      fresh_.push_back(k);
    }
  }

  // Warm start: both lists are sorted by key; carry impulses over.
  std::size_t p = 0;
  for (Contact& k : fresh_) {
    while (p < contacts.size() && contacts[p].key < k.key) ++p;
    if (p < contacts.size() && contacts[p].key == k.key) {
      k.impulse_n = contacts[p].impulse_n;
      k.impulse_t = contacts[p].impulse_t;
    }
  }
  contacts.swap(fresh_);
}

}  // namespace cdshear
