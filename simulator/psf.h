// Point spread function of multiple forward scattering: the generalized-Gaussian kernel of the
// paper's eq. 7, after Metari & Deschenes, "A new convolution kernel for atmospheric point spread
// function applied to computer vision", ICCV 2007:
//   h(u, v) ∝ exp(-((u^2 + v^2) / A^2)^(p/2)),   A(p, sigma) = sigma * sqrt(Gamma(1/p) /
//   Gamma(3/p)), p = sqrt(T) (T: optical thickness),          sigma = 0.5 / sqrt(q) (q:
//   forward-scatter parameter).
// The paper prints A (not A^2) under the fraction; with A^2 the kernel is dimensionally consistent
// and at p = 2 is exactly the Gaussian of standard deviation sigma, so we use A^2 (docs/model.md).
// sigma is in units of `pixels_per_unit` (default 1: sigma in pixels). The normalising constant
// 1/(2 Gamma(1 + 1/p) A) is irrelevant after the discrete kernel is normalised to sum 1.
// Gamma ratios use lgamma (stable for p -> 0). The truncation radius is where the continuous
// kernel's mass outside the radius drops below tail_mass (regularized incomplete gamma
// P(2/p, (R/A)^p)), capped by max_radius_px.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace turbid {

// "paper": eq. 7's generalized Gaussian (optical_thickness, forward_scatter, ... below).
// "small_angle": forward scatter from the water's scattering (simulator/psf_small_angle.h):
// ballistic e^{-c r} J plus a glow carrying (e^{-(c - b_f) r} - e^{-c r}) J.
enum class PsfModel { kPaper, kSmallAngle };
std::string PsfModelName(PsfModel model);  // "paper" | "small_angle"

struct PsfOptions {
  bool enabled = true;  // false: no blur (J * h = J)
  PsfModel model = PsfModel::kPaper;
  // small_angle: glow widths blurred per image (levels geometric in the angular width, the glow
  // interpolated linearly in the variance between the two around each pixel), in [2, 64].
  int glow_levels = 16;
  // Optical thickness T, dimensionless, in [1e-4, 100]. p = sqrt(T). Paper (§III-A.4): T = 4: p
  // = 2.
  double optical_thickness = 4.0;
  // Forward-scatter parameter q, in [1e-6, 1]. sigma = 0.5 / sqrt(q). Paper: q = 0.9.
  double forward_scatter = 0.9;
  // Pixels per unit of sigma, in (0, 1000]. 1: sigma is in pixels (our reading of the paper,
  // which applies the kernel in image space at 1360x1024).
  double pixels_per_unit = 1.0;
  // Continuous mass allowed outside the truncation radius, in [1e-12, 0.1].
  double tail_mass = 1e-4;
  // Hard cap on the truncation radius, pixels, in [1, 512]. The tail lost to the cap is reported
  // (Psf::truncated_mass) and the discrete kernel renormalised.
  int max_radius_px = 64;
  // The kernel counts as a delta (convolution skipped) when 1 - centre weight < this, in [0, 0.5].
  double delta_tolerance = 1e-4;
  // Optional range-dependent width: sigma(r) = sigma * sqrt(r / reference_range_m) (diffusive
  // growth of the forward-scatter blur with path length), applied by blending `depth_levels`
  // kernels. Off by default (paper: one kernel for the image).
  bool depth_dependent = false;
  double reference_range_m = 2.0;  // range at which sigma(r) = sigma, metres, in (0, 1000]
  int depth_levels = 6;            // kernels blended across the range span, in [2, 32]
  // Optional turbidity-dependent forward scatter (off by default; docs/model.md, "Turbidity-
  // dependent forward scatter"): each pixel's own optical thickness along its ray,
  // T(x) = beta_c r(x) per channel, replaces optical_thickness, and the kernel keeps the
  // unscattered share: h_T = exp(-T) delta + (1 - exp(-T)) g_T, g_T eq. 7's kernel at
  // p = sqrt(T). Near objects stay sharp, far ones blur as the water thickens. Exclusive with
  // depth_dependent.
  bool turbidity_dependent = false;
  // Kernels g_T computed per image, in [2, 64]: the distinct T values when there are at most this
  // many (exact), else levels evenly spaced in p = sqrt(T) with outputs blended linearly in p.
  int thickness_levels = 32;

  bool Check(std::string* why) const;
};

// A discrete, normalised kernel and how it was obtained.
struct Psf {
  cv::Mat kernel;         // CV_32FC1, (2R+1)x(2R+1), sums to 1, radially symmetric
  cv::Mat kernel_1d;      // CV_32FC1 column (2R+1)x1 when separable (kernel = k1 k1^T), else empty
  int radius_px = 0;      // R
  double p = 2.0;         // shape exponent p = sqrt(T)
  double sigma_px = 0.0;  // sigma in pixels
  double scale_a_px = 0.0;         // A(p, sigma) in pixels
  double tail_mass_outside = 0.0;  // continuous mass beyond R (>= tail_mass when capped)
  bool is_delta = false;           // true: applying it is the identity (skipped)
  bool separable = false;          // true when p == 2 (Gaussian)
};

// Builds the kernel for sigma scaled by width_scale (>= 0; 0 gives a delta). Throws Error when
// options fail Check.
Psf PsfKernel(const PsfOptions& options, double width_scale = 1.0);

// Continuous (unnormalised) kernel value exp(-(r/A)^p) at radius r (pixels).
double PsfProfile(double p, double scale_a_px, double r_px);

// Regularized lower incomplete gamma P(a, x) for a > 0, x >= 0 (fraction of the 2-D kernel's mass
// within radius R is P(2/p, (R/A)^p)).
double RegularizedGammaP(double a, double x);

// image * h with mirrored borders (BORDER_REFLECT_101); any number of float32 channels. A delta
// returns a copy; a separable kernel runs as two 1-D passes.
cv::Mat ApplyPsf(const Psf& psf, const cv::Mat& image);

// Range-dependent blur (options.depth_dependent): blends blurs at depth_levels widths by range.
// NaN range uses the widest level. Equals ApplyPsf(PsfKernel(options), image) when the range is
// uniform at reference_range_m.
cv::Mat ApplyDepthDependentPsf(const PsfOptions& options, const cv::Mat& image,
                               const cv::Mat& range_m);

// Turbidity-dependent forward scatter (options.turbidity_dependent): the plan for one image.
// Pixel x of channel c is blurred with h_T = e^{-T} delta + (1 - e^{-T}) g_T at its own
// T = thickness_c(x) (clamped to [1e-4, 100]; NaN, i.e. open water, takes the largest T of the
// image). g_T is eq. 7's kernel at T on the disc of radius R where (1 - e^{-T}) x its outside mass
// is below tail_mass, renormalised. Each pixel gathers with its own kernel
//   e^{-T(x)} delta + (1 - e^{-T(x)}) [(1 - w) g_k + w g_{k+1}]:
// exact (w = 0) where T takes at most thickness_levels distinct values, else the glow linear in
// p = sqrt(T) between levels evenly spaced in p (docs/model.md gives the error).
struct TurbidityPsf {
  std::vector<double> thickness;  // T of each level, ascending
  std::vector<Psf> glow;          // g_T of each level (is_delta: the level is the identity)
  bool exact = false;             // every pixel's T is one level's T
  cv::Mat map;                    // the per-pixel thickness planned for (shares its data)
  // For `count` thickness values: the level at or below each (`lower`), the share w of level
  // lower + 1 (0 when exact) and the unscattered share e^{-T}. Branch-free (vectorises).
  void Coefficients(const float* t, int count, int* lower, float* weight, float* direct) const;
  // The whole kernel of level k, e^{-T_k} delta + (1 - e^{-T_k}) g_k, CV_32FC1 (for inverses).
  cv::Mat LevelKernel(int k) const;
  // Per pixel and channel (1 - w) a_k + w a_{k+1} of per-level images a (one per level), e.g. the
  // levels' inverses.
  cv::Mat BlendLevels(const std::vector<cv::Mat>& per_level) const;

  float p_lo = 0.0f, p_scale = 0.0f;  // level position (sqrt(T) - p_lo) * p_scale when !exact
};

// beta_c * r per channel (CV_32FC(beta.size())), NaN where the range is NaN.
cv::Mat ThicknessFromRange(const cv::Mat& range_m, const std::vector<double>& beta_per_m);

// The plan for an image whose per-channel optical thickness is `thickness` (CV_32FC1 or C3).
// Throws Error when options fail Check.
TurbidityPsf PlanTurbidityPsf(const PsfOptions& options, const cv::Mat& thickness);

// image * h_T(x) per pixel (float32, the plan's channel count, BORDER_REFLECT_101 as ApplyPsf).
cv::Mat ApplyTurbidityPsf(const TurbidityPsf& plan, const cv::Mat& image);

}  // namespace turbid
