// Registry entries of the paper's methods: full, its variants and simplified.
#include "enhancer/paper/entries.h"

#include <string>

#include "enhancer/method.h"
#include "enhancer/params.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/params.h"
#include "enhancer/paper/simplified.h"

namespace turbid {
namespace {

using paper_internal::BindSimplified;

// What each variant of `full` reads besides the image (docs/methods.md).
std::string FullInputs(const FullOptions& d) {
  std::string inputs =
      "plane (DVL points, else a plane fitted to the scene depth); camera; LED geometry from the "
      "vehicle's specification (the sidecar's options.light)";
  inputs += d.light_scaling == "physical" ? ", with the LED power in image units (true)"
                                          : ", not its power";
  inputs += d.beta_source == "auto" ? "; beta: the sidecar's water (true)" : "; beta: fixed 0.7 /m";
  return inputs;
}

// `full` (variant) on an input: FullEnhance, or with a step sink the whole-image pipeline, which
// keeps every intermediate (the same output).
cv::Mat RunFull(const std::string& variant, const nlohmann::json& params, const EnhanceInput& in) {
  const FullOptions o = FullOptionsFromJson(params, variant);
  if (in.steps == nullptr) return FullEnhance(o, in.image, in.scene, in.sidecar);
  // Inspected: the whole-image pipeline, which keeps every intermediate (the same output).
  const FullResult r = FullEnhanceDetailed(o, in.image, in.scene, in.sidecar);
  ReportFullSteps(r, *in.steps);
  return r.image;
}

MethodEntry FullEntry(const std::string& variant) {
  const FullOptions d = FullVariantDefaults(variant);
  MethodEntry e;
  e.info.name = variant;
  const std::string steps =
      "denoise, light estimate, plane-induced dehazing, PSF deconvolution, CLAHE";
  if (variant == "full") {
    e.info.summary = "paper full model (" + steps + "), light scale estimated blind";
  } else if (variant == "full_literal") {
    e.info.summary = "paper full model as written: E_L fitted into [min I, max I] (§III-A.2)";
  } else if (variant == "full_matched") {
    e.info.summary = "full with the true water (beta per channel from the sidecar): privileged";
  } else {
    e.info.summary =
        "full with the true water and the light's true power in image units: privileged";
  }
  e.info.source =
      "the reproduced paper (Visibility Enhancement for Underwater Visual SLAM), §III-A, eqs. 4-7";
  e.info.needs_geometry = true;
  e.info.privileged = FullOptionsArePrivileged(d);
  e.info.inputs = FullInputs(d);
  e.info.params = MethodParamsOf(paper_internal::FullFields(), d);
  e.run = [variant](const nlohmann::json& params, const EnhanceInput& in) {
    return RunFull(variant, params, in);
  };
  e.privileged_with = [variant](const nlohmann::json& params) {
    return FullOptionsArePrivileged(FullOptionsFromJson(params, variant));
  };
  return e;
}

MethodEntry SimplifiedEntry() {
  const SimplifiedOptions d;
  MethodEntry e;
  e.info.name = "simplified";
  e.info.summary = "paper simplified model: dual guided-filter detail boost, then CLAHE";
  e.info.source = "the reproduced paper §III-B, eqs. 8-9 (after He et al. TPAMI 2013 §4.2)";
  e.info.inputs = "";  // the image alone
  e.info.params = MethodParamsOf(paper_internal::SimplifiedFields(), d);
  e.run = [](const nlohmann::json& params, const EnhanceInput& in) {
    SimplifiedOptions o = BindSimplified(params);
    o.clahe.rgb = in.rgb;  // the guided filters and the detail boost are per channel
    if (in.steps != nullptr) ReportSimplifiedSteps(o, in.image, *in.steps);
    return SimplifiedEnhance(o, in.image);
  };
  e.rgb_native = true;
  return e;
}

}  // namespace

std::vector<MethodEntry> PaperMethodEntries() {
  return {FullEntry("full"), FullEntry("full_literal"), FullEntry("full_matched"),
          FullEntry("full_physical"), SimplifiedEntry()};
}

}  // namespace turbid
