// The real sweep item: render the scene under the item's parameters, run every method, score each
// result with the requested metrics against the chosen ground truth, save thumbnails. Binds the
// harness to the simulator (simulator/render.h), the enhancer registry and the metrics registry.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "metrics/registry.h"
#include "tools/harness/experiment.h"
#include "tools/harness/stage_profile.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace turbid {

struct RenderResult;
struct Scene;
struct FrameRecord;
class SequenceScorer;

// Name checks and option resolution read from the registries (methods, metrics), the simulator's
// strict RenderOptionsFromJson and the scene loader.
HarnessCatalog RegistryCatalog();

// A method that runs in this process: a Python callable handed to turbid.sweep (experiment
// methods of kind "python", tools/harness/external_method.h). Receives the method's resolved spec
// (batch, encoding) and degraded images as the libraries hold them (float32 linear [0, 1], BGR)
// with their item ids — one for a per-image method, a batch for a batch method — and returns one
// image per input (checked like a file output: CheckMethodOutput). Throws to fail those cells;
// called from the sweep's worker threads.
using InProcessMethod = std::function<std::vector<cv::Mat>(const nlohmann::json& spec,
                                                           const std::vector<cv::Mat>& degraded,
                                                           const std::vector<std::string>& ids)>;

struct HarnessRunnerOptions {
  // Reuse work that does not depend on the swept parameters: each scene is loaded once, one
  // Renderer per scene keeps its caches (range map, light geometry, PSF kernels, blurred J) across
  // items, and no-reference scores of the ground truth are computed once per scene. false loads,
  // renders and scores from scratch for every item (the baseline of benchmarks/harness_bench.cc).
  bool reuse = true;
  // The callables of the experiment's "python" methods, by their key; the runner refuses an
  // experiment whose Python method has none here (the CLI passes none).
  std::map<std::string, InProcessMethod> in_process;
  // Whether the experiment's "command" methods (external programs, with their env) may run:
  // `turbid sweep --allow-commands`, turbid.sweep(..., allow_commands=True). Nothing in an
  // experiment file can grant it; without it the runner refuses an experiment with a command
  // method (CheckCommandsAllowed). `allow_commands_how` names the opt-in in the caller's language.
  bool allow_commands = false;
  std::string allow_commands_how = "--allow-commands";
  // Where the time goes (`turbid bench --sweep`): stage totals over all threads; null = off.
  StageProfile* profile = nullptr;
  bool Check(std::string* why) const;
};

// An experiment file is data unless the user says otherwise: throws Error("<experiment file>:
// method '<label>' runs an external command ...; ... only with <how>") for its first "command"
// method when !allowed. `how` is the opt-in as the caller spells it ("--allow-commands",
// "allow_commands=True"). Call it before any work (the output folder is not touched).
void CheckCommandsAllowed(const Experiment& experiment, bool allowed, const std::string& how);

// What the experiment's "command" methods would run, one line each (for --dry-run): the label,
// per image or batch, the command line and its working directory and environment as JSON strings
// (control characters escaped, so a line cannot pose as another).
std::vector<std::string> DescribeCommands(const Experiment& experiment);

// An item's ground truth as its scores need it: linear, and as the item's camera writes it when
// the experiment scores full-reference metrics in the encoded domain (coded once per item, shared
// by every method's score).
struct ScoreTarget {
  cv::Mat reference;        // linear float32 [0, 1]
  cv::Mat reference_coded;  // EncodeForScoring(reference, camera); empty in the linear domain
  CameraCoding camera;
};

class HarnessRunner {
 public:
  // out_dir receives thumbs/ when the experiment asks for thumbnails.
  HarnessRunner(const Experiment& experiment, std::string out_dir,
                const HarnessRunnerOptions& options = {});
  ~HarnessRunner();
  HarnessRunner(const HarnessRunner&) = delete;
  HarnessRunner& operator=(const HarnessRunner&) = delete;

  // Thread-safe. Method and metric failures are recorded in the result; a scene that cannot be
  // loaded throws (the sweep stops; finished items are kept).
  ItemResult Run(const ItemSpec& item) const;
  // Runs only the methods of task.only (all when empty). Batch external methods get a placeholder
  // row here; their inputs are kept until FinishBatch runs them.
  ItemResult Run(const ItemTask& task) const;
  // Runs every batch external method once on the items of a batch (after Run on each of them)
  // and fills in their rows. One thread.
  void FinishBatch(const std::vector<ItemTask>& tasks, std::vector<ItemResult>* results) const;
  // The sweep hooks for RunSweep: run, and finish + batch size when the experiment has batch
  // external methods (the batch size is the smallest of their batch_size).
  SweepHooks Hooks() const;

 private:
  struct SceneContext;
  struct Pending;    // a degraded image (and its ground truth) waiting for the batch methods
  struct ItemScene;  // the scene, renderer and ground-truth scores an item uses
  SceneContext& Context(int scene_index) const;
  ItemScene SceneFor(const ItemSpec& item) const;
  // The item's ground truth (scored into result; thumbnails written).
  ScoreTarget GroundTruth(const ItemSpec& item, ItemScene& scene, const RenderResult& render,
                          const CameraCoding& camera, ItemResult* result) const;
  // One method (not a batch one) on the item, scored; a failure is the row's error.
  MethodResult RunMethod(const ExperimentMethod& method, const ItemSpec& item, const Scene* scene,
                         const RenderResult& render, const ScoreTarget& target,
                         OriginalCache* original_cache, cv::Mat* output = nullptr) const;
  // A sequence frame's front-end record made from scratch (render + methods, no scores), for a
  // pair whose other frame no thread of this run computes (tools/harness/sweep_sequence.h).
  std::shared_ptr<const FrameRecord> FrameRecordOf(const ItemSpec& item) const;
  // FinishBatch's parts: the tasks waiting for a batch method, a waiting item's images, and the
  // "python" and "command" batch runs.
  std::vector<size_t> BatchMembers(const std::vector<ItemTask>& tasks,
                                   const ExperimentMethod& method) const;
  const Pending& PendingOf(const std::string& id) const;
  void FinishPythonBatch(const ExperimentMethod& method, const std::vector<ItemTask>& tasks,
                         const std::vector<size_t>& members,
                         std::vector<ItemResult>* results) const;
  std::string RunCommandBatch(const ExperimentMethod& method, const std::vector<ItemTask>& tasks,
                              const std::vector<size_t>& members, const std::string& work,
                              const std::string& folder, double* share_ms) const;
  void FinishCommandBatch(const ExperimentMethod& method, const std::vector<ItemTask>& tasks,
                          const std::vector<size_t>& members,
                          std::vector<ItemResult>* results) const;
  // The sweep scheduler's cost of a task: values (pixels x channels) x (methods run + 1); before
  // the scene is loaded, the camera size of a built-in scene, 0 (unknown) for a scene file.
  double Cost(const ItemTask& task) const;
  // A per-image external method or a results folder on one item; throws Error with the reason.
  cv::Mat RunExternal(const ExperimentMethod& method, const std::string& id,
                      const cv::Mat& degraded, double* time_ms) const;
  // Runs a "python" method on degraded images (one per id) and checks each output; throws Error
  // when the call fails or returns the wrong number of images.
  std::vector<cv::Mat> RunInProcess(const ExperimentMethod& method,
                                    const std::vector<cv::Mat>& degraded,
                                    const std::vector<std::string>& ids) const;
  // Scores `enhanced` into row (metrics; full-reference ones in the experiment's score domain)
  // and saves its thumbnail. original_cache (optional): the degraded image's shared metric work
  // across the item's methods.
  void Score(const std::string& id, const std::string& label, const cv::Mat& enhanced,
             const ScoreTarget& target, const cv::Mat& degraded, MethodResult* row,
             OriginalCache* original_cache = nullptr) const;

  const Experiment& experiment_;
  std::string out_dir_;
  HarnessRunnerOptions options_;
  std::vector<std::string> metric_names_;
  std::vector<std::string> reference_only_metrics_;  // no reference, no original needed
  // The full-reference metrics and the others, when full-reference ones are scored coded.
  std::vector<std::string> coded_metrics_, linear_metrics_;
  std::vector<std::unique_ptr<SceneContext>> contexts_;
  std::unique_ptr<SequenceScorer> sequence_;  // front-end metrics (null: none asked)
  std::vector<ItemSpec> specs_;                // every item, when sequence_ is set
  mutable std::mutex pending_mutex_;
  mutable std::map<std::string, std::unique_ptr<Pending>> pending_;  // by item id
};

// Writes a small sRGB PNG (width px wide, aspect kept) of a linear [0, 1] image, atomically.
void WriteThumbnail(const std::string& path, const cv::Mat& linear, int width);

}  // namespace turbid
