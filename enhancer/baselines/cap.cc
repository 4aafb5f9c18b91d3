// Colour attenuation prior (Zhu, Mai, Shao, TIP 2015), deterministic. See enhancer/baselines/cap.h.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "enhancer/baselines/cap.h"
#include "enhancer/baselines/dcp.h"
#include "enhancer/baselines/common.h"
#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/image_pool.h"

namespace turbid {
namespace {

using baselines_internal::IsOddPositive;

// Zhu 2015 eq. 8 without ε: d = θ0 + θ1 v + θ2 s, with HSV value v = max_c I^c and saturation
// s = (max - min) / max (0 where max is 0). Gray input has s = 0: depth follows brightness only.
// Row kernels per channel count (the same double arithmetic, vectorised).
TURBID_ROW_KERNEL void RawDepthRow1(const float* __restrict in, double t0, double t1,
                                    float* __restrict d, int w) {
  for (int x = 0; x < w; ++x) {
    // s = (hi - hi) / hi = 0 for every finite hi (the input is validated), so t2 s is a zero
    // and the sum t0 + t1 v + t2 s equals t0 + t1 v: no double division per pixel.
    const double v = in[x];
    d[x] = static_cast<float>(t0 + t1 * v);
  }
}

TURBID_ROW_KERNEL void RawDepthRow3(const float* __restrict in, double t0, double t1, double t2,
                                    float* __restrict d, int w) {
  for (int x = 0; x < w; ++x) {
    const float* px = in + 3 * x;
    const float hi = std::max(std::max(px[0], px[1]), px[2]);
    const float lo = std::min(std::min(px[0], px[1]), px[2]);
    const double v = hi;
    const double s = hi > 0.0f ? (hi - lo) / hi : 0.0;
    d[x] = static_cast<float>(t0 + t1 * v + t2 * s);
  }
}

cv::Mat RawDepth(const CapOptions& options, const cv::Mat& image) {
  cv::Mat depth = internal::PooledMat(image.size(), CV_32FC1);
  for (int y = 0; y < image.rows; ++y) {
    if (image.channels() == 1) {
      RawDepthRow1(image.ptr<float>(y), options.theta0, options.theta1, depth.ptr<float>(y),
                   image.cols);
    } else {
      RawDepthRow3(image.ptr<float>(y), options.theta0, options.theta1, options.theta2,
                   depth.ptr<float>(y), image.cols);
    }
  }
  return depth;
}

}  // namespace

bool CapOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!std::isfinite(theta0) || !std::isfinite(theta1) || !std::isfinite(theta2)) {
    return fail("theta0, theta1 and theta2 must be finite");
  }
  if (!IsOddPositive(patch_size)) return fail("patch_size must be an odd integer >= 1");
  if (!(beta > 0.0) || !std::isfinite(beta)) return fail("beta must be > 0");
  if (!(t_min > 0.0 && t_min < t_max && t_max <= 1.0)) {
    return fail("t_min and t_max must satisfy 0 < t_min < t_max <= 1");
  }
  if (!(airlight_fraction > 0.0 && airlight_fraction <= 1.0)) {
    return fail("airlight_fraction must be in (0, 1]");
  }
  if (guided_radius < 1) return fail("guided_radius must be >= 1");
  if (!(guided_eps > 0.0) || !std::isfinite(guided_eps)) return fail("guided_eps must be > 0");
  return true;
}

CapResult ColorAttenuationPriorDetailed(const CapOptions& options, const cv::Mat& image) {
  baselines_internal::ValidateImage(image, "cap");
  ThrowIfInvalid(options, "cap");
  CapResult result;
  result.raw_depth = RawDepth(options, image);
  // Zhu 2015 eq. 14: the minimum filter suppresses white objects that the linear model would
  // place far away.
  const cv::Mat min_depth = baselines_internal::MinFilter(result.raw_depth, options.patch_size);
  // Zhu 2015 §IV-D: A is read among the farthest 0.1 % of the (min-filtered) depth map.
  result.airlight_pixel =
      EstimateAirlight(image, min_depth, options.airlight_fraction, &result.airlight);
  result.transmission = internal::PooledMat(image.size(), CV_32FC1);
  const float t_min = static_cast<float>(options.t_min), t_max = static_cast<float>(options.t_max);
  if (!options.refine || image.channels() != 1) {
    // (A colour guide filters the whole image before any row is out: nothing to gain per block.)
    result.depth = options.refine ? baselines_internal::GuidedSmooth(
                                        image, min_depth, options.guided_radius, options.guided_eps)
                                  : min_depth;
    cv::exp(-options.beta * result.depth, result.transmission);
    baselines_internal::ClampRange(result.transmission, t_min, t_max);
    result.image =
        baselines_internal::RecoverRadiance(image, result.transmission, result.airlight, t_min);
    return result;
  }
  // Gray: t = exp(-beta d) (Zhu 2015 eq. 4), clamped, and the radiance recovered, on blocks of
  // refined rows while they are in cache: blocks of 16 rows, the last one taking the rest (so every
  // block holds >= 16 values or is the whole image). The expression and cv::exp run on each block
  // as they ran on the whole image; their vector loops cover every value of a block of >= 16 values
  // (overlapping the last vector instead of finishing with scalar code), so each value is the
  // whole-image one.
  result.image = internal::PooledMat(image.size(), image.type());
  constexpr int kBlockRows = 16;
  const int h = image.rows, w = image.cols;
  int block_start = 0;
  float* block_first = nullptr;
  result.depth = baselines_internal::GuidedSmooth(
      image, min_depth, options.guided_radius, options.guided_eps, [&](int y, float* row) {
        if (y == block_start) block_first = row;
        const int rows = y + 1 - block_start;
        CV_Assert(row == block_first + static_cast<size_t>(rows - 1) * w);  // contiguous rows
        if (!((rows == kBlockRows && h - (y + 1) >= kBlockRows) || y + 1 == h)) return;
        const cv::Mat depth(rows, w, CV_32FC1, block_first);  // the rows are contiguous
        cv::Mat t = result.transmission.rowRange(block_start, y + 1);
        cv::exp(-options.beta * depth, t);
        for (int i = 0; i < rows; ++i) {
          float* tr = t.ptr<float>(i);
          baselines_internal::ClampRangeRow(tr, t_min, t_max, w);
          baselines_internal::RecoverRadianceRow(image.ptr<float>(block_start + i), tr,
                                                 image.channels(), result.airlight, t_min,
                                                 result.image.ptr<float>(block_start + i), w);
        }
        block_start = y + 1;
      });
  return result;
}

cv::Mat ColorAttenuationPrior(const CapOptions& options, const cv::Mat& image) {
  return ColorAttenuationPriorDetailed(options, image).image;
}

}  // namespace turbid
