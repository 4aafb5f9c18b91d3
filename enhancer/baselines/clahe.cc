// CLAHE alone (uniform target) as a baseline, on luminance for colour. See enhancer/baselines/clahe.h.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "enhancer/baselines/clahe.h"
#include "enhancer/baselines/common.h"
#include "core/cpu.h"
#include "core/error.h"

namespace turbid {
namespace baselines_internal {
namespace {

#if defined(__x86_64__) && defined(__GNUC__)
#define TURBID_LUMINANCE_FMA 1
// cv::transform's float 3 -> 1 sum where OpenCV runs its AVX2 + FMA code: the green product first,
// then blue and red fused onto it, fma(w_r, r, fma(w_b, b, w_g g)) (found by comparison on this
// machine; RgbLuminanceMatchesOpenCv checks it wherever it runs, and Luminance uses it only then).
__attribute__((target("avx2,fma"))) void LuminanceRowFma(const float* px, float* lum, int n,
                                                         int b, int r) {
  for (int x = 0; x < n; ++x) {
    lum[x] = __builtin_fmaf(0.2126f, px[3 * x + r],
                            __builtin_fmaf(0.0722f, px[3 * x + b], 0.7152f * px[3 * x + 1]));
  }
}

// True when LuminanceRowFma gives cv::transform's values bit for bit on this CPU (checked once on
// values spread over [0, 1] and beyond).
bool RgbLuminanceMatchesOpenCv() {
  static const bool matches = [] {
    if (!CpuHas(CpuLevel::kAvx2Fma)) return false;
    cv::Mat bgr(64, 67, CV_32FC3);
    cv::RNG rng(20261125);
    rng.fill(bgr, cv::RNG::UNIFORM, -0.25, 1.25);
    cv::Mat expected, got(bgr.size(), CV_32F);
    cv::transform(bgr, expected, cv::Matx13f(0.0722f, 0.7152f, 0.2126f));
    for (int y = 0; y < bgr.rows; ++y)
      LuminanceRowFma(bgr.ptr<float>(y), got.ptr<float>(y), bgr.cols, 0, 2);
    return cv::norm(expected, got, cv::NORM_INF) == 0.0;
  }();
  return matches;
}
#endif

}  // namespace

cv::Mat Luminance(const cv::Mat& image, bool rgb) {
  CV_Assert(image.depth() == CV_32F && (image.channels() == 1 || image.channels() == 3));
  if (image.channels() == 1) return image.clone();
  cv::Mat luminance;
  // Rec. 709 / sRGB primaries on linear data, BGR order.
  const cv::Matx13f weights(0.0722f, 0.7152f, 0.2126f);
#ifdef TURBID_LUMINANCE_FMA
  // cv::transform's own values, in either channel order, without its per-call overhead.
  if (RgbLuminanceMatchesOpenCv()) {
    luminance.create(image.size(), CV_32F);
    for (int y = 0; y < image.rows; ++y)
      LuminanceRowFma(image.ptr<float>(y), luminance.ptr<float>(y), image.cols, rgb ? 2 : 0,
                      rgb ? 0 : 2);
    return luminance;
  }
#endif
  if (!rgb) {
    cv::transform(image, luminance, weights);
    return luminance;
  }
  luminance.create(image.size(), CV_32F);
  // Otherwise bands of rows reordered into a small buffer (in cache) and transformed as one image.
  // cv::transform computes each pixel alone, so the values equal the whole B, G, R image's
  // (tests/enhancer/channel_order_test.cc).
  const int band = std::max(1, 65536 / image.cols);  // ~768 KB of reordered rows: in L2
  std::vector<float> bgr(static_cast<size_t>(band) * image.cols * 3);
  for (int y0 = 0; y0 < image.rows; y0 += band) {
    const int rows = std::min(band, image.rows - y0);
    for (int y = y0; y < y0 + rows; ++y) {
      const float* s = image.ptr<float>(y);
      float* d = bgr.data() + static_cast<size_t>(y - y0) * image.cols * 3;
      for (int x = 0; x < image.cols; ++x) {
        d[3 * x] = s[3 * x + 2];
        d[3 * x + 1] = s[3 * x + 1];
        d[3 * x + 2] = s[3 * x];
      }
    }
    cv::Mat out = luminance.rowRange(y0, y0 + rows);
    cv::transform(cv::Mat(rows, image.cols, CV_32FC3, bgr.data()), out, weights);
  }
  return luminance;
}

cv::Mat ReplaceLuminance(const cv::Mat& image, const cv::Mat& luminance,
                         const cv::Mat& new_luminance) {
  if (image.channels() == 1) {
    cv::Mat out = new_luminance.clone();
    ClampUnit(out);
    return out;
  }
  cv::Mat out(image.size(), CV_32FC3);
  for (int y = 0; y < image.rows; ++y) {
    const cv::Vec3f* in = image.ptr<cv::Vec3f>(y);
    const float* l = luminance.ptr<float>(y);
    const float* nl = new_luminance.ptr<float>(y);
    cv::Vec3f* o = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float v = l[x] > 1e-6f ? in[x][c] * (nl[x] / l[x]) : nl[x];
        o[x][c] = std::clamp(v, 0.0f, 1.0f);
      }
    }
  }
  return out;
}

}  // namespace baselines_internal

bool ClaheBaselineOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (tiles_x < 2 || tiles_y < 2) return fail("tiles_x and tiles_y must be >= 2");
  if (!(clip_limit >= 0.0 && clip_limit <= 1.0)) return fail("clip_limit must be in [0, 1]");
  if (bins < 2 || bins > 65536) return fail("bins must be in [2, 65536]");
  return true;
}

cv::Mat ClaheBaseline(const ClaheBaselineOptions& options, const cv::Mat& image, bool rgb) {
  baselines_internal::ValidateImage(image, "clahe");
  ThrowIfInvalid(options, "clahe");
  if (image.channels() == 1) {
    // Gray: the luminance is the image; clamp the equalised result in place (no copies).
    cv::Mat out = baselines_internal::ClaheGray(image, options.tiles_x, options.tiles_y,
                                                options.clip_limit, options.bins);
    for (int y = 0; y < out.rows; ++y) {
      float* row = out.ptr<float>(y);
      for (int x = 0; x < out.cols; ++x) row[x] = std::min(std::max(row[x], 0.0f), 1.0f);
    }
    return out;
  }
  const cv::Mat luminance = baselines_internal::Luminance(image, rgb);
  const cv::Mat equalised = baselines_internal::ClaheGray(
      luminance, options.tiles_x, options.tiles_y, options.clip_limit, options.bins);
  return baselines_internal::ReplaceLuminance(image, luminance, equalised);
}

}  // namespace turbid
