#include "tools/harness/harness_runner.h"

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
#include "tools/harness/harness_runner_internal.h"
#include "tools/harness/sweep_sequence.h"

namespace turbid {

namespace runner_internal {

namespace fs = std::filesystem;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::map<std::string, double> NanMetrics(const std::vector<std::string>& names) {
  std::map<std::string, double> out;
  for (const std::string& name : names) out[name] = std::nan("");
  return out;
}

bool Selected(const ItemTask& task, const std::string& label) {
  return task.only.empty() ||
         std::find(task.only.begin(), task.only.end(), label) != task.only.end();
}

// A path of the experiment file (relative to its folder), made absolute.
std::string ResolveAgainst(const std::string& base_dir, const std::string& path) {
  const fs::path p(path);
  if (p.is_absolute()) return path;
  return fs::absolute(fs::path(base_dir.empty() ? "." : base_dir) / p).lexically_normal().string();
}

// Reads a method's output; errors name the file as `shown` (work folders are deleted).
cv::Mat ReadOutput(const std::string& path, const std::string& shown, const std::string& encoding,
                   const cv::Mat& degraded) {
  try {
    return ReadMethodOutput(path, encoding, degraded);
  } catch (const Error& error) {
    std::string message = error.what();
    if (message.rfind(path, 0) == 0) message = shown + message.substr(path.size());
    throw Error(message);
  }
}

// "" when the external method's folders under OUT are real folders (or absent); otherwise why the
// method cannot run: its work folder is removed and recreated, which must never go through a link.
std::string ExternalFolderProblem(const std::string& out_dir, const std::string& folder) {
  try {
    RefuseSymlink(out_dir + "/external", "cleans and writes");
    RefuseSymlink(folder, "cleans and writes");
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

// Working directory, environment and timeout of an external command method.
ProcessOptions ProcessFor(const ExperimentMethod& method) {
  const nlohmann::json& spec = method.external;
  ProcessOptions process;
  process.cwd = ResolveAgainst(method.base_dir, spec.at("cwd").get<std::string>());
  for (const auto& [name, value] : spec.at("env").items()) {
    process.env[name] = value.get<std::string>();
  }
  process.timeout_s = spec.at("timeout_s").get<double>();
  return process;
}

}  // namespace runner_internal

using runner_internal::Clock;
using runner_internal::ExternalFolderProblem;
using runner_internal::MillisecondsSince;
using runner_internal::NanMetrics;
using runner_internal::ProcessFor;
using runner_internal::ReadOutput;
using runner_internal::ResolveAgainst;
using runner_internal::Selected;

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

Scene LoadExperimentScene(const ExperimentScene& scene) {
  LoadSceneOptions options;
  options.builtin_scale = scene.scale;
  Scene loaded = LoadScene(scene.load_spec, options);
  loaded.name = scene.name;
  return loaded;
}

// Where RegistryCatalog puts each item's seed: RenderOptions::seed.
constexpr const char* kRenderSeedPath = "seed";

// The options an item renders with: its condition's, parsed once by ParseExperiment, with the
// item's seed. An experiment that writes the seed elsewhere in the options (its own seed_path) or
// was parsed without them renders from the item's JSON, as it was parsed before.
RenderOptions ItemRenderOptions(const Experiment& experiment, const ItemSpec& item) {
  if (item.render != nullptr && experiment.seed_path.empty()) return *item.render;
  if (item.render != nullptr && experiment.seed_path == kRenderSeedPath) {
    RenderOptions options = *item.render;
    options.seed = item.seed;
    return options;
  }
  return RenderOptionsFromJson(item.render_options);
}

// World-space marine snow along a sequence: the frame's pose and time, and (unless the experiment
// sets one) the seed all frames of the condition share, so the particles stay in the world.
void ApplySequenceToSnow(const Sequence& sequence, const ItemSpec& item, RenderOptions* options) {
  if (item.frame < 0 || options->snow.mode != "world") return;
  const Pose& pose = sequence.pose(item.frame);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) options->snow.camera_to_world[i * 4 + j] = pose.rotation(i, j);
    options->snow.camera_to_world[i * 4 + 3] = pose.position_m[i];
  }
  options->snow.time_s = sequence.timestamp_s(item.frame);
  if (options->snow.world_seed == 0) options->snow.world_seed = item.sequence_seed;
}

}  // namespace

HarnessCatalog RegistryCatalog() {
  HarnessCatalog catalog;
  catalog.check_method = [](const std::string& name, const json& params) {
    const MethodInfo& info = FindMethod(name);
    for (const auto& [key, value] : params.items()) {
      bool known = false;
      std::string list;
      for (const MethodParam& param : info.params) {
        known |= param.name == key;
        list += (list.empty() ? "" : ", ") + param.name;
      }
      if (!known) {
        throw Error("method '" + name + "' has no parameter '" + key + "' (" +
                    (list.empty() ? "it takes none" : "known: " + list) + ")");
      }
    }
  };
  catalog.is_privileged = [](const std::string& name, const json& params) {
    return IsPrivileged(name, params);
  };
  catalog.find_metric = [](const std::string& name) {
    if (const std::optional<FrontendMetric> frontend = ParseFrontendMetric(name))
      return HarnessMetricInfo{name, frontend->higher_is_better, false, false, true};
    const MetricInfo& info = FindMetric(name);
    return HarnessMetricInfo{info.name, info.higher_is_better, info.needs_reference,
                             info.needs_original, false};
  };
  catalog.resolve_render = [](const json& options) {
    auto parsed = std::make_shared<const RenderOptions>(RenderOptionsFromJson(options));
    return ResolvedRender{RenderOptionsToJson(*parsed), std::move(parsed)};
  };
  catalog.check_scene = [](const std::string& spec) {
    if (IsBuiltinSpec(spec)) {
      const std::string name = BuiltinSpecName(spec);
      for (const std::string& known : BuiltinSceneNames()) {
        if (known == name) return;
      }
      throw Error("unknown built-in scene '" + name + "'");
    }
    ParseSceneFile(spec);  // strict schema and referenced files, without reading the images
  };
  catalog.sequence_frames = [](const std::string& spec, double scale, const json& trajectory,
                               json* resolved) {
    *resolved = json();
    if (IsBuiltinSpec(spec)) {
      if (trajectory.is_null()) return 0;
      TrajectoryOptions options;
      TrajectoryFields().Read(trajectory, &options, "trajectory");
      *resolved = TrajectoryFields().ToJson(options);
    } else if (!IsRgbdSequenceFile(spec)) {
      return 0;
    }
    return OpenSequence(spec, scale, trajectory, "trajectory")->size();
  };
  catalog.default_seed_path = kRenderSeedPath;
  return catalog;
}

bool HarnessRunnerOptions::Check(std::string* /*why*/) const { return true; }

namespace {

bool IsCommandMethod(const ExperimentMethod& method) {
  return method.IsExternal() && method.external.value("kind", "") == "command";
}

}  // namespace

void CheckCommandsAllowed(const Experiment& experiment, bool allowed, const std::string& how) {
  if (allowed) return;
  for (const ExperimentMethod& method : experiment.methods) {
    if (!IsCommandMethod(method)) continue;
    const json& command = method.external.at("command");
    const std::string program = command.empty() ? "" : command[0].get<std::string>();
    throw Error(experiment.source_path.empty() ? "experiment" : experiment.source_path,
                "method '" + method.label + "' runs an external command (" + json(program).dump() +
                    "); an experiment's commands run only with " + how +
                    " (nothing in the experiment file can allow them)");
  }
}

std::vector<std::string> DescribeCommands(const Experiment& experiment) {
  std::vector<std::string> lines;
  for (const ExperimentMethod& method : experiment.methods) {
    if (!IsCommandMethod(method)) continue;
    const json& spec = method.external;
    const ProcessOptions process = ProcessFor(method);
    std::string line =
        "method '" + method.label + "' (" +
        (spec.value("batch", false) ? "one process per batch of up to " +
                                          std::to_string(spec.value("batch_size", 32)) + " items"
                                    : std::string("one process per image")) +
        "): command " + spec.at("command").dump() + ", cwd " + json(process.cwd).dump() + ", env " +
        spec.at("env").dump();
    lines.push_back(line);
  }
  return lines;
}

struct HarnessRunner::SceneContext {
  std::once_flag once;
  std::exception_ptr error;
  Scene scene;
  std::unique_ptr<Renderer> renderer;
  std::map<std::string, double> reference_metrics;
  std::atomic<bool> loaded{false};     // scene and renderer are set (Cost reads them)
  std::unique_ptr<Sequence> sequence;  // a sequence scene (scene: its frame 0)
};

HarnessRunner::HarnessRunner(const Experiment& experiment, std::string out_dir,
                             const HarnessRunnerOptions& options)
    : experiment_(experiment), out_dir_(std::move(out_dir)), options_(options) {
  for (const HarnessMetricInfo& metric : experiment_.metrics) {
    metric_names_.push_back(metric.name);
    if (metric.sequence) continue;  // scored on pairs of frames (sequence_)
    if (!metric.needs_reference && !metric.needs_original) {
      reference_only_metrics_.push_back(metric.name);
    }
    const bool coded = experiment_.score_domain == ScoreDomain::kEncoded && metric.needs_reference;
    (coded ? coded_metrics_ : linear_metrics_).push_back(metric.name);
  }
  for (size_t i = 0; i < experiment_.scenes.size(); ++i) {
    contexts_.push_back(std::make_unique<SceneContext>());
  }
  CheckCommandsAllowed(experiment_, options_.allow_commands, options_.allow_commands_how);
  if (experiment_.HasSequenceMetrics()) {
    for (const ExperimentMethod& method : experiment_.methods) {
      if (method.IsExternal())
        throw Error(experiment_.source_path,
                    "method '" + method.label +
                        "' is external: front-end metrics run registry methods only (a frame's "
                        "pair may have to be recomputed in this process)");
    }
    sequence_ = std::make_unique<SequenceScorer>(experiment_, options_.profile);
    specs_ = ExpandItems(experiment_);
  }
  for (const ExperimentMethod& method : experiment_.methods) {
    if (!method.IsExternal() || method.external.at("kind") != "python") continue;
    const std::string key = method.external.at("python").get<std::string>();
    if (!options_.in_process.count(key)) {
      throw Error("method '" + method.label + "' is a Python callable ('python': '" + key +
                  "'): run the experiment from Python, turbid.sweep(experiment, out, methods={'" +
                  key + "': f}) (docs/python.md)");
    }
  }
}

HarnessRunner::~HarnessRunner() = default;

HarnessRunner::SceneContext& HarnessRunner::Context(int scene_index) const {
  SceneContext& context = *contexts_.at(static_cast<size_t>(scene_index));
  std::call_once(context.once, [&] {
    const ScopedStage timed(options_.profile, "scene: load, clean scores, thumbnail");
    try {
      const ExperimentScene& spec = experiment_.scenes[static_cast<size_t>(scene_index)];
      if (spec.IsSequence()) {
        context.sequence =
            OpenSequence(spec.load_spec, spec.scale, spec.trajectory, experiment_.source_path);
        context.scene = context.sequence->Frame(0);
        context.scene.name = spec.name;
      } else {
        context.scene = LoadExperimentScene(spec);
      }
      context.renderer = std::make_unique<Renderer>(context.scene);
      // The clean ground truth does not depend on the swept parameters: score it once.
      if (experiment_.ground_truth == "clean" && !reference_only_metrics_.empty()) {
        MetricInputs inputs;
        inputs.image = context.scene.image;
        context.reference_metrics = ComputeMetrics(reference_only_metrics_, inputs);
      }
      if (experiment_.thumbnail_width > 0) {
        WriteThumbnail(out_dir_ + "/thumbs/" + spec.name + "/clean.png", context.scene.image,
                       experiment_.thumbnail_width);
      }
      context.loaded = true;
    } catch (...) {
      context.error = std::current_exception();
    }
  });
  if (context.error) std::rethrow_exception(context.error);
  return context;
}

double HarnessRunner::Cost(const ItemTask& task) const {
  const ItemSpec& item = *task.spec;
  double values = 0.0;
  const SceneContext& context = *contexts_.at(static_cast<size_t>(item.scene_index));
  if (context.loaded.load()) {
    values = static_cast<double>(context.scene.image.total()) * context.scene.image.channels();
  } else {
    const ExperimentScene& spec = experiment_.scenes[static_cast<size_t>(item.scene_index)];
    if (IsBuiltinSpec(spec.load_spec)) {
      try {
        const CameraIntrinsics camera =
            ScaleIntrinsics(BuiltinSceneCamera(BuiltinSpecName(spec.load_spec)), spec.scale);
        values = static_cast<double>(camera.width) * camera.height;
      } catch (const Error&) {
        values = 0.0;  // an unknown name fails when the scene is loaded
      }
    }
  }
  int methods = 0;
  for (const ExperimentMethod& method : experiment_.methods)
    methods += Selected(task, method.label);
  return values * (methods + 1);
}

ItemResult HarnessRunner::Run(const ItemSpec& item) const { return Run(ItemTask{&item, {}}); }

// The scene an item renders: the shared context's with reuse, else one loaded for the item.
struct HarnessRunner::ItemScene {
  std::unique_ptr<SceneContext> fresh;
  const Scene* scene = nullptr;
  const Renderer* renderer = nullptr;
  std::map<std::string, double> reference_metrics;
};

HarnessRunner::ItemScene HarnessRunner::SceneFor(const ItemSpec& item) const {
  const ExperimentScene& scene_spec = experiment_.scenes[static_cast<size_t>(item.scene_index)];
  // Without reuse every item starts from nothing: load, a fresh renderer, ground-truth scores.
  ItemScene s;
  if (item.frame >= 0) {
    // A sequence frame: rendered (or read) now, with its own renderer and clean scores.
    const Sequence& sequence = *Context(item.scene_index).sequence;
    const ScopedStage timed(options_.profile, "scene: sequence frame");
    s.fresh = std::make_unique<SceneContext>();
    s.fresh->scene = sequence.Frame(item.frame);
    s.fresh->renderer = std::make_unique<Renderer>(s.fresh->scene);
    s.scene = &s.fresh->scene;
    s.renderer = s.fresh->renderer.get();
    if (experiment_.ground_truth == "clean" && !reference_only_metrics_.empty()) {
      MetricInputs inputs;
      inputs.image = s.scene->image;
      s.reference_metrics = ComputeMetrics(reference_only_metrics_, inputs);
    }
    return s;
  }
  if (options_.reuse) {
    SceneContext& context = Context(item.scene_index);
    s.scene = &context.scene;
    s.renderer = context.renderer.get();
    s.reference_metrics = context.reference_metrics;
  } else {
    const ScopedStage timed(options_.profile, "scene: load, clean scores, thumbnail");
    s.fresh = std::make_unique<SceneContext>();
    s.fresh->scene = LoadExperimentScene(scene_spec);
    s.fresh->renderer = std::make_unique<Renderer>(s.fresh->scene);
    s.scene = &s.fresh->scene;
    s.renderer = s.fresh->renderer.get();
    if (experiment_.ground_truth == "clean" && !reference_only_metrics_.empty()) {
      MetricInputs inputs;
      inputs.image = s.scene->image;
      s.reference_metrics = ComputeMetrics(reference_only_metrics_, inputs);
    }
  }
  return s;
}

// Ground truth: the clean rho, or the lit J clipped to the metrics' [0, 1] range; its scores go
// into result, and the thumbnails of the degraded image (and lit J) are written.
ScoreTarget HarnessRunner::GroundTruth(const ItemSpec& item, ItemScene& s,
                                       const RenderResult& render, const CameraCoding& camera,
                                       ItemResult* result) const {
  cv::Mat reference = s.scene->image;
  if (experiment_.ground_truth == "lit") {
    cv::min(cv::max(render.lit, 0.0), 1.0, reference);
    if (!reference_only_metrics_.empty()) {
      MetricInputs inputs;
      inputs.image = reference;
      s.reference_metrics = ComputeMetrics(reference_only_metrics_, inputs);
    }
  }
  result->reference_metrics = s.reference_metrics;
  if (experiment_.thumbnail_width > 0) {
    const std::string thumbs = out_dir_ + "/thumbs/" + item.id;
    const ScopedStage timed(options_.profile, "I/O: thumbnails");
    WriteThumbnail(thumbs + "/degraded.png", render.image, experiment_.thumbnail_width);
    if (experiment_.ground_truth == "lit") {
      WriteThumbnail(thumbs + "/lit.png", reference, experiment_.thumbnail_width);
    }
  }
  ScoreTarget target;
  target.reference = reference;
  target.camera = camera;
  if (!coded_metrics_.empty()) {
    const ScopedStage timed(options_.profile, "score: encode");
    target.reference_coded = EncodeForScoring(reference, camera);
  }
  return target;
}

// One (not batch) method on the item, scored; its failure is the row's error.
MethodResult HarnessRunner::RunMethod(const ExperimentMethod& method, const ItemSpec& item,
                                      const Scene* scene, const RenderResult& render,
                                      const ScoreTarget& target, OriginalCache* original_cache,
                                      cv::Mat* output) const {
  MethodResult row;
  row.label = method.label;
  cv::Mat enhanced;
  const auto start = Clock::now();
  try {
    if (method.name == "none" && !method.IsExternal()) {
      enhanced = render.image;
    } else if (method.IsExternal()) {
      enhanced = RunExternal(method, item.id, render.image, &row.time_ms);
    } else {
      EnhanceInput input;
      input.image = render.image;
      input.scene = scene;
      input.sidecar = &render.sidecar;
      enhanced = Enhance(method.name, method.params, input);
    }
    if (!method.IsExternal()) row.time_ms = MillisecondsSince(start);
    if (options_.profile && std::isfinite(row.time_ms))
      options_.profile->Add("method " + method.label, row.time_ms);
    Score(item.id, method.name == "none" && !method.IsExternal() ? "" : method.label, enhanced,
          target, render.image, &row, original_cache);
    if (output != nullptr) *output = enhanced;
  } catch (const OutputError&) {
    throw;  // our own write failed (full disk...): not the method's failure; the sweep stops
  } catch (const std::exception& error) {
    if (row.time_ms == 0.0) row.time_ms = MillisecondsSince(start);
    row.error = error.what();
    row.metrics = NanMetrics(metric_names_);
  }
  return row;
}

namespace {
// Publishes a claimed frame record on every path out of Run (null when none was built).
struct ClaimGuard {
  SequenceScorer* scorer = nullptr;
  int index = -1;
  void Publish(std::shared_ptr<const FrameRecord> record) {
    if (scorer != nullptr) scorer->Publish(index, std::move(record));
    scorer = nullptr;
  }
  ~ClaimGuard() { Publish(nullptr); }
};
}  // namespace

ItemResult HarnessRunner::Run(const ItemTask& task) const {
  const ItemSpec& item = *task.spec;
  // A sequence frame tells the other threads that its record is on the way (sweep_sequence.h).
  ClaimGuard claim;
  const bool frontend = sequence_ != nullptr && item.frame >= 0;
  if (frontend && task.only.empty() && sequence_->Claim(item)) {
    claim.scorer = sequence_.get();
    claim.index = item.index;
  }
  ItemScene s = SceneFor(item);
  ItemResult result;
  result.width = s.scene->width();
  result.height = s.scene->height();
  const auto start_render = Clock::now();
  RenderResult render;
  CameraCoding camera;
  try {
    RenderOptions options = ItemRenderOptions(experiment_, item);
    if (item.frame >= 0) ApplySequenceToSnow(*Context(item.scene_index).sequence, item, &options);
    camera.encoding = options.camera.encoding;
    camera.bit_depth = options.camera.bit_depth;
    render = s.renderer->Render(options);
  } catch (const Error& error) {
    result.error = std::string("render: ") + error.what();
    for (const ExperimentMethod& method : experiment_.methods) {
      if (!Selected(task, method.label)) continue;
      result.methods.push_back({method.label, NanMetrics(metric_names_), result.error, 0.0});
    }
    return result;
  }
  result.render_ms = MillisecondsSince(start_render);
  if (options_.profile) options_.profile->Add("render", result.render_ms);
  const ScoreTarget target = GroundTruth(item, s, render, camera, &result);

  bool batch_pending = false;
  std::map<std::string, cv::Mat> outputs;  // front end: each method's output by label
  // The degraded image's visible-edge analysis, shared by the scores of every method of the item.
  const std::shared_ptr<OriginalCache> original_cache = NewOriginalCache();
  for (const ExperimentMethod& method : experiment_.methods) {
    if (!Selected(task, method.label)) continue;
    if (method.IsBatch()) {
      // Run once for the whole batch by FinishBatch; this row is replaced there.
      MethodResult row;
      row.label = method.label;
      row.metrics = NanMetrics(metric_names_);
      row.error = "batch method not run";
      batch_pending = true;
      result.methods.push_back(std::move(row));
      continue;
    }
    cv::Mat output;
    result.methods.push_back(RunMethod(method, item, s.scene, render, target, original_cache.get(),
                                       frontend ? &output : nullptr));
    if (frontend && result.methods.back().error.empty()) outputs[method.label] = output;
  }
  if (frontend) {
    const Sequence& sequence = *Context(item.scene_index).sequence;
    outputs[""] = s.scene->image;
    const std::shared_ptr<const FrameRecord> record =
        sequence_->Build(*s.scene, sequence.pose(item.frame), camera, outputs);
    claim.Publish(record);
    sequence_->Score(
        item, *record,
        [&](int index) {
          return sequence_->Take(index, [&] { return FrameRecordOf(specs_.at(index)); });
        },
        &result);
  }
  if (batch_pending) {
    auto pending = std::make_unique<Pending>();
    pending->degraded = render.image;
    pending->target = target;
    std::lock_guard<std::mutex> lock(pending_mutex_);
    pending_[item.id] = std::move(pending);
  }
  return result;
}

std::shared_ptr<const FrameRecord> HarnessRunner::FrameRecordOf(const ItemSpec& item) const {
  const ScopedStage timed(options_.profile, "front end: recompute a paired frame");
  ItemScene s = SceneFor(item);
  RenderOptions options = ItemRenderOptions(experiment_, item);
  ApplySequenceToSnow(*Context(item.scene_index).sequence, item, &options);
  CameraCoding camera;
  camera.encoding = options.camera.encoding;
  camera.bit_depth = options.camera.bit_depth;
  std::map<std::string, cv::Mat> outputs;
  outputs[""] = s.scene->image;
  try {
    const RenderResult render = s.renderer->Render(options);
    for (const ExperimentMethod& method : experiment_.methods) {
      try {
        if (method.name == "none") {
          outputs[method.label] = render.image;
          continue;
        }
        EnhanceInput input;
        input.image = render.image;
        input.scene = s.scene;
        input.sidecar = &render.sidecar;
        outputs[method.label] = Enhance(method.name, method.params, input);
      } catch (const std::exception&) {
        // failed here as in its own item: the method has no frame (its pair values are NaN)
      }
    }
  } catch (const Error&) {
    return std::make_shared<FrameRecord>();  // the render failed: no frame has a pair
  }
  const Sequence& sequence = *Context(item.scene_index).sequence;
  return sequence_->Build(*s.scene, sequence.pose(item.frame), camera, outputs);
}

void HarnessRunner::Score(const std::string& id, const std::string& label, const cv::Mat& enhanced,
                          const ScoreTarget& target, const cv::Mat& degraded, MethodResult* row,
                          OriginalCache* original_cache) const {
  MetricInputs inputs;
  inputs.reference = target.reference;
  inputs.image = enhanced;
  inputs.original = degraded;
  inputs.original_cache = original_cache;
  std::map<std::string, double> elapsed;
  std::map<std::string, double>* timing = options_.profile ? &elapsed : nullptr;
  row->metrics.clear();
  if (!linear_metrics_.empty()) row->metrics = ComputeMetrics(linear_metrics_, inputs, timing);
  if (!coded_metrics_.empty()) {
    // Full-reference metrics on the images as the camera writes them (encoded once per image).
    MetricInputs coded;
    {
      const ScopedStage timed(options_.profile, "score: encode");
      coded.image = EncodeForScoring(enhanced, target.camera);
    }
    coded.reference = target.reference_coded;
    coded.data_range = target.camera.DataRange();
    std::map<std::string, double> coded_elapsed;
    const std::map<std::string, double> scores =
        ComputeMetrics(coded_metrics_, coded, timing ? &coded_elapsed : nullptr);
    row->metrics.insert(scores.begin(), scores.end());
    elapsed.insert(coded_elapsed.begin(), coded_elapsed.end());
  }
  for (const auto& [name, ms] : elapsed) options_.profile->Add("metric " + name, ms);
  if (experiment_.thumbnail_width > 0 && !label.empty()) {
    const ScopedStage timed(options_.profile, "I/O: thumbnails");
    WriteThumbnail(out_dir_ + "/thumbs/" + id + "/" + label + ".png", enhanced,
                   experiment_.thumbnail_width);
  }
}

SweepHooks HarnessRunner::Hooks() const {
  SweepHooks hooks;
  hooks.run = [this](const ItemTask& task) { return Run(task); };
  hooks.cost = [this](const ItemTask& task) { return Cost(task); };
  if (options_.reuse) {
    // One worker builds a scene (the built-in hull takes about a second) while the others run the
    // items of scenes already built; a failed build is reported by the scene's items.
    hooks.group = [](const ItemTask& task) { return task.spec->scene_index; };
    hooks.prepare = [this](int scene_index) {
      try {
        Context(scene_index);
      } catch (...) {
      }
    };
  }
  int batch = 0;
  for (const ExperimentMethod& method : experiment_.methods) {
    if (!method.IsBatch()) continue;
    const int size = method.external.value("batch_size", 32);
    batch = batch == 0 ? size : std::min(batch, size);
  }
  if (batch > 0) {
    hooks.finish = [this](const std::vector<ItemTask>& tasks, std::vector<ItemResult>* results) {
      FinishBatch(tasks, results);
    };
    hooks.batch_items = batch;
  }
  return hooks;
}

void WriteThumbnail(const std::string& path, const cv::Mat& linear, int width) {
  std::error_code ec;
  fs::create_directories(fs::path(path).parent_path(), ec);
  if (ec) throw OutputError(path, "cannot create the thumbnail folder: " + ec.message());
  cv::Mat small = linear;
  if (linear.cols > width) {
    const int height = std::max(
        1, static_cast<int>(std::lround(static_cast<double>(linear.rows) * width / linear.cols)));
    cv::resize(linear, small, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  }
  WriteImageOptions options;
  options.transfer = Transfer::kSrgb;
  options.overwrite = true;  // a killed item may have left its thumbnails; they are rewritten
  WriteImage(path, small, options);
}

}  // namespace turbid
