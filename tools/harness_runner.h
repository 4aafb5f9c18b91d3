// The real sweep item: render the scene under the item's parameters, run every method, score each
// result with the requested metrics against the chosen ground truth, save thumbnails. Binds the
// harness to the simulator (simulator/render.h), the enhancer registry and the metrics registry.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "tools/experiment.h"
#include "tools/tables.h"

namespace turbid {

// Name checks and option resolution read from the registries (methods, metrics), the simulator's
// strict RenderOptionsFromJson and the scene loader.
HarnessCatalog RegistryCatalog();

struct HarnessRunnerOptions {
  // Reuse work that does not depend on the swept parameters: each scene is loaded once, one
  // Renderer per scene keeps its caches (range map, light geometry, PSF kernels, blurred J) across
  // items, and no-reference scores of the ground truth are computed once per scene. false loads,
  // renders and scores from scratch for every item (the baseline of benchmarks/harness_bench.cc).
  bool reuse = true;
  bool Check(std::string* why) const;
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

 private:
  struct SceneContext;
  SceneContext& Context(int scene_index) const;

  const Experiment& experiment_;
  std::string out_dir_;
  HarnessRunnerOptions options_;
  std::vector<std::string> metric_names_;
  std::vector<std::string> reference_only_metrics_;  // no reference, no original needed
  std::vector<std::unique_ptr<SceneContext>> contexts_;
};

// Writes a small sRGB PNG (width px wide, aspect kept) of a linear [0, 1] image, atomically.
void WriteThumbnail(const std::string& path, const cv::Mat& linear, int width);

}  // namespace turbid
