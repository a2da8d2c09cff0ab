#include "cell_list.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cdshear {

void CellList::build(const World& world, double min_cell_size) {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  periodic_ = world.domain.periodic_x;
  lx_ = world.domain.length_x;

  double xmin = std::numeric_limits<double>::max(), xmax = -xmin;
  double ymin = xmin, ymax = -xmin;
  for (std::size_t i = 0; i < n; ++i) {
    xmin = std::min(xmin, d.position[i].x);
    xmax = std::max(xmax, d.position[i].x);
    ymin = std::min(ymin, d.position[i].y);
    ymax = std::max(ymax, d.position[i].y);
  }
  if (n == 0) xmin = xmax = ymin = ymax = 0.0;
  if (periodic_) {
    x0_ = 0.0;
    nx_ = std::max(1, static_cast<int>(std::floor(lx_ / min_cell_size)));
    cell_w_ = lx_ / nx_;
  } else {
    x0_ = xmin;
    nx_ = std::max(1, static_cast<int>(std::floor((xmax - xmin) / min_cell_size)) + 1);
    cell_w_ = min_cell_size;
  }
  y0_ = ymin;
  ny_ = std::max(1, static_cast<int>(std::floor((ymax - ymin) / min_cell_size)) + 1);
  cell_h_ = min_cell_size;

  // Counting sort of disks into cells; disks keep ascending order inside a cell.
  cell_start_.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
  disk_cell_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    int cx, cy;
    disk_cell_[i] = cell_of(d.position[i], &cx, &cy);
    ++cell_start_[disk_cell_[i] + 1];
  }
  for (std::size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  items_.resize(n);
  std::vector<std::int32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < n; ++i) items_[fill[disk_cell_[i]]++] = static_cast<std::int32_t>(i);
}

int CellList::cell_of(Vec2 p, int* cx, int* cy) const {
  *cx = std::clamp(static_cast<int>(std::floor((p.x - x0_) / cell_w_)), 0, nx_ - 1);
  *cy = std::clamp(static_cast<int>(std::floor((p.y - y0_) / cell_h_)), 0, ny_ - 1);
  return *cy * nx_ + *cx;
}

}  // namespace cdshear
