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

}  // namespace
}  // namespace cdshear
