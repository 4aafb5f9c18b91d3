// The sweep's item scheduler: costliest runnable task first, one worker prepares a group while the
// others run tasks of prepared groups, every task handed out exactly once, Stop wakes waiters.
#include "tools/harness/item_scheduler.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

namespace turbid {
namespace {

using Kind = ItemScheduler::Work::Kind;

std::vector<size_t> RunAll(ItemScheduler& scheduler) {
  std::vector<size_t> order;
  for (;;) {
    const ItemScheduler::Work work = scheduler.Next();
    if (work.kind == Kind::kDone) break;
    if (work.kind == Kind::kPrepare) {
      scheduler.Prepared(work.group);
      continue;
    }
    order.push_back(work.task);
  }
  return order;
}

TEST(ItemScheduler, WithoutGroupsOrCostsItIsItemOrder) {
  ItemScheduler scheduler(5, {}, {}, false);
  EXPECT_EQ(RunAll(scheduler), (std::vector<size_t>{0, 1, 2, 3, 4}));
}

TEST(ItemScheduler, CostliestFirstAndTiesInItemOrder) {
  const std::vector<double> cost = {1, 5, 1, 5, 3};
  ItemScheduler scheduler(cost.size(), {}, [&](size_t k) { return cost[k]; }, false);
  EXPECT_EQ(RunAll(scheduler), (std::vector<size_t>{1, 3, 4, 0, 2}));
}

TEST(ItemScheduler, GroupsArePreparedCostliestEstimateFirstAndCostsAreAskedAgain) {
  // Tasks 0-2 in group 0 (estimate unknown: 0), tasks 3-4 in group 1 (estimate 10). Once
  // prepared, group 0's tasks turn out to cost 20 and group 1's 10.
  const std::vector<int> group = {0, 0, 0, 1, 1};
  bool prepared[2] = {false, false};
  ItemScheduler scheduler(
      group.size(), [&](size_t k) { return group[k]; },
      [&](size_t k) {
        const int g = group[k];
        if (!prepared[g]) return g == 1 ? 10.0 : 0.0;
        return g == 0 ? 20.0 + static_cast<double>(k) : 10.0;
      },
      true);
  // Two workers at the start: both groups are handed out to prepare, the costlier estimate first.
  const ItemScheduler::Work first = scheduler.Next();
  ASSERT_EQ(first.kind, Kind::kPrepare);
  EXPECT_EQ(first.group, 1);
  const ItemScheduler::Work second = scheduler.Next();
  ASSERT_EQ(second.kind, Kind::kPrepare);
  EXPECT_EQ(second.group, 0);
  // Group 1 is ready first: its tasks run while group 0 is still being prepared.
  prepared[1] = true;
  scheduler.Prepared(1);
  ItemScheduler::Work work = scheduler.Next();
  ASSERT_EQ(work.kind, Kind::kRun);
  EXPECT_EQ(work.task, 3u);
  EXPECT_EQ(work.group, 1);
  // Group 0 is ready: its costlier tasks (asked again now) come before task 4, costliest first.
  prepared[0] = true;
  scheduler.Prepared(0);
  std::vector<size_t> rest;
  while ((work = scheduler.Next()).kind == Kind::kRun) rest.push_back(work.task);
  EXPECT_EQ(work.kind, Kind::kDone);
  EXPECT_EQ(rest, (std::vector<size_t>{2, 1, 0, 4}));
}

TEST(ItemScheduler, AWorkerWaitsOnlyWhenEveryRemainingTaskNeedsAGroupBeingPrepared) {
  ItemScheduler scheduler(2, [](size_t) { return 0; }, {}, true);
  const ItemScheduler::Work prepare = scheduler.Next();
  ASSERT_EQ(prepare.kind, Kind::kPrepare);
  std::atomic<bool> got{false};
  size_t task = 99;
  std::thread waiter([&] {
    const ItemScheduler::Work work = scheduler.Next();
    EXPECT_EQ(work.kind, Kind::kRun);
    task = work.task;
    got = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(got.load()) << "the waiter must block while the group is being prepared";
  scheduler.Prepared(prepare.group);
  waiter.join();
  EXPECT_TRUE(got.load());
  EXPECT_EQ(task, 0u);
}

TEST(ItemScheduler, StopWakesAWaitingWorker) {
  ItemScheduler scheduler(3, [](size_t) { return 0; }, {}, true);
  ASSERT_EQ(scheduler.Next().kind, Kind::kPrepare);
  std::thread waiter([&] { EXPECT_EQ(scheduler.Next().kind, Kind::kDone); });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  scheduler.Stop();
  waiter.join();
  EXPECT_EQ(scheduler.Next().kind, Kind::kDone);
}

TEST(ItemScheduler, PreparedTwiceOrUnhandedIsALogicError) {
  ItemScheduler scheduler(1, [](size_t) { return 0; }, {}, true);
  EXPECT_THROW(scheduler.Prepared(0), std::logic_error);
  ASSERT_EQ(scheduler.Next().kind, Kind::kPrepare);
  scheduler.Prepared(0);
  EXPECT_THROW(scheduler.Prepared(0), std::logic_error);
  EXPECT_THROW(ItemScheduler(1, [](size_t) { return -1; }, {}, true), std::invalid_argument);
}

TEST(ItemScheduler, ManyWorkersGetEveryTaskExactlyOnceAfterItsGroupIsPrepared) {
  std::mt19937 rng(7);
  const size_t count = 500;
  std::vector<int> group(count);
  std::vector<double> cost(count);
  for (size_t k = 0; k < count; ++k) {
    group[k] = static_cast<int>(rng() % 17);
    cost[k] = static_cast<double>(rng() % 5);
  }
  ItemScheduler scheduler(
      count, [&](size_t k) { return group[k]; }, [&](size_t k) { return cost[k]; }, true);
  std::vector<std::atomic<int>> runs(count);
  std::vector<std::atomic<bool>> ready(17);
  std::atomic<int> prepares{0}, early{0};
  std::vector<std::thread> workers;
  for (int t = 0; t < 4; ++t) {
    workers.emplace_back([&] {
      for (;;) {
        const ItemScheduler::Work work = scheduler.Next();
        if (work.kind == Kind::kDone) return;
        if (work.kind == Kind::kPrepare) {
          ++prepares;
          std::this_thread::sleep_for(std::chrono::microseconds(200));
          ready[static_cast<size_t>(work.group)] = true;
          scheduler.Prepared(work.group);
          continue;
        }
        if (!ready[static_cast<size_t>(group[work.task])].load()) ++early;
        ++runs[work.task];
      }
    });
  }
  for (std::thread& w : workers) w.join();
  EXPECT_EQ(prepares.load(), 17);
  EXPECT_EQ(early.load(), 0);
  for (size_t k = 0; k < count; ++k) EXPECT_EQ(runs[k].load(), 1) << "task " << k;
}

}  // namespace
}  // namespace turbid
