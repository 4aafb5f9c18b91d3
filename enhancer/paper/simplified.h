// `simplified`, the paper's simplified model (§III-B): I_g + alpha (I_f - I_g) (eqs. 8-9),
// I_f = GIF_{2,0.1^2}(I), I_g = GIF_{8,0.4^2}(I), then CLAHE.
// Inputs float32 linear [0,1], 1 or 3 channels; outputs the same size and channels in [0,1].
// docs/methods.md has formulas and defaults.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "enhancer/blocks/clahe.h"
#include "enhancer/registry.h"

namespace turbid {

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
// Reports `simplified`'s intermediates to `sink` (computed whole-image, only when asked; the
// streamed SimplifiedEnhance keeps none): 01_fine (I_f), 02_coarse (I_g) and 03_boosted
// (I_g + alpha (I_f - I_g), clamped to [0, 1], before CLAHE).
void ReportSimplifiedSteps(const SimplifiedOptions& options, const cv::Mat& image, StepSink& sink);

}  // namespace turbid
