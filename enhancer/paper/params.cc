// The parameters of `full` (and its variants) and `simplified`: one field table each (core/fields.h)
// onto FullOptions and SimplifiedOptions, with the CLAHE and deconvolution keys they share.
#include "enhancer/paper/params.h"

#include <string>

#include "core/error.h"
#include "enhancer/method.h"
#include "enhancer/params.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/simplified.h"

namespace turbid {
namespace paper_internal {
namespace {

constexpr int kRadius = static_cast<int>(SizeBound::kRadius);
constexpr int kPerAxis = static_cast<int>(SizeBound::kPerAxis);

const Fields<DeconvolutionOptions>& DeconvolutionFields() {
  using O = DeconvolutionOptions;
  using M = DeconvolutionMethod;
  static const Fields<O> fields =
      Fields<O>()
          .Choice("deconvolution", &O::method,
                  {{DeconvolutionMethodName(M::kWiener), M::kWiener},
                   {DeconvolutionMethodName(M::kRichardsonLucy), M::kRichardsonLucy}},
                  "wiener | richardson_lucy")
          .Member("nsr", &O::nsr, "Wiener noise-to-signal ratio, [1e-8, 10]")
          .Member("iterations", &O::iterations, "Richardson-Lucy iterations, [1, 1000]");
  return fields;
}

}  // namespace

const Fields<ClaheOptions>& ClaheFields() {
  using O = ClaheOptions;
  using D = ClaheDistribution;
  static const Fields<O> fields =
      Fields<O>()
          .Member("tiles_x", &O::tiles_x, "CLAHE tiles along x, >= 2 (adapthisteq: 8)")
          .Tag(kPerAxis)
          .Member("tiles_y", &O::tiles_y, "CLAHE tiles along y, >= 2 (adapthisteq: 8)")
          .Tag(kPerAxis)
          .Member("clip_limit", &O::clip_limit, "CLAHE clip limit as a fraction, [0,1] (0.01)")
          .Member("bins", &O::bins, "CLAHE histogram bins, [2, 65536] (256)")
          .Choice("distribution", &O::distribution,
                  {{ClaheDistributionName(D::kUniform), D::kUniform},
                   {ClaheDistributionName(D::kRayleigh), D::kRayleigh},
                   {ClaheDistributionName(D::kExponential), D::kExponential}},
                  "CLAHE target: uniform | rayleigh | exponential (paper: rayleigh)")
          .Member("alpha", &O::alpha, "Rayleigh/exponential parameter, > 0 (paper: 0.4)");
  return fields;
}

const Fields<FullOptions>& FullFields() {
  using O = FullOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("denoise", &O::denoise, "step 1: guided-filter denoise (eq. 4)")
          .Member("denoise_radius", &O::denoise_radius, "guided filter k, pixels (paper: 4)")
          .Tag(kRadius)
          .Member("denoise_eps", &O::denoise_eps,
                  "guided filter epsilon on [0,1] data (paper: 0.1^2)")
          .Member("denoise_adaptive", &O::denoise_adaptive,
                  "epsilon scaled by t_med^2, floored at (factor * noise sigma)^2 (false: as given)")
          .Member("denoise_noise_factor", &O::denoise_noise_factor,
                  "adaptive denoise: multiple of the Immerkaer noise estimate, [0, 100]")
          .Member("light", &O::light,
                  "step 2: artificial-light estimate (eq. 5; lights from the sidecar)")
          .Member("light_scaling", &O::light_scaling,
                  "blind: scale estimated from the veil | range: E_L mapped onto [min I, max I] "
                  "(paper as written) | physical: E_L as modelled (privileged)")
          .Member("light_scale_percentile", &O::light_scale_percentile,
                  "blind: percentile of I_de / ((1 - t) L), %, (0, 50]")
          .Member("light_scale_support", &O::light_scale_support,
                  "blind: share of max (1 - t) L a pixel needs to count, (0, 1)")
          .Member("light_subsample", &O::light_subsample,
                  "E_L and t computed at 1/this size, [1, 64]")
          .Member("dehaze", &O::dehaze, "step 3: plane-induced dehazing (eq. 6)")
          .Member("beta_per_m", &O::beta_per_m,
                  "attenuation in t = exp(-beta r), 1/m (paper: 0.7); setting it implies "
                  "beta_source fixed")
          .Member("beta_source", &O::beta_source,
                  "fixed: beta_per_m | auto: the sidecar's water (per channel) when given "
                  "(privileged)")
          .Member("t_min", &O::t_min, "lower clamp on t in eq. 6, (0, 1]")
          .Member("exposure_percentile", &O::exposure_percentile,
                  "J_plane divided by this percentile when above 1 (0: clip), [0, 100]")
          .Member("keep_detail", &O::keep_detail,
                  "weight of the denoising residual added back after dehazing (0: discarded), "
                  "[0, 10]")
          .Member("plane", &O::plane, "plane source: auto | dvl | depth | scene | frontal")
          .Member("frontal_distance_m", &O::frontal_distance_m,
                  "distance of the fallback frontal plane, m")
          .Member("max_range_m", &O::max_range_m, "range where a ray misses the plane, m")
          .Member("deblur", &O::deblur, "step 4: PSF deconvolution (eq. 7)")
          .Member("psf_optical_thickness", &O::psf_optical_thickness, "PSF T (paper: 4)")
          .Member("psf_forward_scatter", &O::psf_forward_scatter, "PSF q (paper: 0.9)")
          .Nested("", &O::deconvolution, DeconvolutionFields())
          .Member("contrast", &O::contrast, "step 5: CLAHE")
          .Choice("clahe_domain", &O::clahe_domain,
                  {{ClaheDomainName(ClaheDomain::kEncoded), ClaheDomain::kEncoded},
                   {ClaheDomainName(ClaheDomain::kLinear), ClaheDomain::kLinear}},
                  "encoded: CLAHE on the camera-coded image (the sidecar camera's encoding, sRGB "
                  "without one), decoded back to linear | linear: on linear light (before issue "
                  "32; `full` then uses clahe_alpha 0.3 unless it is named)")
          .Member("clahe_target_mean", &O::clahe_target_mean,
                  "CLAHE alpha chosen per image so the output keeps the restored image's mean (at "
                  "least clahe_min_mean) instead of clahe_alpha; naming clahe_alpha implies false")
          .Member("clahe_min_mean", &O::clahe_min_mean,
                  "floor of the kept mean (an underexposed image is brought up to it), linear, "
                  "[0, 0.6]; clahe_domain encoded: coded with the camera's curve")
          .Nested("clahe_", &O::clahe, ClaheFields());
  return fields;
}

const Fields<SimplifiedOptions>& SimplifiedFields() {
  using O = SimplifiedOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("fine_radius", &O::fine_radius, "k_f, pixels (paper: 2)")
          .Tag(kRadius)
          .Member("fine_eps", &O::fine_eps, "sigma_f on [0,1] data (paper: 0.1^2)")
          .Member("coarse_radius", &O::coarse_radius, "k_g, pixels (paper: 8)")
          .Tag(kRadius)
          .Member("coarse_eps", &O::coarse_eps, "sigma_g on [0,1] data (paper: 0.4^2)")
          .Member("coarse_subsample", &O::coarse_subsample,
                  "fast guided filter ratio for I_g, 1 = exact")
          .Member("alpha", &O::alpha, "detail amplification (paper: 5)")
          .Member("contrast", &O::contrast, "CLAHE after the detail boost")
          .Nested("clahe_", &O::clahe, ClaheFields());
  return fields;
}

SimplifiedOptions BindSimplified(const nlohmann::json& params) {
  return ReadMethodParams("simplified", params, SimplifiedFields());
}

}  // namespace paper_internal

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
  if (params.is_object()) {
    // A beta the user names is the beta they want: it wins over a sidecar's water unless
    // beta_source says otherwise (read after this, it overrides).
    if (params.contains("beta_per_m")) o.beta_source = "fixed";
    // An alpha the user names is the alpha they want, unless clahe_target_mean says otherwise.
    if (params.contains("clahe_alpha")) o.clahe_target_mean = false;
  }
  o = ReadMethodParams(variant, params, paper_internal::FullFields(), o);
  // clahe_domain linear named without clahe_alpha: blind `full` as before issue 32, bit for bit.
  const bool alpha_named = params.is_object() && params.contains("clahe_alpha");
  if (variant == "full" && o.clahe_domain == ClaheDomain::kLinear && !alpha_named) {
    o.clahe.alpha = kLinearDomainFullAlpha;
  }
  return o;
}

std::string ClaheDomainName(ClaheDomain domain) {
  return domain == ClaheDomain::kEncoded ? "encoded" : "linear";
}

}  // namespace turbid
