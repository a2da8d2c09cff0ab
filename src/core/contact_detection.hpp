// Candidate contacts: every disk pair and disk-wall pair whose gap is below a margin. The list
// comes out sorted by ContactKey, so the impulses of contacts that persist from the previous step
// are carried over (warm start) by one merge.
//
// Disk pairs come from a neighbour (Verlet) list: the pairs whose gap was below margin + skin
// when the list was built (with a cell list). While no disk has moved more than
// (margin_built + skin - margin) / 2 since, every pair now closer than the margin is in it
// (|delta_now| >= |delta_built| - 2 max displacement), so a step only measures the listed pairs;
// otherwise the list is built again. The candidates are exactly those of a cell-list search at
// every step, in the same order, with the same arithmetic: the skin changes the cost, never the
// result.
#pragma once

#include <cstdint>
#include <vector>

#include "cell_list.hpp"
#include "contact.hpp"
#include "world.hpp"

namespace cdshear {

class ContactDetector {
 public:
  /// Replaces `contacts` with the candidates of `world` (gap < margin [length]), keeping the
  /// impulses of candidates that were already in `contacts` (same key). Up to `threads` OpenMP
  /// threads share the disks (at least kMinDisksPerThread each): each lists the candidates of a
  /// run of consecutive disks, and the runs are joined in disk order, so the list is the same,
  /// bit for bit, on any number of threads.
  void detect(const World& world, double margin, std::vector<Contact>& contacts, int threads = 1);

  /// Disks per thread below which detection uses fewer threads: a parallel region costs a few
  /// microseconds, listing the candidates of a disk about 0.1.
  static constexpr std::size_t kMinDisksPerThread = 1000;

  /// Extra reach of the neighbour list beyond the margin, as a share of the largest diameter.
  /// 0.1: in a shear run at the default time step (wall displacement 0.002 d per step) the list
  /// is rebuilt after 25 steps or more (no disk moves faster than the wall); larger skins list
  /// more pairs per step.
  static constexpr double kSkinPerDiameter = 0.1;

  /// Times the neighbour list was built (for tests and benchmarks).
  std::uint64_t neighbour_builds() const { return builds_; }

 private:
  /// True when the neighbour list holds every pair with gap < margin in `world` (see above).
  bool neighbours_cover(const World& world, double margin) const;
  /// Builds the list on `team` threads (the same list on any number).
  void build_neighbours(const World& world, double margin, int team);
  /// Appends the neighbours j > i of disks [first, last) within `reach` to `out` (ascending for
  /// each i) and stores each disk's count in start_[i + 1].
  void list_neighbours(const World& world, double reach, std::size_t first, std::size_t last,
                       std::vector<std::int32_t>& out);
  /// Appends the candidates of disks [first, last) to `out`, in key order.
  void list_candidates(const World& world, double margin, std::size_t first, std::size_t last,
                       std::vector<Contact>& out) const;

  CellList cells_;
  std::vector<Contact> fresh_;
  std::vector<std::vector<Contact>> parts_;  // one per thread: the candidates of its disks
  std::vector<std::size_t> part_offset_;     // where each thread's part goes in the joined list
  // Neighbour list, CSR: the partners j > i of disk i are neighbours_[start_[i]..start_[i+1]),
  // ascending.
  std::vector<std::int32_t> neighbours_;
  std::vector<std::size_t> start_;
  std::vector<std::vector<std::int32_t>> parts_neighbours_;  // one per thread: its disks' list
  // What the list was built for: positions and radii of the disks, margin + skin, the domain.
  std::vector<Vec2> built_position_;
  std::vector<double> built_radius_;
  double built_reach_ = -1.0;  // margin + skin [length]; < 0: no list yet
  double built_length_x_ = 0.0;
  bool built_periodic_ = false;
  std::uint64_t builds_ = 0;
};

/// Copies the impulses of the contacts of `previous` (sorted by key) onto those of `fresh` (a
/// run of keys in ascending order) that have the same key: the warm start.
void carry_impulses(const std::vector<Contact>& previous, std::vector<Contact>& fresh);

/// Signed gap between disk i and wall w (negative when overlapping).
double wall_gap(const World& world, std::size_t i, const Wall& w);

}  // namespace cdshear
