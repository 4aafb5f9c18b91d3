// Enhancement methods by name: the CLI (`turbid enhance`, `--list`), the sweep and the docs all
// read this one table. Contract used by tools/; extend, do not break.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scenes/scene.h"
#include "simulator/render_record.h"

namespace turbid {

// Receives a method's named intermediate steps (`turbid enhance --dump-steps`). A method reports
// them only when EnhanceInput::steps is set: without a sink it does no extra work and keeps no
// extra copies. Steps come in the method's working channel order (B, G, R for colour).
class StepSink {
 public:
  virtual ~StepSink() = default;
  // An intermediate image named for the file it is dumped to ("01_denoised", sorted by name);
  // valid only during the call. `comparable`: a picture of the scene, comparable with the input
  // (the visible-edge measure applies); false for maps (transmission, range, weights). Empty
  // images are not steps: methods skip them.
  virtual void Image(const std::string& name, const cv::Mat& image, bool comparable) = 0;
  // A fact about the run for steps.json, e.g. "steps" (what ran and why), "light_scale", "plane".
  virtual void Note(const std::string& key, const nlohmann::json& value) = 0;
};

struct EnhanceInput {
  cv::Mat image;                            // degraded image, float32 linear [0,1], 1 or 3 channels
  const Scene* scene = nullptr;             // geometry (camera, depth, plane, DVL) when known
  const RenderRecord* sidecar = nullptr;    // the render's record (true parameters) when known
  // A 3-channel image in R, G, B order (the Python boundary) rather than turbid's B, G, R; the
  // result comes back in the same order. Methods that read the order natively (MethodEntry::
  // rgb_native) take it as it is; Enhance reorders for the others.
  bool rgb = false;
  StepSink* steps = nullptr;  // named intermediate steps go here when set (StepSink above)
};

// How a size-like parameter is bounded by the image a method runs on. Enhance refuses a larger
// value with one line naming the method, the parameter, its value and the bound (docs/methods.md,
// "Size parameters"); the method's default is always accepted, so tiny images keep working.
enum class SizeBound {
  kNone,
  kWindow,   // a window's side, pixels: at most 2 x the image's larger side + 1 (such a window
             // centred on any pixel already covers the whole image)
  kRadius,   // a window's radius, pixels: at most the image's larger side
  kPerAxis,  // regions along one axis (CLAHE tiles): at most the image's larger side
};

struct MethodParam {
  std::string name;
  nlohmann::json default_value;
  std::string doc;  // meaning, units, valid range, source of the default
  SizeBound bound = SizeBound::kNone;
};

struct MethodInfo {
  std::string name;             // registry key, e.g. "full", "dcp"
  std::string summary;          // one line
  std::string source;           // paper / reference the method follows
  bool needs_geometry = false;  // needs EnhanceInput::scene
  bool needs_sidecar = false;   // needs EnhanceInput::sidecar (oracle)
  // Privileged (SPEC "Fair comparisons"): receives true simulation parameters (water, light, PSF,
  // noise, exact geometry) beyond what its published version has. The CLI's --list, tables and the
  // report mark it; no default method but the oracle is privileged.
  bool privileged = false;
  // What the method reads besides the degraded image, in words, e.g. "scene plane (depth or DVL);
  // sidecar: camera, LED geometry and power". Empty: the image alone. docs/methods.md lists them.
  std::string inputs;
  std::vector<MethodParam> params;
};

// The largest value `bound` allows on an image of `size` (INT64_MAX for kNone).
int64_t SizeBoundLimit(SizeBound bound, cv::Size size);

// Throws Error("<method>: parameter '<name>' = <value> exceeds <limit>, ...") when a size-like
// parameter of `info` (an override in `params`, else its default) is larger than SizeBoundLimit
// for `image_size` and than its default. Enhance calls it; so do callers that run a method's
// options directly (turbid enhance --dump-steps).
void CheckSizeParams(const MethodInfo& info, const nlohmann::json& params, cv::Size image_size);

const std::vector<MethodInfo>& ListMethods();
const MethodInfo& FindMethod(const std::string& name);  // throws Error for unknown names
// Whether method `name` with parameter overrides `params` is privileged (SPEC "Fair comparisons"):
// info.privileged, or a parameter that makes it read true simulation parameters (e.g. `full` with
// beta_source=auto). Throws Error for unknown names and bad params.
bool IsPrivileged(const std::string& name, const nlohmann::json& params);

// Runs method `name` with parameter overrides `params` (an object; unknown keys or bad values
// throw Error). Returns float32 in [0,1] with the input's channel count (and channel order).
cv::Mat Enhance(const std::string& name, const nlohmann::json& params, const EnhanceInput& input);

// Enhance's last step, in place: NaN -> 0, then clamped to [0, 1] (-0 becomes +0). The same
// values as cv::patchNaNs, cv::min(·, 1) and cv::max(·, 0) in one pass.
void ClampEnhanceOutput(cv::Mat& image);

}  // namespace turbid
