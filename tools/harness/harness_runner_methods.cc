// HarnessRunner's method runs (in process and external commands) and its batches (Python
// callables and command batches), split from harness_runner.cc.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/safe_name.h"
#include "enhancer/registry.h"
#include "metrics/frontend.h"
#include "metrics/registry.h"
#include "scenes/builtin.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "scenes/sequence.h"
#include "simulator/render.h"
#include "tools/harness/external_method.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/harness_runner_internal.h"
#include "tools/harness/sweep_sequence.h"

namespace turbid {

using runner_internal::Clock;
using runner_internal::ExternalFolderProblem;
using runner_internal::MillisecondsSince;
using runner_internal::NanMetrics;
using runner_internal::ProcessFor;
using runner_internal::ReadOutput;
using runner_internal::ResolveAgainst;
using runner_internal::Selected;

namespace fs = std::filesystem;
using nlohmann::json;

std::vector<cv::Mat> HarnessRunner::RunInProcess(const ExperimentMethod& method,
                                                 const std::vector<cv::Mat>& degraded,
                                                 const std::vector<std::string>& ids) const {
  const InProcessMethod& run =
      options_.in_process.at(method.external.at("python").get<std::string>());
  std::vector<cv::Mat> outputs;
  try {
    outputs = run(method.external, degraded, ids);
  } catch (const OutputError& error) {
    throw Error(error.what());  // the method's own write failed: a failure of the method
  }
  if (outputs.size() != degraded.size()) {
    throw Error("returned " + std::to_string(outputs.size()) + " images for " +
                std::to_string(degraded.size()) + " inputs");
  }
  for (size_t k = 0; k < outputs.size(); ++k) {
    outputs[k] = CheckMethodOutput(outputs[k], degraded[k],
                                   degraded.size() > 1 ? "output for " + ids[k] : "");
  }
  return outputs;
}

cv::Mat HarnessRunner::RunExternal(const ExperimentMethod& method, const std::string& id,
                                   const cv::Mat& degraded, double* time_ms) const {
  const nlohmann::json& spec = method.external;
  if (spec.at("kind") == "python") {  // a failed call is timed by Run, as every failed method
    const auto start = Clock::now();
    const std::vector<cv::Mat> out = RunInProcess(method, {degraded}, {id});
    *time_ms = MillisecondsSince(start);
    return out[0];
  }
  if (spec.at("kind") == "results") {
    *time_ms = std::nan("");  // nothing ran
    const std::string pattern = spec.at("results").get<std::string>();
    const std::string written = ExpandCommand(nlohmann::json::array({pattern}), {{"id", id}})[0];
    const std::string path = ResolveAgainst(method.base_dir, written);
    if (!fs::exists(path)) throw Error("missing results file " + written);
    return ReadOutput(path, written, spec.at("encoding").get<std::string>(), degraded);
  }
  const std::string folder = out_dir_ + "/external/" + method.label;
  const std::string work = fs::absolute(folder + "/work-" + id).string();
  if (const std::string link = ExternalFolderProblem(out_dir_, folder); !link.empty()) {
    throw Error(link);
  }
  std::error_code ec;
  fs::remove_all(work, ec);
  fs::create_directories(work + "/in", ec);
  if (!ec) fs::create_directories(work + "/out", ec);
  if (ec) throw OutputError(work, "cannot create the work folder: " + ec.message());
  const std::string input = work + "/in/" + id + InputExtension(spec);
  const std::string output = work + "/out/" + id + OutputExtension(spec);
  WriteMethodInput(input, degraded, spec.at("input"));
  ProcessOptions process = ProcessFor(method);
  process.argv =
      ExpandCommand(spec.at("command"), {{"input", input}, {"output", output}, {"id", id}});
  process.log_path = folder + "/" + id + ".log";
  const ProcessResult ran = RunProcess(process);
  *time_ms = ran.wall_ms;
  const std::string failure = ran.Failure();
  cv::Mat enhanced;
  std::string problem;
  if (!failure.empty()) {
    problem = failure + " (log: external/" + method.label + "/" + id + ".log)";
  } else if (!fs::exists(output)) {
    const std::string other = FindOutputFile(work + "/out", id);
    if (other.empty()) {
      problem = "wrote no output (expected " + id + OutputExtension(spec) + ")";
    } else {
      try {
        enhanced = ReadOutput(other, fs::path(other).filename().string(),
                              spec.at("output").at("encoding").get<std::string>(), degraded);
      } catch (const Error& error) {
        problem = error.what();
      }
    }
  } else {
    try {
      enhanced = ReadOutput(output, fs::path(output).filename().string(),
                            spec.at("output").at("encoding").get<std::string>(), degraded);
    } catch (const Error& error) {
      problem = error.what();
    }
  }
  fs::remove_all(work, ec);
  if (!problem.empty()) throw Error(problem);
  fs::remove(process.log_path, ec);  // logs are kept for failures only
  return enhanced;
}

namespace {

// The row of `label` in an item's result.
MethodResult& RowOf(ItemResult& result, const std::string& label) {
  for (MethodResult& row : result.methods) {
    if (row.label == label) return row;
  }
  throw Error("internal: no row for " + label);
}

}  // namespace

std::vector<size_t> HarnessRunner::BatchMembers(const std::vector<ItemTask>& tasks,
                                                const ExperimentMethod& method) const {
  std::vector<size_t> members;
  std::lock_guard<std::mutex> lock(pending_mutex_);
  for (size_t k = 0; k < tasks.size(); ++k) {
    if (Selected(tasks[k], method.label) && pending_.count(tasks[k].spec->id)) {
      members.push_back(k);
    }
  }
  return members;
}

const HarnessRunner::Pending& HarnessRunner::PendingOf(const std::string& id) const {
  std::lock_guard<std::mutex> lock(pending_mutex_);
  return *pending_.at(id);
}

// A "python" batch method: one call for the batch; outputs are checked and scored per item.
void HarnessRunner::FinishPythonBatch(const ExperimentMethod& method,
                                      const std::vector<ItemTask>& tasks,
                                      const std::vector<size_t>& members,
                                      std::vector<ItemResult>* results) const {
  std::vector<cv::Mat> degraded;
  std::vector<std::string> ids;
  for (size_t k : members) {
    degraded.push_back(PendingOf(tasks[k].spec->id).degraded);
    ids.push_back(tasks[k].spec->id);
  }
  std::vector<cv::Mat> outputs;
  std::string problem;
  const auto start = Clock::now();
  try {
    outputs = RunInProcess(method, degraded, ids);
  } catch (const OutputError&) {
    throw;
  } catch (const std::exception& error) {
    problem = error.what();
  }
  const double share_ms = MillisecondsSince(start) / static_cast<double>(members.size());
  if (options_.profile)
    options_.profile->Add("method " + method.label, share_ms * static_cast<double>(members.size()));
  for (size_t m = 0; m < members.size(); ++m) {
    MethodResult& row = RowOf((*results)[members[m]], method.label);
    row.time_ms = share_ms;
    row.time_is_batch_share = true;
    row.metrics = NanMetrics(metric_names_);
    row.error = problem;
    if (!problem.empty()) continue;
    try {
      const Pending& pending = PendingOf(tasks[members[m]].spec->id);
      Score(ids[m], method.label, outputs[m], pending.target, pending.degraded, &row);
      row.error.clear();
    } catch (const OutputError&) {
      throw;
    } catch (const std::exception& error) {
      row.error = error.what();
      row.metrics = NanMetrics(metric_names_);
    }
  }
}

// A "command" batch method's one process: its inputs written into WORK/in, run on WORK/in and
// WORK/out. Returns the batch's problem ("" when it ran) and each member's share of its time.
std::string HarnessRunner::RunCommandBatch(const ExperimentMethod& method,
                                           const std::vector<ItemTask>& tasks,
                                           const std::vector<size_t>& members,
                                           const std::string& work, const std::string& folder,
                                           double* share_ms) const {
  const nlohmann::json& spec = method.external;
  const std::string log_name = "batch-" + tasks[members.front()].spec->id + ".log";
  std::error_code ec;
  std::string batch_problem = ExternalFolderProblem(out_dir_, folder);
  if (batch_problem.empty()) {
    fs::remove_all(work, ec);
    fs::create_directories(work + "/in", ec);
    if (!ec) fs::create_directories(work + "/out", ec);
    if (ec) throw OutputError(work, "cannot create the work folder: " + ec.message());
  }
  for (size_t k : members) {
    if (!batch_problem.empty()) break;
    try {
      WriteMethodInput(work + "/in/" + tasks[k].spec->id + InputExtension(spec),
                       PendingOf(tasks[k].spec->id).degraded, spec.at("input"));
    } catch (const OutputError&) {
      throw;
    } catch (const Error& error) {
      batch_problem = std::string("cannot write the inputs: ") + error.what();
    }
  }
  *share_ms = 0.0;
  if (!batch_problem.empty()) return batch_problem;
  ProcessOptions process = ProcessFor(method);
  process.argv = ExpandCommand(spec.at("command"),
                               {{"input_dir", work + "/in"}, {"output_dir", work + "/out"}});
  process.log_path = folder + "/" + log_name;
  const ProcessResult ran = RunProcess(process);
  *share_ms = ran.wall_ms / static_cast<double>(members.size());
  if (options_.profile) options_.profile->Add("method " + method.label, ran.wall_ms);
  const std::string failure = ran.Failure();
  if (!failure.empty()) {
    return failure + " (log: external/" + method.label + "/" + log_name + ")";
  }
  fs::remove(process.log_path, ec);  // logs are kept for failures only
  return "";
}

// A "command" batch method: one process for the batch; its outputs are read and scored per item.
void HarnessRunner::FinishCommandBatch(const ExperimentMethod& method,
                                       const std::vector<ItemTask>& tasks,
                                       const std::vector<size_t>& members,
                                       std::vector<ItemResult>* results) const {
  const nlohmann::json& spec = method.external;
  const std::string first_id = tasks[members.front()].spec->id;
  const std::string folder = out_dir_ + "/external/" + method.label;
  const std::string work = fs::absolute(folder + "/work-" + first_id).string();
  double share_ms = 0.0;
  const std::string batch_problem =
      RunCommandBatch(method, tasks, members, work, folder, &share_ms);
  for (size_t k : members) {
    MethodResult& row = RowOf((*results)[k], method.label);
    row.time_ms = share_ms;
    row.time_is_batch_share = true;
    row.metrics = NanMetrics(metric_names_);
    row.error = batch_problem;
    if (!batch_problem.empty()) continue;
    const std::string& id = tasks[k].spec->id;
    try {
      const std::string path = FindOutputFile(work + "/out", id);
      if (path.empty()) throw Error("wrote no output for this item (expected " + id + ".*)");
      const Pending& pending = PendingOf(id);
      const cv::Mat enhanced =
          ReadOutput(path, fs::path(path).filename().string(),
                     spec.at("output").at("encoding").get<std::string>(), pending.degraded);
      Score(id, method.label, enhanced, pending.target, pending.degraded, &row);
      row.error.clear();
    } catch (const OutputError&) {
      throw;
    } catch (const std::exception& error) {
      row.error = error.what();
      row.metrics = NanMetrics(metric_names_);
    }
  }
  std::error_code ec;
  if (ExternalFolderProblem(out_dir_, folder).empty()) fs::remove_all(work, ec);
}

void HarnessRunner::FinishBatch(const std::vector<ItemTask>& tasks,
                                std::vector<ItemResult>* results) const {
  for (const ExperimentMethod& method : experiment_.methods) {
    if (!method.IsBatch()) continue;
    // The items of this batch that wait for this method (rendered, selected).
    const std::vector<size_t> members = BatchMembers(tasks, method);
    if (members.empty()) continue;
    if (method.external.at("kind") == "python") {
      FinishPythonBatch(method, tasks, members, results);
    } else {
      FinishCommandBatch(method, tasks, members, results);
    }
  }
  std::lock_guard<std::mutex> lock(pending_mutex_);
  for (const ItemTask& task : tasks) pending_.erase(task.spec->id);
}

}  // namespace turbid
