// Hands a sweep's pending items to its worker threads: the most expensive runnable item first, and
// a scene's shared state (the built-in hull takes a second to build) prepared by one worker while
// the others keep working on scenes that are ready, instead of all of them waiting on it.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <vector>

namespace turbid {

class ItemScheduler {
 public:
  // Tasks are 0 .. count - 1. group(k): the group (scene) task k needs prepared before it runs;
  // groups are small non-negative ids. cost(k): its relative cost, asked for every task when the
  // scheduler is built (an estimate: 0 when unknown) and again for a group's tasks once the group
  // is prepared. needs_prepare false: every group counts as prepared from the start.
  ItemScheduler(size_t count, const std::function<int(size_t)>& group,
                std::function<double(size_t)> cost, bool needs_prepare);

  struct Work {
    enum class Kind { kRun, kPrepare, kDone };
    Kind kind = Kind::kDone;
    size_t task = 0;  // kRun
    int group = -1;   // kPrepare (and the group of a kRun task)
  };

  // The next thing a worker should do; blocks only while every remaining task belongs to a group
  // another worker is preparing. Order: the costliest task of a prepared group (ties: the lowest
  // task index); when no prepared group has tasks left, the unprepared group whose costliest
  // estimate is highest (ties: lowest first task) is handed out to prepare. kDone when every
  // task is handed out, or after Stop().
  Work Next();
  // The worker that got kPrepare for `group` has prepared it (successfully or not: a failed
  // preparation is the task runner's to report): its tasks become runnable, ordered by the costs
  // asked again now.
  void Prepared(int group);
  // Every later and every waiting Next() returns kDone.
  void Stop();

 private:
  enum class State { kUnprepared, kPreparing, kPrepared };
  struct Group {
    State state = State::kUnprepared;
    std::vector<size_t> tasks;  // not yet handed out; runnable order once prepared
    size_t head = 0;            // next task of `tasks` to hand out
    double estimate = 0.0;      // highest estimated cost of its tasks (before it is prepared)
  };
  void Order(Group& group) const;

  std::function<double(size_t)> cost_;
  std::vector<double> costs_;
  std::vector<Group> groups_;
  size_t remaining_ = 0;  // tasks not yet handed out
  bool stopped_ = false;
  std::mutex mutex_;
  std::condition_variable ready_;
};

}  // namespace turbid
