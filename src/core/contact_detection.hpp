// Candidate contacts: every disk pair and disk-wall pair whose gap is below a margin, found with
// a cell list. The list comes out sorted by ContactKey, so the impulses of contacts that persist
// from the previous step are carried over (warm start) by one merge.
#pragma once

#include <vector>

#include "cell_list.hpp"
#include "contact.hpp"
#include "world.hpp"

namespace cdshear {

class ContactDetector {
 public:
  /// Replaces `contacts` with the candidates of `world` (gap < margin [length]), keeping the
  /// impulses of candidates that were already in `contacts` (same key).
  void detect(const World& world, double margin, std::vector<Contact>& contacts);

 private:
  CellList cells_;
  std::vector<Contact> fresh_;
  struct Candidate {
    std::int32_t j, image;
    Vec2 delta;
  };
  std::vector<Candidate> around_;
};

/// Signed gap between disk i and wall w (negative when overlapping).
double wall_gap(const World& world, std::size_t i, const Wall& w);

}  // namespace cdshear
