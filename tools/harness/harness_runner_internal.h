// Helpers shared by the item runner (harness_runner.cc) and its method runs and batches
// (harness_runner_methods.cc). Internal to tools/harness.
#pragma once

#include <chrono>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "tools/harness/external_method.h"
#include "tools/harness/harness_runner.h"

namespace turbid {

// An item whose batch method has not run yet: its degraded image and what it is scored against.
struct HarnessRunner::Pending {
  cv::Mat degraded;
  ScoreTarget target;
};

namespace runner_internal {

using Clock = std::chrono::steady_clock;

double MillisecondsSince(Clock::time_point start);
// Every metric NaN (a method that failed or did not run).
std::map<std::string, double> NanMetrics(const std::vector<std::string>& names);
// Whether the task runs the method labelled `label` (an empty `only` runs every one).
bool Selected(const ItemTask& task, const std::string& label);
// A path of the experiment file (relative to its folder), made absolute.
std::string ResolveAgainst(const std::string& base_dir, const std::string& path);
// Reads a method's output; errors name the file as `shown` (work folders are deleted).
cv::Mat ReadOutput(const std::string& path, const std::string& shown, const std::string& encoding,
                   const cv::Mat& degraded);
// "" when the external method's folders under OUT are real folders (or absent); otherwise why
// the method cannot run.
std::string ExternalFolderProblem(const std::string& out_dir, const std::string& folder);
// Working directory, environment and timeout of an external command method.
ProcessOptions ProcessFor(const ExperimentMethod& method);

}  // namespace runner_internal
}  // namespace turbid
