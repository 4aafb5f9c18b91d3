// Baseline tarel: Tarel, Hautière, "Fast visibility restoration from a single color or gray level
// image", ICCV 2009, §4-5 (atmospheric veil from a median of medians; MedianFilter:
// enhancer/baselines/median.h).
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

}  // namespace turbid
