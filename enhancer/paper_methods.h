// The paper's enhancement methods (§III) and the simulator-inverting oracle:
//   full       — §III-A: guided-filter denoise (eq. 4) -> artificial-light estimate from the light
//                model (eq. 5, simulator/light.h) on the fitted plane, scaled into [min I, max I]
//                -> plane-induced dehazing (eq. 6, t = exp(-beta r) clamped) -> PSF deconvolution
//                (eq. 7, simulator/psf.h) -> CLAHE with a Rayleigh target (§III-A.5);
//   simplified — §III-B: I_g + alpha (I_f - I_g) (eqs. 8-9), I_f = GIF_{2,0.1^2}(I),
//                I_g = GIF_{8,0.4^2}(I), then CLAHE;
//   oracle     — inverts the renderer (simulator/render.h) with the true parameters from a render's
//                sidecar and the scene: subtracts the marine snow it re-renders from the seed and
//                the veil, divides by t, deconvolves with the true PSF and divides by E_A + E_L.
// Inputs float32 linear [0,1], 1 or 3 channels; outputs the same size and channels in [0,1].
// docs/methods.md has formulas, defaults, the geometry fallbacks and the choices the paper leaves
// open.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "enhancer/clahe.h"
#include "enhancer/deconvolution.h"
#include "scenes/scene.h"
#include "simulator/light.h"

namespace turbid {

struct MethodEntry;

// Where the dehazing plane comes from: "auto" (DVL points if >= 3, else RANSAC on the scene depth,
// else the scene's dominant plane, else frontal), "dvl", "depth", "scene", "frontal" (a plane
// facing the camera at frontal_distance_m).
struct FullOptions {
  bool denoise = true;        // step 1 (§III-A.1)
  int denoise_radius = 4;     // guided filter k, pixels, >= 1 (paper: 4)
  double denoise_eps = 0.01;  // guided filter epsilon on [0,1] data, > 0 (paper: 0.1^2)
  bool light = true;          // step 2 (§III-A.2); also skipped when there are no lights
  // "range": E_L scaled per channel into [min I_de, max I_de] (the paper); "physical": E_L from
  // the light model as is (U0 calibrated in image units, as the simulator's are).
  std::string light_scaling = "range";
  int light_subsample = 8;  // E_L and t computed at 1/this resolution, upsampled (smooth), [1, 64]
  bool dehaze = true;       // step 3 (§III-A.3)
  double beta_per_m = 0.7;  // attenuation for t = exp(-beta r), 1/m, [0, 10] (paper: 0.7)
  // Where beta comes from: "auto" — the water of a render sidecar when one is given (per channel,
  // options.water: beta_rgb_per_m / beta_gray_per_m, as rendered), else beta_per_m; "fixed" —
  // always beta_per_m (the paper's single tuned value).
  std::string beta_source = "auto";
  double t_min = 0.1;                  // transmission clamp in eq. 6, (0, 1]
  std::string plane = "auto";          // plane source, see above
  double frontal_distance_m = 2.0;     // distance of the fallback frontal plane, metres, > 0
  double max_range_m = 20.0;           // range used where a ray misses the plane, metres, > 0
  bool deblur = true;                  // step 4 (§III-A.4); skipped when the PSF is a delta
  double psf_optical_thickness = 4.0;  // T (paper: 4)
  double psf_forward_scatter = 0.9;    // q (paper: 0.9)
  DeconvolutionOptions deconvolution;  // Wiener, NSR 0.01
  bool contrast = true;                // step 5 (§III-A.5)
  ClaheOptions clahe;                  // 8x8 tiles, clip 0.01, 256 bins, Rayleigh, alpha 0.4
  bool Check(std::string* why) const;
};

struct FullResult {
  cv::Mat image;         // final output, [0,1]
  cv::Mat denoised;      // I_de (eq. 4)
  cv::Mat light;         // estimated E_L (scaled), image channels; empty when skipped
  cv::Mat range_m;       // plane-induced range along the ray, CV_32FC1; empty when skipped
  cv::Mat transmission;  // exp(-beta r) clamped, CV_32FC1 (one beta) or image channels (beta per
                         // channel differs); empty when skipped
  std::vector<double> beta_per_m;  // beta used per image channel ({gray} or {B, G, R})
  std::string beta_source;         // "sidecar water" or "beta_per_m"
  cv::Mat dehazed;                 // J_plane (eq. 6)
  cv::Mat deblurred;               // J_deblur
  std::optional<Plane> plane;
  std::string plane_source;        // which source gave the plane
  std::vector<std::string> steps;  // what ran / what was skipped and why
};

// Geometry: `scene` (may be null), the sidecar's light options and camera (may be null).
FullResult FullEnhanceDetailed(const FullOptions& options, const cv::Mat& image, const Scene* scene,
                               const nlohmann::json* sidecar);
cv::Mat FullEnhance(const FullOptions& options, const cv::Mat& image, const Scene* scene,
                    const nlohmann::json* sidecar);

// Strict binding of a JSON params object (registry keys, `turbid enhance --list`) onto FullOptions;
// throws Error naming the key.
FullOptions FullOptionsFromJson(const nlohmann::json& params);

// Artificial-light estimate (§III-A.2): E_L from IrradianceMap on the plane (every surface normal
// = the plane normal), at 1/subsample resolution then upsampled bilinearly; with `range_scaling`
// each channel is mapped linearly onto [min, max] of that channel of `reference` (a constant E_L
// maps to the minimum). beta_per_m: one value for every channel, or one per channel of
// `reference` (image order). Returns image channels of `reference`.
cv::Mat EstimateArtificialLight(const IrradianceOptions& lights, const Plane& plane,
                                const CameraIntrinsics& camera,
                                const std::vector<double>& beta_per_m, const cv::Mat& reference,
                                bool range_scaling, int subsample, double max_range_m);

struct SimplifiedOptions {
  int fine_radius = 2;       // k_f, pixels (paper: 2)
  double fine_eps = 0.01;    // sigma_f on [0,1] data (paper: 0.1^2)
  int coarse_radius = 8;     // k_g, pixels (paper: 8)
  double coarse_eps = 0.16;  // sigma_g (paper: 0.4^2)
  int coarse_subsample = 1;  // fast guided filter ratio for I_g, [1, 8] (1: exact)
  double alpha = 5.0;        // detail amplification, [0, 100] (paper: 5)
  bool contrast = true;      // CLAHE after the detail boost
  ClaheOptions clahe;        // as in `full` (Rayleigh, alpha 0.4)
  bool Check(std::string* why) const;
};
cv::Mat SimplifiedEnhance(const SimplifiedOptions& options, const cv::Mat& image);

struct OracleOptions {
  // "clean": recover rho (the scoring ground truth); "lit": recover J = (E_A + E_L) rho.
  std::string target = "clean";
  bool remove_snow = true;         // re-render the marine snow from the seed and subtract it
  double nsr = 1e-3;               // Wiener NSR for the true PSF, [1e-8, 10]
  double min_transmission = 1e-3;  // floor on t when dividing, (0, 1]
  double min_irradiance = 1e-3;    // floor on E_A + E_L when dividing, > 0
  bool Check(std::string* why) const;
};
// Needs the scene the render was made from (same size and channels) and its sidecar.
cv::Mat OracleEnhance(const OracleOptions& options, const cv::Mat& image, const Scene& scene,
                      const nlohmann::json& sidecar);

// Registry entries for full, simplified and oracle.
std::vector<MethodEntry> PaperMethodEntries();

}  // namespace turbid
