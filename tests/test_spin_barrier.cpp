// SpinBarrier (src/core/threads.hpp): the barrier the solver's threads meet at. Every thread
// must see what every other wrote before the barrier, whether it waited spinning or asleep.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "threads.hpp"

namespace cdshear {
namespace {

/// Runs body(thread) on `team` std::threads and joins them; aborts the test binary if they
/// have not all returned within a minute (a barrier that lost a wake-up would hang forever).
template <class Body>
void run_team(unsigned team, const Body& body) {
  std::atomic<bool> done{false};
  std::thread watchdog([&done] {
    for (int k = 0; k < 600 && !done.load(); ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (!done.load()) {
      std::fprintf(stderr, "SpinBarrier: the team did not finish within a minute\n");
      std::abort();
    }
  });
  std::vector<std::thread> threads;
  for (unsigned t = 0; t < team; ++t) threads.emplace_back([&body, t] { body(t); });
  for (std::thread& t : threads) t.join();
  done.store(true);
  watchdog.join();
}

TEST(SpinBarrier, NoThreadLeavesBeforeEveryThreadArrived) {
  // Each round every thread writes the round into its own slot, meets the others, and reads
  // every slot: a thread that left early would read a slot from the round before. Four threads
  // on however many processors: those beyond the processors make the others wait long enough
  // to sleep on the barrier as well as spin.
  constexpr unsigned kTeam = 4;
  constexpr int kRounds = 3000;
  SpinBarrier barrier;
  std::vector<std::atomic<int>> slot(kTeam);
  std::atomic<int> stale{0};
  run_team(kTeam, [&](unsigned t) {
    for (int round = 1; round <= kRounds; ++round) {
      slot[t].store(round, std::memory_order_relaxed);
      barrier.wait(kTeam);
      for (unsigned u = 0; u < kTeam; ++u)
        if (slot[u].load(std::memory_order_relaxed) != round) stale.fetch_add(1);
      barrier.wait(kTeam);  // nobody writes the next round before all have read this one
    }
  });
  EXPECT_EQ(stale.load(), 0);
}

TEST(SpinBarrier, WakesAThreadThatFellAsleepOnIt) {
  // One thread arrives 5 ms late every round, far beyond the others' spinning (kSpins pauses,
  // about half a millisecond): they sleep on the barrier and must be woken, each round.
  constexpr unsigned kTeam = 3;
  constexpr int kRounds = 20;
  SpinBarrier barrier;
  std::atomic<int> arrivals{0};
  std::atomic<int> early_leaves{0};
  run_team(kTeam, [&](unsigned t) {
    for (int round = 1; round <= kRounds; ++round) {
      if (t == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
      arrivals.fetch_add(1);
      barrier.wait(kTeam);
      if (arrivals.load() < static_cast<int>(kTeam) * round) early_leaves.fetch_add(1);
      barrier.wait(kTeam);
    }
  });
  EXPECT_EQ(early_leaves.load(), 0);
  EXPECT_EQ(arrivals.load(), static_cast<int>(kTeam) * kRounds);
}

}  // namespace
}  // namespace cdshear
