#include "thread_chooser.hpp"

#include <algorithm>

namespace cdshear {

ThreadChooser::ThreadChooser(int most, std::uint64_t trial_steps, std::uint64_t recheck_steps)
    : most_(std::max(most, 1)),
      trial_steps_(std::max<std::uint64_t>(trial_steps, 1)),
      recheck_steps_(recheck_steps) {
  if (most_ > 1) start_trial();
}

void ThreadChooser::start_trial() {
  ++trials_;
  trying_ = true;
  block_ = 0;
  in_block_ = 0;
  sum_one_ = sum_most_ = 0.0;
  current_ = 1;  // blocks alternate: one, most, one, most
}

bool ThreadChooser::after_step(double seconds) {
  if (most_ == 1) return false;
  if (!trying_) {
    if (current_ == most_ && watch(seconds)) {
      ++watch_trials_;
      start_trial();
    } else if (recheck_steps_ > 0 && ++since_choice_ >= recheck_steps_) {
      start_trial();
    }
    return false;
  }
  (current_ == 1 ? sum_one_ : sum_most_) += seconds;
  if (++in_block_ < trial_steps_) return false;
  in_block_ = 0;
  if (++block_ < kBlocks) {
    current_ = block_ % 2 == 0 ? 1 : most_;
    return false;
  }
  const double steps = static_cast<double>(trial_steps_) * (kBlocks / 2);
  last_one_ = sum_one_ / steps;
  last_most_ = sum_most_ / steps;
  current_ = last_most_ < last_one_ ? most_ : 1;
  trying_ = false;
  since_choice_ = 0;
  watched_ = 0;
  sum_watched_ = 0.0;
  return true;
}

bool ThreadChooser::watch(double seconds) {
  sum_watched_ += seconds;
  const std::uint64_t block = 2 * trial_steps_;
  if (++watched_ < block) return false;
  const double mean = sum_watched_ / static_cast<double>(block);
  watched_ = 0;
  sum_watched_ = 0.0;
  return mean > last_one_;
}

}  // namespace cdshear
