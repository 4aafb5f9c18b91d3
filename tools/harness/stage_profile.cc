#include "tools/harness/stage_profile.h"

#include <utility>

namespace turbid {

void StageProfile::Add(const std::string& stage, double ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& e = entries_[stage];
  e.ms += ms;
  ++e.calls;
}

std::map<std::string, StageProfile::Entry> StageProfile::Snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_;
}

ScopedStage::ScopedStage(StageProfile* profile, std::string stage)
    : profile_(profile), stage_(std::move(stage)) {
  if (profile_ != nullptr) start_ = std::chrono::steady_clock::now();
}

ScopedStage::~ScopedStage() {
  if (profile_ == nullptr) return;
  profile_->Add(stage_, std::chrono::duration<double, std::milli>(
                            std::chrono::steady_clock::now() - start_)
                            .count());
}

}  // namespace turbid
