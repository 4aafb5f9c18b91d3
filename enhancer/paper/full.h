// `full`, the paper's full model (§III-A): guided-filter denoise (eq. 4) -> artificial-light
// estimate from the light model (eq. 5, simulator/light.h) on the fitted plane, scaled into image
// units -> plane-induced dehazing (eq. 6, t = exp(-beta r) clamped) -> PSF deconvolution (eq. 7,
// simulator/psf.h) -> CLAHE with a Rayleigh target (§III-A.5). `simplified` (§III-B):
// enhancer/paper/simplified.h; the registry entries: enhancer/paper/entries.h; the oracles:
// enhancer/oracle.h.
// Inputs float32 linear [0,1], 1 or 3 channels; outputs the same size and channels in [0,1].
// docs/methods.md has formulas, defaults, the geometry fallbacks and the choices the paper leaves
// open.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/deconvolution.h"
#include "enhancer/registry.h"
#include "scenes/camera_encoding.h"
#include "scenes/scene.h"
#include "simulator/light.h"
#include "simulator/render_record.h"

namespace turbid {

// Where the dehazing plane comes from: "auto" (DVL points if >= 3, else RANSAC on the scene depth,
// else the scene's dominant plane, else frontal), "dvl", "depth", "scene", "frontal" (a plane
// facing the camera at frontal_distance_m).
//
// What `full` reads (docs/methods.md, "Which inputs each method sees"): the image; the plane (DVL
// points, or a plane fitted to the scene's depth, as the paper's DVL gives); the camera; the LED
// geometry (position, axis, half-power angle, colour) from the vehicle's specification, which
// turbid takes from the render sidecar's `options.light` when one is given. With the default
// `light_scaling=blind` the LED power is not used: its scale is estimated from the image. Reading
// the water's beta (`beta_source=auto`) or the light's power in image units
// (`light_scaling=physical`) makes the method privileged (IsPrivileged in enhancer/registry.h).
// Where step 5 equalises (clahe_domain, docs/methods.md "The CLAHE domain"):
//   kEncoded — the camera-coded image: the restored linear image is clipped to [0, 1], coded with
//              the camera's transfer curve (the render sidecar's camera.encoding; sRGB when the
//              method is given no sidecar camera), equalised there (the paper's adapthisteq on its
//              camera's 8-bit frames, Rayleigh alpha 0.4) and decoded back to linear. The default.
//   kLinear  — linear light, as before issue 32 (with blind `full`'s alpha 0.3 when the key is
//              named in JSON without clahe_alpha: FullOptionsFromJson).
enum class ClaheDomain { kEncoded, kLinear };
std::string ClaheDomainName(ClaheDomain domain);  // "encoded" / "linear"

// CLAHE of blind `full` with clahe_domain linear (the default before issue 32): adapthisteq's
// defaults with Rayleigh alpha 0.3.
inline ClaheOptions LinearDomainFullClahe() {
  ClaheOptions c;
  c.alpha = 0.3;
  return c;
}
// The alpha blind `full` uses with clahe_domain linear unless clahe_alpha is named.
inline constexpr double kLinearDomainFullAlpha = 0.3;

struct FullOptions {
  bool denoise = true;        // step 1 (§III-A.1)
  int denoise_radius = 4;     // guided filter k, pixels, >= 1 (paper: 4)
  double denoise_eps = 0.01;  // guided filter epsilon on [0,1] data, > 0 (paper: 0.1^2)
  // Haze-adaptive epsilon: texture of contrast dJ appears in I as t dJ (eq. 4), so the epsilon
  // that keeps in I what denoise_eps keeps in J is denoise_eps * t_med^2 (t_med: the median
  // transmission on the plane); never below (denoise_noise_factor * sigma_n)^2, sigma_n the
  // image's noise estimated after Immerkaer 1996, nor above denoise_eps. false: denoise_eps as is
  // (the paper read literally).
  bool denoise_adaptive = true;
  double denoise_noise_factor = 3.0;  // multiple of the noise estimate (3-sigma rule), [0, 100]
  bool light = true;                  // step 2 (§III-A.2); also skipped when there are no lights
  // How the light model's units map to pixel values:
  //   "blind"    — E_L = a_c L per channel, a_c estimated from the image as the largest scale the
  //                veil can have where it dominates: a low percentile (light_scale_percentile) of
  //                I_de / ((1 - t) L) over the pixels where (1 - t) L >= light_scale_support of its
  //                maximum (docs/methods.md, "Blind light scale"). The default.
  //   "range"    — E_L mapped per channel onto [min I_de, max I_de] (§III-A.2 read literally);
  //   "physical" — E_L from the light model as is (U0 calibrated in image units, as the
  //                simulator's are): privileged.
  std::string light_scaling = "blind";
  double light_scale_percentile = 1.0;  // blind: percentile of the ratio, %, (0, 50]
  double light_scale_support = 0.25;    // blind: share of max (1 - t) L a pixel needs, (0, 1)
  int light_subsample = 8;  // E_L and t computed at 1/this resolution, upsampled (smooth), [1, 64]
  bool dehaze = true;       // step 3 (§III-A.3)
  double beta_per_m = 0.7;  // attenuation for t = exp(-beta r), 1/m, [0, 10] (paper: 0.7)
  // Where beta comes from: "fixed" — always beta_per_m (the paper's single tuned value; the
  // default); "auto" — the water of a render sidecar when one is given (per channel,
  // options.water: beta_rgb_per_m / beta_gray_per_m, as rendered), else beta_per_m: privileged.
  std::string beta_source = "fixed";
  // Transmission clamp in eq. 6, (0, 1]. Blind `full` fixes beta at 0.7 /m whatever the water:
  // where it is clearer, exp(-0.7 r) underestimates t and eq. 6 amplifies noise by 1/t. 0.3 caps
  // that gain at 3.3 (docs/methods.md, "The transmission floor"); the variants use 0.1.
  double t_min = 0.3;
  // Exposure after dehazing: when the `exposure_percentile` percentile of J_plane (all channels)
  // exceeds 1, J_plane is divided by it, so that the lit radiance eq. 6 returns is not clipped
  // before CLAHE (the paper's concern, "prevented from being over-saturated", §III-A.2). 0: off
  // (values above 1 clip). [0, 100].
  double exposure_percentile = 99.5;
  // Weight of the denoising residual I - I_de added back after dehazing (at its input amplitude,
  // not divided by t), [0, 10]; 0: discarded (the paper). 0.3: keeps the input's visible edges
  // (Hautiere e >= 0) at a small cost in SSIM (docs/methods.md, "Blind full: choices measured").
  double keep_detail = 0.3;
  std::string plane = "auto";          // plane source, see above
  double frontal_distance_m = 2.0;     // distance of the fallback frontal plane, metres, > 0
  double max_range_m = 20.0;           // range used where a ray misses the plane, metres, > 0
  bool deblur = true;                  // step 4 (§III-A.4); skipped when the PSF is a delta
  double psf_optical_thickness = 4.0;  // T (paper: 4)
  double psf_forward_scatter = 0.9;    // q (paper: 0.9)
  DeconvolutionOptions deconvolution;  // Wiener, NSR 0.01
  bool contrast = true;                // step 5 (§III-A.5)
  // Where CLAHE equalises (above): the camera-coded image, as the paper did, by default.
  ClaheDomain clahe_domain = ClaheDomain::kEncoded;
  // 8x8 tiles, clip 0.01, 256 bins, Rayleigh alpha 0.4: adapthisteq's defaults, the paper's. The
  // paper equalised camera-encoded frames, where Rayleigh(0.4) has a mean of 0.47 coded, 0.25 in
  // linear light. With clahe_domain linear, blind `full` used alpha 0.3 (a linear mean of 0.37;
  // docs/methods.md, "The CLAHE target"), which JSON's {"clahe_domain": "linear"} restores.
  ClaheOptions clahe;
  // Brightness-keeping CLAHE target (ClaheOptions::keep_mean): alpha chosen per image so that the
  // mapped mean is max(mean entering CLAHE, clahe_min_mean) instead of the fixed clahe.alpha, whose
  // Rayleigh(0.4) target lifts every restored scene towards mid-grey. Off by default: which is
  // better depends on how bright the ground truth is, which a blind method cannot know (measured
  // both ways in docs/methods.md, "Blind full: choices measured"). Naming clahe_alpha implies off.
  bool clahe_target_mean = false;
  // clahe_target_mean's floor; 0.18 is photographic middle grey (the linear reflectance
  // reflected-light meters are calibrated to).
  double clahe_min_mean = 0.18;
  bool Check(std::string* why) const;
};

// The registry's variants of `full` (one options struct, different defaults):
//   full          blind light scale, beta 0.7 fixed, exposure kept in range;
//   full_literal  the paper as written: E_L fitted into [min I, max I], beta 0.7, clipped;
//   full_matched  blind light scale, beta from the render sidecar's water (privileged);
//   full_physical E_L in the simulator's image units and the sidecar's beta (privileged).
FullOptions FullVariantDefaults(const std::string& variant);

struct FullResult {
  cv::Mat image;             // final output, [0,1]
  cv::Mat denoised;          // I_de (eq. 4)
  double denoise_eps = 0.0;  // the epsilon the denoising used
  double noise_sigma = 0.0;  // Immerkaer's noise estimate of the input (adaptive denoise)
  cv::Mat light;             // estimated E_L (scaled), image channels; empty when skipped
  cv::Mat range_m;           // plane-induced range along the ray, CV_32FC1; empty when skipped
  cv::Mat transmission;  // exp(-beta r) clamped, CV_32FC1 (one beta) or image channels (beta per
                         // channel differs); empty when skipped
  std::vector<double> beta_per_m;  // beta used per image channel ({gray} or {B, G, R})
  std::string beta_source;         // "sidecar water" or "beta_per_m"
  // Per image channel: E_L = light_scale * (light model with the specification's U0); from the
  // blind estimate, or the range fit's slope, or 1 (physical). Empty when the light step is off.
  std::vector<double> light_scale;
  double exposure_scale = 1.0;  // J_plane was divided by this before deblurring (>= 1)
  double clahe_alpha = 0.0;     // the CLAHE target parameter used (0 when CLAHE is off)
  // The curve CLAHE equalised through: the camera's encoding (clahe_domain encoded) or kLinear
  // (clahe_domain linear, or a linear camera); clahe_encoding_source says where it came from.
  CameraEncoding clahe_encoding = CameraEncoding::kLinear;
  std::string clahe_encoding_source;
  cv::Mat dehazed;              // J_plane (eq. 6), after the exposure scale
  cv::Mat deblurred;            // J_deblur
  std::optional<Plane> plane;
  std::string plane_source;        // which source gave the plane
  std::vector<std::string> steps;  // what ran / what was skipped and why
};

// Blind light scale (docs/methods.md, "Blind light scale"), per channel of `denoised`:
//   bound — the `percentile` (%) of I_de / w over the pixels where w = (1 - t) L >= support * max
//   w:
//           the largest scale for which I_de - (1 - t) a L >= 0 holds (J >= 0), robustly;
//   fit   — a of the least-squares fit I_de = u t + a (1 - t) L + a rho (t L) over every sampled
//           pixel (eq. 2 with a constant mean reflectance rho and ambient term u), trimmed of its
//           20% worst residuals; usable when a > 0 and 0 <= rho <= 1;
//   scale — min(fit, bound) (the bound alone when the fit is unusable).
// `light` has the channels of `denoised` (or one), `transmission` one or the image's channels.
// Channels without support get 0. Pixels are sampled on a stride-`stride` grid; 0: the largest
// stride that keeps >= 65,536 samples (4 at 1360x1024, 2 at 640x480, 1 below 512x256).
struct LightScaleEstimate {
  double scale = 0.0, bound = 0.0, fit = 0.0;
  std::string source = "none";  // "fit", "bound" or "bound (no usable fit)"
};
std::vector<LightScaleEstimate> EstimateLightScale(const cv::Mat& denoised, const cv::Mat& light,
                                                   const cv::Mat& transmission, double percentile,
                                                   double support, int stride = 0);

// Geometry: `scene` (may be null), the sidecar's light options and camera (may be null).
FullResult FullEnhanceDetailed(const FullOptions& options, const cv::Mat& image, const Scene* scene,
                               const RenderRecord* sidecar);
cv::Mat FullEnhance(const FullOptions& options, const cv::Mat& image, const Scene* scene,
                    const RenderRecord* sidecar);

// Reports FullEnhanceDetailed's intermediates to `sink` under the names `turbid enhance
// --dump-steps` writes: 01_denoised, 02_light, 02_veil_removed (I_de - (1 - t) E_L, the veil
// removed before dividing by t), 03_range_m, 03_transmission, 04_dehazed, 05_deblurred; and the
// notes steps, light_scale, exposure_scale, clahe_alpha and plane.
void ReportFullSteps(const FullResult& r, StepSink& sink);

// Strict binding of a JSON params object (registry keys, `turbid enhance --list`) onto FullOptions
// (starting from the defaults of `variant`, "full" unless said); throws Error naming the key.
FullOptions FullOptionsFromJson(const nlohmann::json& params, const std::string& variant = "full");
// True when options with these settings read true simulation parameters (sidecar water or the
// light's power in image units).
bool FullOptionsArePrivileged(const FullOptions& options);

// Artificial-light estimate (§III-A.2): E_L from IrradianceMap on the plane (every surface normal
// = the plane normal), at 1/subsample resolution then upsampled bilinearly; with `range_scaling`
// each channel is mapped linearly onto [min, max] of that channel of `reference` (a constant E_L
// maps to the minimum). beta_per_m: one value for every channel, or one per channel of
// `reference` (image order). Returns image channels of `reference`.
cv::Mat EstimateArtificialLight(const IrradianceOptions& lights, const Plane& plane,
                                const CameraIntrinsics& camera,
                                const std::vector<double>& beta_per_m, const cv::Mat& reference,
                                bool range_scaling, int subsample, double max_range_m);

}  // namespace turbid
