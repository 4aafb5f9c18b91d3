// Baseline clahe: CLAHE alone (uniform target) on luminance (MATLAB adapthisteq's defaults).
// Every function takes float32 images in [0,1] with 1 or 3 channels (BGR order, linear) and returns
// the same size and channel count, finite and clamped to [0,1]. Empty input, another depth or
// channel count, or non-finite values throw Error; options are checked with Check and throw Error
// naming the parameter. Formulas, defaults and the behaviour on gray input:
// docs/methods-baselines.md.
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace turbid {

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

}  // namespace turbid
