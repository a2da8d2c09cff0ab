// Uniform-grid cell list over disk centres, honouring the periodic x boundary. Used to find
// candidate contacts in O(n) instead of looking at all pairs.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "world.hpp"

namespace cdshear {

class CellList {
 public:
  /// Bins the disks of `world` into square-ish cells of side >= `min_cell_size`.
  void build(const World& world, double min_cell_size);

  /// Calls visit(j, image_j, delta) for every disk j > i in the 3x3 neighbourhood of i's cell,
  /// once per distinct (j, image): delta = centre_j + image_j L_x e_x - centre_i is the
  /// minimum-image separation. Callers filter by distance.
  template <class Visit>
  void for_each_neighbour_above(const World& world, std::size_t i, Visit&& visit) const;

  int cells_x() const { return nx_; }
  int cells_y() const { return ny_; }

 private:
  int cell_of(Vec2 p, int* cx, int* cy) const;

  double x0_ = 0.0, y0_ = 0.0;  // grid origin
  double cell_w_ = 1.0, cell_h_ = 1.0;
  int nx_ = 1, ny_ = 1;
  bool periodic_ = false;
  double lx_ = 0.0;
  std::vector<std::int32_t> cell_start_;  // size nx*ny+1, offsets into items_
  std::vector<std::int32_t> items_;       // disk indices, grouped by cell, ascending within
  std::vector<std::int32_t> disk_cell_;   // cell of each disk
};

template <class Visit>
void CellList::for_each_neighbour_above(const World& world, std::size_t i, Visit&& visit) const {
  const int c = disk_cell_[i];
  const int cx = c % nx_, cy = c / nx_;
  const Vec2 pi = world.disks.position[i];
  int seen_x[3];
  int n_seen_x = 0;
  for (int dx = -1; dx <= 1; ++dx) {
    int x = cx + dx;
    if (periodic_) {
      x = (x + nx_) % nx_;
    } else if (x < 0 || x >= nx_) {
      continue;
    }
    bool dup = false;  // with fewer than 3 columns, neighbour columns repeat
    for (int k = 0; k < n_seen_x; ++k) dup = dup || seen_x[k] == x;
    if (dup) continue;
    seen_x[n_seen_x++] = x;
    for (int dy = -1; dy <= 1; ++dy) {
      const int y = cy + dy;
      if (y < 0 || y >= ny_) continue;
      const int cell = y * nx_ + x;
      for (int k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
        const std::int32_t j = items_[k];
        if (static_cast<std::size_t>(j) <= i) continue;
        Vec2 delta = world.disks.position[j] - pi;
        const double shift = world.domain.periods_in(delta.x);
        delta.x -= shift * lx_;
        visit(j, -static_cast<std::int32_t>(shift), delta);
      }
    }
  }
}

}  // namespace cdshear
