// Where a sweep's time goes (`turbid bench --sweep`): thread-safe totals of wall time per stage
// (scene loading, render, each method, each metric, thumbnails, journal, tables), summed over the
// sweep's threads. Off (a null pointer) in ordinary runs.
#ifndef TURBID_TOOLS_STAGE_PROFILE_H_
#define TURBID_TOOLS_STAGE_PROFILE_H_

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

namespace turbid {

class StageProfile {
 public:
  struct Entry {
    double ms = 0.0;     // wall time inside the stage, summed over calls and threads
    int64_t calls = 0;
  };
  void Add(const std::string& stage, double ms);
  std::map<std::string, Entry> Snapshot() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

// Adds the time from construction to destruction to `stage` (nothing when profile is null).
class ScopedStage {
 public:
  ScopedStage(StageProfile* profile, std::string stage);
  ~ScopedStage();
  ScopedStage(const ScopedStage&) = delete;
  ScopedStage& operator=(const ScopedStage&) = delete;

 private:
  StageProfile* profile_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace turbid

#endif  // TURBID_TOOLS_STAGE_PROFILE_H_
