// The JSON parameter binding of `full` (and its variants) and `simplified`: ParamBinder calls
// (enhancer/method.h) onto FullOptions and SimplifiedOptions, and the shared CLAHE parameters.
#include "enhancer/paper/params.h"

#include <string>

#include "core/error.h"
#include "enhancer/method.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/simplified.h"

namespace turbid {
namespace paper_internal {

void BindClahe(ParamBinder& b, const std::string& prefix, ClaheOptions* c, std::string* dist) {
  b.Bind(prefix + "tiles_x", &c->tiles_x);
  b.Bind(prefix + "tiles_y", &c->tiles_y);
  b.Bind(prefix + "clip_limit", &c->clip_limit);
  b.Bind(prefix + "bins", &c->bins);
  b.Bind(prefix + "distribution", dist);
  b.Bind(prefix + "alpha", &c->alpha);
}

std::vector<MethodParam> ClahePar(const std::string& prefix, const ClaheOptions& c) {
  return {
      Param(prefix + "tiles_x", c.tiles_x, "CLAHE tiles along x, >= 2 (adapthisteq: 8)",
            SizeBound::kPerAxis),
      Param(prefix + "tiles_y", c.tiles_y, "CLAHE tiles along y, >= 2 (adapthisteq: 8)",
            SizeBound::kPerAxis),
      Param(prefix + "clip_limit", c.clip_limit, "CLAHE clip limit as a fraction, [0,1] (0.01)"),
      Param(prefix + "bins", c.bins, "CLAHE histogram bins, [2, 65536] (256)"),
      Param(prefix + "distribution", ClaheDistributionName(c.distribution),
            "CLAHE target: uniform | rayleigh | exponential (paper: rayleigh)"),
      Param(prefix + "alpha", c.alpha, "Rayleigh/exponential parameter, > 0 (paper: 0.4)"),
  };
}

SimplifiedOptions BindSimplified(const nlohmann::json& params) {
  SimplifiedOptions o;
  ParamBinder b("simplified", params);
  b.Bind("fine_radius", &o.fine_radius);
  b.Bind("fine_eps", &o.fine_eps);
  b.Bind("coarse_radius", &o.coarse_radius);
  b.Bind("coarse_eps", &o.coarse_eps);
  b.Bind("coarse_subsample", &o.coarse_subsample);
  b.Bind("alpha", &o.alpha);
  b.Bind("contrast", &o.contrast);
  std::string dist = ClaheDistributionName(o.clahe.distribution);
  BindClahe(b, "clahe_", &o.clahe, &dist);
  b.FinishKeys();
  try {
    o.clahe.distribution = ClaheDistributionFromName(dist);
  } catch (const Error& e) {
    throw Error(std::string("simplified: ") + e.what());
  }
  b.Finish(o);
  return o;
}

}  // namespace paper_internal

using paper_internal::BindClahe;

FullOptions FullVariantDefaults(const std::string& variant) {
  FullOptions o;
  if (variant == "full") return o;
  // The variants keep the paper's reading of the clamp (t >= 0.1): `full_literal` is the paper as
  // written, `full_matched` / `full_physical` know the true beta (no over-correction to guard);
  // and the paper's CLAHE target, Rayleigh alpha 0.4.
  o.t_min = 0.1;
  o.clahe.alpha = ClaheOptions().alpha;
  if (variant == "full_literal") {
    o.light_scaling = "range";
    o.denoise_adaptive = false;
    o.keep_detail = 0;
    o.exposure_percentile = 0;
  } else if (variant == "full_matched") {
    o.beta_source = "auto";
  } else if (variant == "full_physical") {
    o.light_scaling = "physical";
    o.beta_source = "auto";
    o.exposure_percentile = 0;
  } else {
    throw Error("unknown variant of full '" + variant + "'");
  }
  return o;
}

bool FullOptionsArePrivileged(const FullOptions& o) {
  return o.beta_source == "auto" || o.light_scaling == "physical";
}

FullOptions FullOptionsFromJson(const nlohmann::json& params, const std::string& variant) {
  FullOptions o = FullVariantDefaults(variant);
  ParamBinder b(variant, params);
  b.Bind("denoise", &o.denoise);
  b.Bind("denoise_radius", &o.denoise_radius);
  b.Bind("denoise_eps", &o.denoise_eps);
  b.Bind("denoise_adaptive", &o.denoise_adaptive);
  b.Bind("denoise_noise_factor", &o.denoise_noise_factor);
  b.Bind("light", &o.light);
  b.Bind("light_scaling", &o.light_scaling);
  b.Bind("light_scale_percentile", &o.light_scale_percentile);
  b.Bind("light_scale_support", &o.light_scale_support);
  b.Bind("light_subsample", &o.light_subsample);
  b.Bind("dehaze", &o.dehaze);
  b.Bind("beta_per_m", &o.beta_per_m);
  // A beta the user names is the beta they want: it wins over a sidecar's water unless
  // beta_source says otherwise.
  if (params.is_object() && params.contains("beta_per_m")) o.beta_source = "fixed";
  b.Bind("beta_source", &o.beta_source);
  b.Bind("t_min", &o.t_min);
  b.Bind("exposure_percentile", &o.exposure_percentile);
  b.Bind("keep_detail", &o.keep_detail);
  b.Bind("plane", &o.plane);
  b.Bind("frontal_distance_m", &o.frontal_distance_m);
  b.Bind("max_range_m", &o.max_range_m);
  b.Bind("deblur", &o.deblur);
  b.Bind("psf_optical_thickness", &o.psf_optical_thickness);
  b.Bind("psf_forward_scatter", &o.psf_forward_scatter);
  std::string deconv = DeconvolutionMethodName(o.deconvolution.method);
  b.Bind("deconvolution", &deconv);
  b.Bind("nsr", &o.deconvolution.nsr);
  b.Bind("iterations", &o.deconvolution.iterations);
  b.Bind("contrast", &o.contrast);
  // An alpha the user names is the alpha they want, unless clahe_target_mean says otherwise.
  if (params.is_object() && params.contains("clahe_alpha")) o.clahe_target_mean = false;
  b.Bind("clahe_target_mean", &o.clahe_target_mean);
  b.Bind("clahe_min_mean", &o.clahe_min_mean);
  std::string dist = ClaheDistributionName(o.clahe.distribution);
  BindClahe(b, "clahe_", &o.clahe, &dist);
  b.FinishKeys();
  try {
    o.deconvolution.method = DeconvolutionMethodFromName(deconv);
    o.clahe.distribution = ClaheDistributionFromName(dist);
  } catch (const Error& e) {
    throw Error(variant + ": " + e.what());
  }
  b.Finish(o);
  return o;
}

}  // namespace turbid
