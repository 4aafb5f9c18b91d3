// Baseline cap: Zhu, Mai, Shao, "A fast single image haze removal algorithm using color
// attenuation prior", TIP 24(11) 2015, eqs. 8, 14-16 (deterministic: no random ε term). The
// airlight search is dcp's (EstimateAirlight, enhancer/baselines/dcp.h).
// Every function takes float32 images in [0,1] with 1 or 3 channels (BGR order, linear) and returns
// the same size and channel count, finite and clamped to [0,1]. Empty input, another depth or
// channel count, or non-finite values throw Error; options are checked with Check and throw Error
// naming the parameter. Formulas, defaults and the behaviour on gray input:
// docs/methods-baselines.md.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace turbid {

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

}  // namespace turbid
