// How many threads a run's steps get, chosen by measured speed.
//
// A step's result is the same on any number of threads (nlgs_solver.hpp, "coloured"), so the
// thread count changes only the time a step takes, and that is not known in advance: on a
// machine whose two processors share one core, or for a cell of a few thousand disks, the
// barriers of every sweep phase can cost more than the work two threads share: system 5 took 1.2
// times as long on two threads as on one on one 2-core virtual machine, 0.67 times on another
// (docs/performance.md, "Threads"). So a run given
// more than one thread times its steps on both counts, in alternating blocks (one thread, all,
// one, all: a slow drift of the step's cost weighs on both alike), keeps the faster, and
// measures again every `recheck_steps` steps, as the packing and the machine's load change.
// Ties go to one thread. While it runs on all threads it also watches their speed: when the mean
// over a watch block (two trial blocks' steps) is slower than one thread was at the last trial, it
// measures again at once: on a 2-core virtual machine the host may move the two processors
// apart in the middle of a run, and two threads may then be slower than one (docs/performance.md,
// "Where the host places the two processors"). One thread runs as fast wherever it is: nothing is
// watched there. Plain logic on the durations it is given: the run loop times the steps.
#pragma once

#include <cstdint>

namespace cdshear {

class ThreadChooser {
 public:
  /// `most` threads at most (1: always one, no trial); blocks of `trial_steps` steps.
  explicit ThreadChooser(int most, std::uint64_t trial_steps = 25,
                         std::uint64_t recheck_steps = 20000);

  /// Threads for the next step.
  int threads() const { return current_; }

  /// Records the duration of the step just taken on threads(); true when it ended a trial (a
  /// new choice: threads(), seconds_per_step(1) and seconds_per_step(most) tell it).
  bool after_step(double seconds);

  /// Mean seconds per step of the last trial on `threads` (1 or most; 0 before any trial).
  double seconds_per_step(int threads) const { return threads == 1 ? last_one_ : last_most_; }
  int most() const { return most_; }
  /// Trials so far, and those started by the watch on all threads (not by recheck_steps).
  int trials() const { return trials_; }
  int watch_trials() const { return watch_trials_; }

 private:
  static constexpr int kBlocks = 4;  // one, most, one, most
  int most_;
  std::uint64_t trial_steps_, recheck_steps_;
  int current_ = 1;
  bool trying_ = false;
  int block_ = 0;               // block of the trial under way
  std::uint64_t in_block_ = 0;  // steps taken in it
  std::uint64_t since_choice_ = 0;
  double sum_one_ = 0.0, sum_most_ = 0.0;
  double last_one_ = 0.0, last_most_ = 0.0;
  std::uint64_t watched_ = 0;  // steps of the watch block under way (on all threads)
  double sum_watched_ = 0.0;
  int trials_ = 0, watch_trials_ = 0;

  /// After a step on all threads outside a trial: true when its watch block ended slower than
  /// one thread's last measured speed.
  bool watch(double seconds);

  void start_trial();
};

}  // namespace cdshear
