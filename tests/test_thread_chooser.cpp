// ThreadChooser (src/app/thread_chooser.hpp): the thread count of a run's steps, chosen by the
// durations it is given. Durations here are synthetic: the chooser's logic, not the machine.
#include <gtest/gtest.h>

#include <vector>

#include "thread_chooser.hpp"

namespace cdshear {
namespace {

/// Steps `steps` times with step durations given by `seconds(threads, step)`; the thread counts
/// used, step by step.
template <class Seconds>
std::vector<int> drive(ThreadChooser& chooser, int steps, const Seconds& seconds) {
  std::vector<int> used;
  for (int k = 0; k < steps; ++k) {
    used.push_back(chooser.threads());
    chooser.after_step(seconds(chooser.threads(), k));
  }
  return used;
}

TEST(ThreadChooser, KeepsTheFasterCountAfterAlternatingTrials) {
  ThreadChooser faster_alone(2, 5, 1000);
  const std::vector<int> a =
      drive(faster_alone, 60, [](int threads, int) { return threads == 1 ? 1.0 : 1.2; });
  // Trial: 5 on one, 5 on two, 5 on one, 5 on two; then one thread.
  EXPECT_EQ(a[0], 1);
  EXPECT_EQ(a[5], 2);
  EXPECT_EQ(a[10], 1);
  EXPECT_EQ(a[15], 2);
  for (int k = 20; k < 60; ++k) EXPECT_EQ(a[k], 1) << "step " << k;
  EXPECT_DOUBLE_EQ(faster_alone.seconds_per_step(1), 1.0);
  EXPECT_DOUBLE_EQ(faster_alone.seconds_per_step(2), 1.2);

  ThreadChooser faster_together(4, 5, 1000);
  const std::vector<int> b =
      drive(faster_together, 60, [](int threads, int) { return threads == 1 ? 1.0 : 0.6; });
  for (int k = 20; k < 60; ++k) EXPECT_EQ(b[k], 4) << "step " << k;
}

TEST(ThreadChooser, TiesGoToOneThreadAndOneThreadNeverTries) {
  ThreadChooser tie(2, 3, 1000);
  const std::vector<int> a = drive(tie, 30, [](int, int) { return 1.0; });
  for (int k = 12; k < 30; ++k) EXPECT_EQ(a[k], 1);
  ThreadChooser one(1, 3, 10);
  const std::vector<int> b = drive(one, 50, [](int, int) { return 1.0; });
  for (const int t : b) EXPECT_EQ(t, 1);
}

TEST(ThreadChooser, MeasuresAgainAndFollowsAChange) {
  // Two threads pay until step 100, then one thread does (the packing or the machine changed).
  ThreadChooser chooser(2, 5, 50);
  const std::vector<int> used = drive(chooser, 200, [](int threads, int step) {
    const bool two_pay = step < 100;
    return (threads == 2) == two_pay ? 1.0 : 1.5;
  });
  EXPECT_EQ(used[30], 2);   // first choice: two
  EXPECT_EQ(used[199], 1);  // after the change, a later trial chose one
}

TEST(ThreadChooser, MeasuresAgainAtOnceWhenAllThreadsFallBehindOneThreadsSpeed) {
  // Two threads pay until step 300, then run at 1.2 times one thread's time (the processors moved
  // apart); the periodic recheck (every 100000 steps) is far off: the watch must see it.
  ThreadChooser chooser(2, 5, 100000);
  const auto seconds = [](int threads, int step) {
    if (threads == 1) return 1.0;
    return step < 300 ? 0.6 : 1.2;
  };
  const std::vector<int> used = drive(chooser, 400, seconds);
  EXPECT_EQ(used[299], 2);
  EXPECT_EQ(chooser.trials(), 2);
  EXPECT_EQ(chooser.watch_trials(), 1);
  // The watch block that holds step 300 ends at step 309 (blocks of 10 from step 20); the trial
  // then takes steps 310 to 329, and one thread every step after it.
  for (int k = 330; k < 400; ++k) EXPECT_EQ(used[k], 1) << "step " << k;
  EXPECT_DOUBLE_EQ(chooser.seconds_per_step(2), 1.2);

  // Two threads a little faster than one, with steps that vary: no watch trial.
  ThreadChooser steady(2, 5, 100000);
  drive(steady, 2000, [](int threads, int step) {
    const double wobble = 1.0 + 0.05 * ((step % 7) - 3) / 3.0;  // +-5%
    return (threads == 1 ? 1.0 : 0.9) * wobble;
  });
  EXPECT_EQ(steady.trials(), 1);
  EXPECT_EQ(steady.watch_trials(), 0);
}

TEST(ThreadChooser, WatchesNothingOnOneThread) {
  // One thread chosen; from step 100 its steps take longer and two threads would be faster, but
  // only the periodic recheck finds that out: one thread's speed says nothing of two threads'.
  ThreadChooser chooser(2, 5, 200);
  const std::vector<int> used = drive(chooser, 400, [](int threads, int step) {
    if (threads == 1) return step < 100 ? 1.0 : 1.3;
    return step < 100 ? 1.5 : 0.5;
  });
  for (int k = 20; k < 220; ++k) EXPECT_EQ(used[k], 1) << "step " << k;
  EXPECT_EQ(chooser.watch_trials(), 0);
  EXPECT_EQ(used[399], 2);  // the recheck after 200 steps on one thread
}

}  // namespace
}  // namespace cdshear
