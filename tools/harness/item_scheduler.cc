#include "tools/harness/item_scheduler.h"

#include <algorithm>
#include <stdexcept>

namespace turbid {

ItemScheduler::ItemScheduler(size_t count, const std::function<int(size_t)>& group,
                             std::function<double(size_t)> cost, bool needs_prepare)
    : cost_(std::move(cost)), costs_(count, 0.0), remaining_(count) {
  for (size_t k = 0; k < count; ++k) {
    const int g = group ? group(k) : 0;
    if (g < 0) throw std::invalid_argument("ItemScheduler: negative group");
    if (static_cast<size_t>(g) >= groups_.size()) groups_.resize(static_cast<size_t>(g) + 1);
    costs_[k] = cost_ ? cost_(k) : 0.0;
    Group& target = groups_[static_cast<size_t>(g)];
    target.estimate = target.tasks.empty() ? costs_[k] : std::max(target.estimate, costs_[k]);
    target.tasks.push_back(k);
  }
  for (Group& g : groups_) {
    if (!needs_prepare) {
      g.state = State::kPrepared;
      Order(g);
    }
  }
}

void ItemScheduler::Order(Group& group) const {
  // Costliest first; equal costs keep item order, so without costs the sweep runs in item order.
  std::stable_sort(group.tasks.begin() + static_cast<long>(group.head), group.tasks.end(),
                   [&](size_t a, size_t b) { return costs_[a] > costs_[b]; });
}

ItemScheduler::Work ItemScheduler::Next() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    if (stopped_ || remaining_ == 0) return {};
    // The costliest task among the prepared groups.
    Group* best = nullptr;
    int best_id = -1;
    for (size_t g = 0; g < groups_.size(); ++g) {
      Group& candidate = groups_[g];
      if (candidate.state != State::kPrepared || candidate.head == candidate.tasks.size()) continue;
      if (best == nullptr) {
        best = &candidate;
        best_id = static_cast<int>(g);
        continue;
      }
      const size_t a = candidate.tasks[candidate.head], b = best->tasks[best->head];
      if (costs_[a] > costs_[b] || (costs_[a] == costs_[b] && a < b)) {
        best = &candidate;
        best_id = static_cast<int>(g);
      }
    }
    if (best != nullptr) {
      Work work;
      work.kind = Work::Kind::kRun;
      work.task = best->tasks[best->head++];
      work.group = best_id;
      --remaining_;
      return work;
    }
    // Nothing runnable: prepare the unprepared group with the costliest estimate.
    int open = -1;
    for (size_t g = 0; g < groups_.size(); ++g) {
      const Group& candidate = groups_[g];
      if (candidate.state != State::kUnprepared || candidate.tasks.empty()) continue;
      if (open < 0) {
        open = static_cast<int>(g);
        continue;
      }
      const Group& current = groups_[static_cast<size_t>(open)];
      if (candidate.estimate > current.estimate ||
          (candidate.estimate == current.estimate && candidate.tasks[0] < current.tasks[0])) {
        open = static_cast<int>(g);
      }
    }
    if (open >= 0) {
      groups_[static_cast<size_t>(open)].state = State::kPreparing;
      Work work;
      work.kind = Work::Kind::kPrepare;
      work.group = open;
      return work;
    }
    // Every remaining task waits on a group another worker is preparing.
    ready_.wait(lock);
  }
}

void ItemScheduler::Prepared(int group) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Group& g = groups_.at(static_cast<size_t>(group));
    if (g.state != State::kPreparing) throw std::logic_error("ItemScheduler: group not handed out");
    if (cost_) {
      for (size_t k = g.head; k < g.tasks.size(); ++k) costs_[g.tasks[k]] = cost_(g.tasks[k]);
    }
    Order(g);
    g.state = State::kPrepared;
  }
  ready_.notify_all();
}

void ItemScheduler::Stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopped_ = true;
  }
  ready_.notify_all();
}

}  // namespace turbid
