// Guided image filter: He, Sun, Tang, "Guided image filtering", TPAMI 35(6) 2013, Alg. 1
// (eqs. 7-8 gray guide, eqs. 19-21 colour guide), and the fast subsampled variant of
// He & Sun, "Fast guided filter", arXiv:1505.00996 (2015), Alg. 2. The paper we reproduce uses it
// for denoising (§III-A.1, radius k = 4, ε = 0.1²) and for the simplified model's detail layers.
//
// Box means over a (2r+1)x(2r+1) window are O(N): vertical running sums (re-anchored by direct
// summation every 64 rows so float rounding does not drift), horizontal sums per row (direct or
// blocked for r <= 12, binary doubling beyond). One-channel guides stream by rows: a and b live
// in a ring of 2r+2 rows, so the output is the only full-size buffer. Border rule: the window is
// clipped to the image and the mean divides by the number of pixels actually inside it (He's
// reference code's N = boxfilter(ones) normalisation). cv::ximgproc::guidedFilter instead uses
// BORDER_REFLECT_101 box filters, so the two agree (to float rounding) on every pixel at least r
// pixels from the border — twice r for the mean of the coefficients a, b — i.e. at distance >= 2r;
// tests compare there. Radii larger than the image are allowed (the window is clipped).
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "enhancer/blocks/box_filter.h"  // BoxMean: the clipped window of this filter

namespace turbid {

struct GuidedFilterOptions {
  // Window radius r in pixels (window side 2r+1), >= 0 (0: the filter returns the input). The
  // paper's k: 4 for denoising (§III-A.1); 2 and 8 in the simplified model (§III-B).
  int radius = 4;
  // Regulariser ε on [0,1] data, > 0 and finite. Edges with variance >> ε are kept. Paper: 0.1².
  double eps = 0.01;
  // Fast guided filter subsampling ratio s, >= 1 (1: exact filter). Coefficients are computed at
  // 1/s resolution with radius max(1, round(r/s)) and upsampled bilinearly (He & Sun 2015: s = r/4
  // keeps quality). Output differs from the exact filter by O(s/r) in textured areas.
  int subsample = 1;

  bool Check(std::string* why) const;
};

// Filters `src` (CV_32F, any number of channels; each channel filtered independently) with the
// guide `guide` (CV_32FC1 or CV_32FC3, same size). A 3-channel guide uses the colour-guide
// formulation (3x3 covariance per pixel). Returns CV_32F with src's channel count. Not clamped.
// Throws Error for empty/mismatched/non-float inputs or options failing Check.
cv::Mat GuidedFilter(const GuidedFilterOptions& options, const cv::Mat& guide, const cv::Mat& src);

// One-channel guide and source (CV_32FC1, same size): GuidedFilter's filter with, at radii
// above 12, the horizontal window sums formed as running sums 8 columns apart (restarted from a
// direct sum every 128 columns) instead of GuidedFilter's doubling tree (the vertical sums are
// GuidedFilter's): about half the additions, equal to GuidedFilter to float rounding but not bit
// for bit (radii 1..12: GuidedFilter itself). `row_done(y, row)`, if
// given, is called on each output row as soon as it is written (in order, while it is in cache;
// it may modify the row). The dcp / udcp / cap refinement (r = 60, 30) uses it. Throws Error as
// GuidedFilter does.
cv::Mat GuidedFilterGrayRunning(const cv::Mat& guide, const cv::Mat& src, int radius, double eps,
                                const std::function<void(int, float*)>& row_done = nullptr);

// Self-guided shorthand: GuidedFilter(options, image, image) for one-channel images; for
// three-channel images each channel guides itself (the edge-preserving smoother the paper uses),
// filtered interleaved (radius 1..12, subsample 1; else channel by channel), with the same
// result bit for bit as filtering each channel alone.
cv::Mat GuidedFilterSelf(const GuidedFilterOptions& options, const cv::Mat& image);

// Self-guided filters of one image (1 or 3 channels) at several settings, streamed by rows
// without full-size intermediates: emit(y, rows) receives row y of each filter's output (rows[k]
// for options[k], `image.cols * channels` floats, interleaved, valid during the call), for
// y = 0, 1, ..., rows-1. Equal to GuidedFilterSelf(options[k], image) row by row. Throws Error as
// GuidedFilter does.
void GuidedFilterSelfRows(const std::vector<GuidedFilterOptions>& options, const cv::Mat& image,
                          const std::function<void(int, const std::vector<const float*>&)>& emit);

}  // namespace turbid
