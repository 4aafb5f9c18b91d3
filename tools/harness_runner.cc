#include "tools/harness_runner.h"

#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "enhancer/registry.h"
#include "metrics/registry.h"
#include "scenes/builtin.h"
#include "scenes/error.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "simulator/render.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

double MillisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::map<std::string, double> NanMetrics(const std::vector<std::string>& names) {
  std::map<std::string, double> out;
  for (const std::string& name : names) out[name] = std::nan("");
  return out;
}

Scene LoadExperimentScene(const ExperimentScene& scene) {
  LoadSceneOptions options;
  options.builtin_scale = scene.scale;
  Scene loaded = LoadScene(scene.load_spec, options);
  loaded.name = scene.name;
  return loaded;
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
    const MetricInfo& info = FindMetric(name);
    return HarnessMetricInfo{info.name, info.higher_is_better, info.needs_reference,
                             info.needs_original};
  };
  catalog.resolve_render = [](const json& options) {
    return RenderOptionsToJson(RenderOptionsFromJson(options));
  };
  catalog.check_scene = [](const std::string& spec) {
    if (IsBuiltinSpec(spec)) {
      const std::string name = spec.rfind("builtin:", 0) == 0 ? spec.substr(8) : spec;
      for (const std::string& known : BuiltinSceneNames()) {
        if (known == name) return;
      }
      throw Error("unknown built-in scene '" + name + "'");
    }
    ParseSceneFile(spec);  // strict schema and referenced files, without reading the images
  };
  catalog.default_seed_path = "seed";
  return catalog;
}

bool HarnessRunnerOptions::Check(std::string* /*why*/) const { return true; }

struct HarnessRunner::SceneContext {
  std::once_flag once;
  std::exception_ptr error;
  Scene scene;
  std::unique_ptr<Renderer> renderer;
  std::map<std::string, double> reference_metrics;
};

HarnessRunner::HarnessRunner(const Experiment& experiment, std::string out_dir,
                             const HarnessRunnerOptions& options)
    : experiment_(experiment), out_dir_(std::move(out_dir)), options_(options) {
  for (const HarnessMetricInfo& metric : experiment_.metrics) {
    metric_names_.push_back(metric.name);
    if (!metric.needs_reference && !metric.needs_original) {
      reference_only_metrics_.push_back(metric.name);
    }
  }
  for (size_t i = 0; i < experiment_.scenes.size(); ++i) {
    contexts_.push_back(std::make_unique<SceneContext>());
  }
}

HarnessRunner::~HarnessRunner() = default;

HarnessRunner::SceneContext& HarnessRunner::Context(int scene_index) const {
  SceneContext& context = *contexts_.at(static_cast<size_t>(scene_index));
  std::call_once(context.once, [&] {
    try {
      const ExperimentScene& spec = experiment_.scenes[static_cast<size_t>(scene_index)];
      context.scene = LoadExperimentScene(spec);
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
    } catch (...) {
      context.error = std::current_exception();
    }
  });
  if (context.error) std::rethrow_exception(context.error);
  return context;
}

ItemResult HarnessRunner::Run(const ItemSpec& item) const {
  const ExperimentScene& scene_spec = experiment_.scenes[static_cast<size_t>(item.scene_index)];
  // Without reuse every item starts from nothing: load, a fresh renderer, ground-truth scores.
  std::unique_ptr<SceneContext> fresh;
  const Scene* scene = nullptr;
  const Renderer* renderer = nullptr;
  std::map<std::string, double> reference_metrics;
  if (options_.reuse) {
    SceneContext& context = Context(item.scene_index);
    scene = &context.scene;
    renderer = context.renderer.get();
    reference_metrics = context.reference_metrics;
  } else {
    fresh = std::make_unique<SceneContext>();
    fresh->scene = LoadExperimentScene(scene_spec);
    fresh->renderer = std::make_unique<Renderer>(fresh->scene);
    scene = &fresh->scene;
    renderer = fresh->renderer.get();
    if (experiment_.ground_truth == "clean" && !reference_only_metrics_.empty()) {
      MetricInputs inputs;
      inputs.image = scene->image;
      reference_metrics = ComputeMetrics(reference_only_metrics_, inputs);
    }
  }

  ItemResult result;
  result.width = scene->width();
  result.height = scene->height();
  const std::string thumbs = out_dir_ + "/thumbs/" + item.id;
  const auto start_render = Clock::now();
  RenderResult render;
  try {
    render = renderer->Render(RenderOptionsFromJson(item.render_options));
  } catch (const Error& error) {
    result.error = std::string("render: ") + error.what();
    for (const ExperimentMethod& method : experiment_.methods) {
      result.methods.push_back({method.label, NanMetrics(metric_names_), result.error, 0.0});
    }
    return result;
  }
  result.render_ms = MillisecondsSince(start_render);

  // Ground truth: the clean rho, or the lit J clipped to the metrics' [0, 1] range.
  cv::Mat reference = scene->image;
  if (experiment_.ground_truth == "lit") {
    cv::min(cv::max(render.lit, 0.0), 1.0, reference);
    if (!reference_only_metrics_.empty()) {
      MetricInputs inputs;
      inputs.image = reference;
      reference_metrics = ComputeMetrics(reference_only_metrics_, inputs);
    }
  }
  result.reference_metrics = reference_metrics;
  if (experiment_.thumbnail_width > 0) {
    WriteThumbnail(thumbs + "/degraded.png", render.image, experiment_.thumbnail_width);
    if (experiment_.ground_truth == "lit") {
      WriteThumbnail(thumbs + "/lit.png", reference, experiment_.thumbnail_width);
    }
  }

  for (const ExperimentMethod& method : experiment_.methods) {
    MethodResult row;
    row.label = method.label;
    cv::Mat enhanced;
    const auto start = Clock::now();
    try {
      if (method.name == "none") {
        enhanced = render.image;
      } else {
        EnhanceInput input;
        input.image = render.image;
        input.scene = scene;
        input.sidecar = &render.sidecar;
        enhanced = Enhance(method.name, method.params, input);
      }
      row.time_ms = MillisecondsSince(start);
      MetricInputs inputs;
      inputs.reference = reference;
      inputs.image = enhanced;
      inputs.original = render.image;
      row.metrics = ComputeMetrics(metric_names_, inputs);
      if (experiment_.thumbnail_width > 0 && method.name != "none") {
        WriteThumbnail(thumbs + "/" + method.label + ".png", enhanced, experiment_.thumbnail_width);
      }
    } catch (const std::exception& error) {
      if (row.time_ms == 0.0) row.time_ms = MillisecondsSince(start);
      row.error = error.what();
      row.metrics = NanMetrics(metric_names_);
    }
    result.methods.push_back(std::move(row));
  }
  return result;
}

void WriteThumbnail(const std::string& path, const cv::Mat& linear, int width) {
  std::error_code ec;
  fs::create_directories(fs::path(path).parent_path(), ec);
  if (ec) throw Error(path, "cannot create the thumbnail folder: " + ec.message());
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
