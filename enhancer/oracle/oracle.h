// The oracles: privileged references that read every true parameter of a render (its sidecar and
// the scene it was made from) and estimate the clean image rho of the forward model
// (docs/model.md, simulator/render.h):
//   I = [J * h](x) t(x) + (1 - t(x)) (E_L(x) + B_inf) + S(x) + n(x),   J = (E_A + E_L) rho.
//   oracle_exact — the algebraic inverse: subtract the re-rendered marine snow S and the veil,
//                  divide by t, undo the blur exactly (reflect-101 borders, as the renderer
//                  blurs; range-dependent PSF by preconditioned fixed-point iteration), divide by
//                  E_A + E_L. Float precision on noise-free float renders; amplifies noise by
//                  1 / (t (E_A + E_L)), so it is a poor reference once there is noise.
//   oracle       — the oracle-parameter LMMSE reference (a strong reference, not a bound: its
//                  prior is estimated locally): the same model, inverted with the known Poisson-Gaussian noise
//                  variance (Foi et al., IEEE TIP 2008) as a linear MMSE (Wiener) estimate: a
//                  hierarchical local-Gaussian prior on rho (adaptive Wiener filter, Lee, IEEE
//                  PAMI 1980; Kuan et al., IEEE PAMI 1985, with the known per-pixel noise
//                  variance), then Wiener deconvolution of the true PSF (Gonzalez & Woods §5.8)
//                  with the noise-to-signal ratio that is left. Pixels with t below a floor (open
//                  water, invalid depth) are masked: set to the local prior mean, counted.
// docs/methods.md ("oracle") has the formulas and the choices.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scenes/scene.h"
#include "simulator/render_record.h"

namespace turbid {

struct MethodEntry;

struct OracleExactOptions {
  // "clean": recover rho (the scoring ground truth); "lit": recover J = (E_A + E_L) rho.
  std::string target = "clean";
  bool remove_snow = true;         // re-render the marine snow from the seed and subtract it
  double min_transmission = 1e-6;  // floor on t when dividing, (0, 1]
  double min_irradiance = 1e-6;    // floor on E_A + E_L when dividing, > 0
  // Range-dependent PSF: fixed-point iterations x += P (b - A x), P the per-pixel blend of the
  // levels' exact inverses, until max |b - A x| <= tolerance or this many iterations, [1, 1000].
  int max_iterations = 100;
  double tolerance = 1e-7;  // residual in image units, [0, 1]
  bool Check(std::string* why) const;
};

struct OracleOptions {
  std::string target = "clean";  // as in OracleExactOptions
  bool remove_snow = true;       // re-render the marine snow from the seed and subtract it
  // Pixels with t below this (every channel's t, open water, invalid depth) are masked: no data
  // is read there; they get the prior mean. (0, 1).
  double mask_transmission = 1e-3;
  // Window radii of the prior's levels, pixels, coarse to fine (each >= 1, strictly decreasing):
  // the prior mean at a level is the inverse-variance-weighted mean over its window, shrunk
  // towards the next coarser level's in proportion to how well the data determine it.
  int coarse_radius = 16;
  int middle_radius = 4;
  int pixel_radius = 2;  // window of the per-pixel prior variance, >= 1
  bool deblur = true;    // Wiener deconvolution of the true PSF after the MMSE estimate
  bool Check(std::string* why) const;
};

struct OracleResult {
  cv::Mat image;            // estimate of rho (or J with target "lit"), [0,1]
  int masked_pixels = 0;    // pixels with t < mask (oracle) / t < min_transmission (exact)
  int iterations = 0;       // oracle_exact with a range-dependent PSF: fixed-point iterations
  double residual = 0.0;    // and the max |b - A x| they left
  double deblur_nsr = 0.0;  // oracle: the Wiener noise-to-signal ratio used for the PSF
  std::vector<std::string> steps;  // what ran and what was skipped, in order
};

// Both need the scene the render was made from (same size and channels) and its sidecar; throw
// Error otherwise.
OracleResult OracleExactEnhance(const OracleExactOptions& options, const cv::Mat& image,
                                const Scene& scene, const RenderRecord& sidecar);
OracleResult OracleEnhance(const OracleOptions& options, const cv::Mat& image, const Scene& scene,
                           const RenderRecord& sidecar);

// Reflect-101 deconvolution: the x with ConvolveReflect101(x, kernel) = image (cv::filter2D with
// BORDER_REFLECT_101, as the renderer blurs), found by the DFT of the even periodic extension
// (period 2N - 2 per axis, where reflect-101 convolution is circular), regularised by nsr
// (X = B K / (K^2 + nsr); K is real: the kernel is symmetric). Any channel count; exposed for
// tests.
cv::Mat DeconvolveReflect101(const cv::Mat& image, const cv::Mat& kernel, double nsr);

// Registry entries: oracle, oracle_exact.
std::vector<MethodEntry> OracleMethodEntries();

}  // namespace turbid
