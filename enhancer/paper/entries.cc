// Registry entries of the paper's methods: full, its variants and simplified.
#include "enhancer/paper/entries.h"

#include <string>

#include "enhancer/method.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/params.h"
#include "enhancer/paper/simplified.h"

namespace turbid {
namespace {

using paper_internal::BindSimplified;
using paper_internal::ClahePar;

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
  e.info.params = {
      Param("denoise", d.denoise, "step 1: guided-filter denoise (eq. 4)"),
      Param("denoise_radius", d.denoise_radius, "guided filter k, pixels (paper: 4)",
            SizeBound::kRadius),
      Param("denoise_eps", d.denoise_eps, "guided filter epsilon on [0,1] data (paper: 0.1^2)"),
      Param("denoise_adaptive", d.denoise_adaptive,
            "epsilon scaled by t_med^2, floored at (factor * noise sigma)^2 (false: as given)"),
      Param("denoise_noise_factor", d.denoise_noise_factor,
            "adaptive denoise: multiple of the Immerkaer noise estimate, [0, 100]"),
      Param("light", d.light, "step 2: artificial-light estimate (eq. 5; lights from the sidecar)"),
      Param("light_scaling", d.light_scaling,
            "blind: scale estimated from the veil | range: E_L mapped onto [min I, max I] (paper "
            "as written) | physical: E_L as modelled (privileged)"),
      Param("light_scale_percentile", d.light_scale_percentile,
            "blind: percentile of I_de / ((1 - t) L), %, (0, 50]"),
      Param("light_scale_support", d.light_scale_support,
            "blind: share of max (1 - t) L a pixel needs to count, (0, 1)"),
      Param("light_subsample", d.light_subsample, "E_L and t computed at 1/this size, [1, 64]"),
      Param("dehaze", d.dehaze, "step 3: plane-induced dehazing (eq. 6)"),
      Param("beta_per_m", d.beta_per_m,
            "attenuation in t = exp(-beta r), 1/m (paper: 0.7); setting it implies beta_source "
            "fixed"),
      Param("beta_source", d.beta_source,
            "fixed: beta_per_m | auto: the sidecar's water (per channel) when given (privileged)"),
      Param("t_min", d.t_min, "lower clamp on t in eq. 6, (0, 1]"),
      Param("exposure_percentile", d.exposure_percentile,
            "J_plane divided by this percentile when above 1 (0: clip), [0, 100]"),
      Param("keep_detail", d.keep_detail,
            "weight of the denoising residual added back after dehazing (0: discarded), [0, 10]"),
      Param("plane", d.plane, "plane source: auto | dvl | depth | scene | frontal"),
      Param("frontal_distance_m", d.frontal_distance_m,
            "distance of the fallback frontal plane, m"),
      Param("max_range_m", d.max_range_m, "range where a ray misses the plane, m"),
      Param("deblur", d.deblur, "step 4: PSF deconvolution (eq. 7)"),
      Param("psf_optical_thickness", d.psf_optical_thickness, "PSF T (paper: 4)"),
      Param("psf_forward_scatter", d.psf_forward_scatter, "PSF q (paper: 0.9)"),
      Param("deconvolution", DeconvolutionMethodName(d.deconvolution.method),
            "wiener | richardson_lucy"),
      Param("nsr", d.deconvolution.nsr, "Wiener noise-to-signal ratio, [1e-8, 10]"),
      Param("iterations", d.deconvolution.iterations, "Richardson-Lucy iterations, [1, 1000]"),
      Param("contrast", d.contrast, "step 5: CLAHE"),
      Param("clahe_target_mean", d.clahe_target_mean,
            "CLAHE alpha chosen per image so the output keeps the restored image's mean (at "
            "least clahe_min_mean) instead of clahe_alpha; naming clahe_alpha implies false"),
      Param("clahe_min_mean", d.clahe_min_mean,
            "floor of the kept mean (an underexposed image is brought up to it), [0, 0.6]"),
  };
  for (MethodParam& p : ClahePar("clahe_", d.clahe)) e.info.params.push_back(p);
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
  e.info.params = {
      Param("fine_radius", d.fine_radius, "k_f, pixels (paper: 2)", SizeBound::kRadius),
      Param("fine_eps", d.fine_eps, "sigma_f on [0,1] data (paper: 0.1^2)"),
      Param("coarse_radius", d.coarse_radius, "k_g, pixels (paper: 8)", SizeBound::kRadius),
      Param("coarse_eps", d.coarse_eps, "sigma_g on [0,1] data (paper: 0.4^2)"),
      Param("coarse_subsample", d.coarse_subsample, "fast guided filter ratio for I_g, 1 = exact"),
      Param("alpha", d.alpha, "detail amplification (paper: 5)"),
      Param("contrast", d.contrast, "CLAHE after the detail boost"),
  };
  for (MethodParam& p : ClahePar("clahe_", d.clahe)) e.info.params.push_back(p);
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
