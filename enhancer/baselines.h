// Classic single-image dehazing / underwater enhancement baselines, with their published defaults:
//   clahe  — CLAHE alone (uniform target) on luminance;
//   dcp    — He, Sun, Tang, "Single image haze removal using dark channel prior", CVPR 2009 /
//            TPAMI 33(12) 2011, eqs. 5, 11-12, 22, with the guided-filter refinement of He, Sun,
//            Tang, "Guided image filtering", TPAMI 35(6) 2013, §4.4 (r 60, ε 1e-4);
//   udcp   — Drews, do Nascimento, Moraes, Botelho, Campos, "Transmission estimation in underwater
//            single images", ICCV Workshops 2013: the dark channel over G and B only;
//   cap    — Zhu, Mai, Shao, "A fast single image haze removal algorithm using color attenuation
//            prior", TIP 24(11) 2015, eqs. 8, 14-16 (deterministic: no random ε term);
//   tarel  — Tarel, Hautière, "Fast visibility restoration from a single color or gray level
//            image", ICCV 2009, §4-5 (atmospheric veil from a median of medians);
//   fusion — Ancuti, Ancuti, Haber, Bekaert, "Enhancing underwater images and videos by fusion",
//            CVPR 2012, §3-4.
// Every function takes float32 images in [0,1] with 1 or 3 channels (BGR order, linear) and returns
// the same size and channel count, finite and clamped to [0,1]. Empty input, another depth or
// channel count, or non-finite values throw Error; options are checked with Check and throw Error
// naming the parameter. Formulas, defaults and the behaviour on gray input:
// docs/methods-baselines.md.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "enhancer/method.h"

namespace turbid {

// ---------------------------------------------------------------------------------------------
// Building blocks shared by the prior-based methods (exposed for tests).

// Dark channel (He 2011 eq. 5): per pixel the minimum over the selected channels, then the minimum
// over a patch_size x patch_size square (border: replicate). `skip_red` drops channel 2 (red in
// BGR) as UDCP does; gray images use their one channel either way.
cv::Mat DarkChannel(const cv::Mat& image, int patch_size, bool skip_red = false);

// Airlight (He 2011 §4.4): among the `fraction` brightest pixels of `prior` (at least one), the
// input pixel with the largest channel sum (ties: first in row-major order). Returns the pixel
// position; `airlight` gets the input value there (gray: all three entries equal).
cv::Point EstimateAirlight(const cv::Mat& image, const cv::Mat& prior, double fraction,
                           cv::Vec3f* airlight);

// ---------------------------------------------------------------------------------------------
// dcp and udcp

struct DcpOptions {
  // Side of the square dark-channel window, pixels, odd, >= 1. He 2011 §5: 15 x 15.
  int patch_size = 15;
  // Fraction of the haze removed, (0, 1]; keeps a little haze for depth perception. He 2011 eq. 12.
  double omega = 0.95;
  // Lower bound on the transmission when recovering the radiance, (0, 1]. He 2011 eq. 22.
  double t0 = 0.1;
  // Fraction of the brightest dark-channel pixels searched for the airlight, (0, 1]. He 2011 §4.4.
  double airlight_fraction = 0.001;
  // Refine the patch-wise transmission with a guided filter (guide: the input image). He 2013
  // §4.4 replaces the soft matting of He 2011 §4.2 with it.
  bool refine = true;
  // Guided-filter radius, pixels, >= 1 (He 2013 dehazing example: r 60).
  int guided_radius = 60;
  // Guided-filter regulariser ε on [0,1] data, > 0 (He 2013 dehazing example: 1e-4).
  double guided_eps = 1e-4;
  bool Check(std::string* why) const;
};

// UDCP keeps DCP's pipeline and defaults; only the dark channel changes (G and B only).
struct UdcpOptions : DcpOptions {};

struct DcpResult {
  cv::Mat image;             // recovered radiance J, same size and channels as the input, [0,1]
  cv::Mat dark_channel;      // CV_32FC1 dark channel of the input (udcp: of G and B)
  cv::Mat raw_transmission;  // CV_32FC1 patch-wise transmission, He 2011 eq. 12
  cv::Mat transmission;      // CV_32FC1 refined transmission (== raw when refine is off), [0,1]
  cv::Vec3f airlight;        // A per channel, BGR (gray: three equal entries)
  cv::Point airlight_pixel;  // where A was read
};

DcpResult DarkChannelPriorDetailed(const DcpOptions& options, const cv::Mat& image);
cv::Mat DarkChannelPrior(const DcpOptions& options, const cv::Mat& image);
DcpResult UnderwaterDarkChannelPriorDetailed(const UdcpOptions& options, const cv::Mat& image);
cv::Mat UnderwaterDarkChannelPrior(const UdcpOptions& options, const cv::Mat& image);

// ---------------------------------------------------------------------------------------------
// cap

struct CapOptions {
  // Linear depth model d = θ0 + θ1 v + θ2 s (v: HSV value, s: HSV saturation). Zhu 2015 eq. 8
  // and §IV-C (learned coefficients); the random term ε of eq. 8 is left out (deterministic).
  double theta0 = 0.121779;
  double theta1 = 0.959710;
  double theta2 = -0.780245;
  // Side of the square minimum filter applied to the raw depth, pixels, odd, >= 1. Zhu 2015 eq. 14:
  // 15 x 15.
  int patch_size = 15;
  // Scattering coefficient in t = exp(-β d), > 0. Zhu 2015 §V: β = 1.
  double beta = 1.0;
  // Transmission clamp when recovering the radiance, 0 < t_min < t_max <= 1. Zhu 2015 eq. 16.
  double t_min = 0.05;
  double t_max = 1.0;
  // Fraction of the farthest (largest-depth) pixels searched for the airlight, (0, 1]. Zhu 2015
  // §IV-D: top 0.1 %.
  double airlight_fraction = 0.001;
  // Guided-filter refinement of the min-filtered depth (guide: the input). Zhu's reference code
  // uses a 60 x 60 neighbourhood (radius 30) and ε 1e-3.
  bool refine = true;
  int guided_radius = 30;    // pixels, >= 1
  double guided_eps = 1e-3;  // on [0,1] data, > 0
  bool Check(std::string* why) const;
};

struct CapResult {
  cv::Mat image;         // recovered radiance, [0,1]
  cv::Mat raw_depth;     // CV_32FC1 θ0 + θ1 v + θ2 s per pixel
  cv::Mat depth;         // CV_32FC1 after the minimum filter and (optionally) the guided filter
  cv::Mat transmission;  // CV_32FC1 exp(-β depth) clamped to [t_min, t_max]
  cv::Vec3f airlight;    // A per channel, BGR
  cv::Point airlight_pixel;
};

CapResult ColorAttenuationPriorDetailed(const CapOptions& options, const cv::Mat& image);
cv::Mat ColorAttenuationPrior(const CapOptions& options, const cv::Mat& image);

// ---------------------------------------------------------------------------------------------
// tarel

struct TarelOptions {
  // Percentage of the veil removed, (0, 1). Tarel 2009 §4 and reference code: 0.95.
  double p = 0.95;
  // Median window side (the largest assumed white object), pixels, odd, >= 1. Tarel 2009: 11.
  int sv = 11;
  // White balance for colour input: < 0 none; 0 global (mean colour of the 1 % whitest pixels
  // mapped to gray); > 0 local, the strength of a per-pixel balance from sv-median colours
  // (reference code: 0.5 a good start, 1 removes most colour). Tarel 2009 §5 assumes white-balanced
  // input; we default to global balance because underwater colour casts are strong.
  double balance = 0.0;
  // Final gamma correction and tone mapping of Tarel's reference code (matches the log-mean and
  // log-std of the bottom third of the image, then maps the maximum to 1).
  bool tone_map = true;
  // Extra factor on the gamma exponent, > 0 (reference code: 1.3).
  double gamma_factor = 1.3;
  bool Check(std::string* why) const;
};

struct TarelResult {
  cv::Mat image;      // final result, [0,1]
  cv::Mat balanced;   // input after white balance (clamped to [0,1])
  cv::Mat whiteness;  // CV_32FC1 W = min over channels of `balanced` (gray: the same buffer)
  cv::Mat veil;  // CV_32FC1 atmospheric veil V = p max(min(W, B), 0), B = med(W) - med|W - med(W)|
  cv::Mat restored;  // (balanced - V) / (1 - V), colours restored, before tone mapping; >= 0
  cv::Vec3f white;   // global white-balance colour (1,1,1 when none), BGR
};

TarelResult TarelDetailed(const TarelOptions& options, const cv::Mat& image);
cv::Mat Tarel(const TarelOptions& options, const cv::Mat& image);

// Median over an odd size x size window (border: reflect, as MATLAB's 'symmetric'), float32
// one-channel, exact: comparator networks shared between neighbouring windows
// (enhancer/baselines_median.cc; ~25 ms at 1360x1024 for size 11 on one core).
cv::Mat MedianFilter(const cv::Mat& image, int size);

// ---------------------------------------------------------------------------------------------
// clahe (uniform target, on luminance for colour)

struct ClaheBaselineOptions {
  // Contextual regions along x and y, >= 2 each. MATLAB adapthisteq default: [8 8].
  int tiles_x = 8;
  int tiles_y = 8;
  // Clip limit as a fraction of the tile's pixels, [0, 1]. adapthisteq default: 0.01.
  double clip_limit = 0.01;
  // Histogram bins, >= 2. adapthisteq default: 256.
  int bins = 256;
  bool Check(std::string* why) const;
};

// rgb: a colour image in R, G, B order (the result keeps it); the same values as for B, G, R.
cv::Mat ClaheBaseline(const ClaheBaselineOptions& options, const cv::Mat& image, bool rgb = false);

// ---------------------------------------------------------------------------------------------
// fusion

struct FusionOptions {
  // Laplacian-pyramid levels, >= 1; fewer are used on images too small for them. Ancuti 2012
  // blend with a multi-scale pyramid; five levels as in the comparison of the reproduced paper.
  int levels = 5;
  // Gray-world white balance of the first input (colour only). Ancuti 2012 §3.1.
  bool white_balance = true;
  // Largest gain the gray-world balance may apply to one channel, >= 1 (keeps a nearly absent red
  // channel from being multiplied into noise).
  double max_white_balance_gain = 4.0;
  // CLAHE of the second input's luminance (Ancuti 2012 §3.1: local adaptive histogram
  // equalisation); adapthisteq defaults.
  ClaheBaselineOptions clahe;
  // Width of the exposedness Gaussian around 0.5, > 0. Ancuti 2012 §3.2: σ = 0.25.
  double exposedness_sigma = 0.25;
  bool Check(std::string* why) const;
};

struct FusionResult {
  cv::Mat image;                 // fused result, [0,1]
  // the two derived inputs (white-balanced, or the input image itself when not balanced;
  // contrast-enhanced)
  std::vector<cv::Mat> inputs;
  std::vector<cv::Mat> weights;  // their normalised CV_32FC1 weight maps (sum to 1 per pixel)
};

FusionResult FusionDetailed(const FusionOptions& options, const cv::Mat& image);
cv::Mat Fusion(const FusionOptions& options, const cv::Mat& image);

// Fusion weight of one input before normalisation (Ancuti 2012 §3.2): Laplacian contrast + local
// contrast + saliency + exposedness, CV_32FC1, >= 0.
cv::Mat FusionWeight(const cv::Mat& input, double exposedness_sigma);

// Multi-scale blend (Ancuti 2012 eq. 10): sum over k of Laplacian pyramid(input k) times Gaussian
// pyramid(weight k), collapsed. Weights must sum to 1 per pixel; inputs share size and channels.
// `levels` is capped so the coarsest level is at least 1 x 1. Not clamped.
cv::Mat PyramidBlend(const std::vector<cv::Mat>& inputs, const std::vector<cv::Mat>& weights,
                     int levels);

// ---------------------------------------------------------------------------------------------
// Registry entries for clahe, dcp, udcp, cap, tarel and fusion (parameters bound strictly from
// JSON onto the Options above; defaults come from the structs).
std::vector<MethodEntry> BaselineMethodEntries();

}  // namespace turbid
