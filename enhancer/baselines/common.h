// Internals shared by the baseline methods (enhancer/baselines/*.h); not part of the public API.
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace turbid::baselines_internal {

// Throws Error("<method>: ...") unless `image` is non-empty CV_32F with 1 or 3 channels and every
// value is finite.
void ValidateImage(const cv::Mat& image, const std::string& method);

// Minimum over a size x size square (size odd); border: replicate, so tiny images work. Equal to
// cv::erode with a size x size rectangle and BORDER_REPLICATE (O(1) comparisons per pixel).
// Full-size results here and in the dcp / cap pipelines come from the recycling pool of
// simulator/image_pool.h (fresh pages for every temporary cost more than the arithmetic).
cv::Mat MinFilter(const cv::Mat& gray, int size);

// Guided-filter smoothing of the one-channel `src` with `guide` (1 or 3 channels), radius and ε on
// [0,1] data; radius is capped to the image size (a larger window adds nothing but border).
// One-channel guides at radii > 12 take GuidedFilterGrayRunning (equal to GuidedFilter to float
// rounding). `row_done(y, row)`, if given, is called on each output row in order (for a
// one-channel guide as soon as the row is written, while it is in cache); it may modify it.
cv::Mat GuidedSmooth(const cv::Mat& guide, const cv::Mat& src, int radius, double eps,
                     const std::function<void(int, float*)>& row_done = nullptr);

// CLAHE with a uniform target on a one-channel float image in [0,1] (adapthisteq semantics).
cv::Mat ClaheGray(const cv::Mat& gray, int tiles_x, int tiles_y, double clip_limit, int bins);

// J = (I - A) / max(t, t_min) + A per channel (He 2011 eq. 22), clamped to [0,1].
cv::Mat RecoverRadiance(const cv::Mat& image, const cv::Mat& transmission,
                        const cv::Vec3f& airlight, double t_min);

// One row of RecoverRadiance: w pixels of `channels` (1 or 3) values.
void RecoverRadianceRow(const float* in, const float* t, int channels, const cv::Vec3f& airlight,
                        float t_min, float* out, int w);
// One row of ClampRange (n values).
void ClampRangeRow(float* v, float lo, float hi, int n);

// Clamps a CV_32F image to [lo, hi] in place, one pass: min(max(v, lo), hi).
void ClampRange(cv::Mat& image, float lo, float hi);

// Clamps to [0,1] in place (NaN never reaches here: inputs are validated and every division is
// guarded).
void ClampUnit(cv::Mat& image);

// Luminance of a linear BGR image (Rec. 709 weights); gray images are returned as is (a copy).
// rgb: the image is in R, G, B order; the values are the same as for its B, G, R twin.
cv::Mat Luminance(const cv::Mat& image, bool rgb = false);
// Replaces the luminance of `image` by `new_luminance`, scaling the three channels by the ratio so
// hue and saturation stay; pixels with zero luminance become gray. Output clamped to [0,1].
cv::Mat ReplaceLuminance(const cv::Mat& image, const cv::Mat& luminance,
                         const cv::Mat& new_luminance);

// Exact median over a k x k window (k odd, >= 3) of a CV_32FC1 image, border reflected (as
// MATLAB's 'symmetric'); comparator networks shared between neighbouring windows
// (enhancer/baselines/median.cc). MedianFilter (enhancer/baselines/median.h) calls it. k = 11 runs
// networks compiled to straight-line code unless `allow_compiled` is false (tests: the run-time
// networks, used for every other k, then run for k = 11 too).
cv::Mat NetworkMedian(const cv::Mat& image, int k, bool allow_compiled = true);

inline bool IsOddPositive(int v) { return v >= 1 && v % 2 == 1; }

}  // namespace turbid::baselines_internal
