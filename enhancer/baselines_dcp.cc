// Dark channel prior (He, Sun, Tang, TPAMI 2011) and its underwater variant over G and B only
// (Drews et al., ICCV Workshops 2013). See enhancer/baselines.h.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "enhancer/baselines.h"
#include "enhancer/baselines_common.h"
#include "scenes/error.h"

namespace turbid {
namespace {

using baselines_internal::GuidedSmooth;
using baselines_internal::IsOddPositive;
using baselines_internal::MinFilter;
using baselines_internal::RecoverRadiance;
using baselines_internal::ValidateImage;

// A channel of the airlight this small is treated as this value, so I/A stays finite on black
// input.
constexpr float kMinAirlight = 1e-6f;

// Per-pixel minimum of I^c / A^c over the selected channels (He 2011 eq. 11, before the patch min).
cv::Mat NormalisedChannelMin(const cv::Mat& image, const cv::Vec3f& airlight, bool skip_red) {
  const int channels = image.channels();
  cv::Mat out(image.size(), CV_32FC1);
  const int last = (channels == 3 && skip_red) ? 2 : channels;
  for (int y = 0; y < image.rows; ++y) {
    const float* in = image.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      float m = std::numeric_limits<float>::max();
      for (int c = 0; c < last; ++c) {
        m = std::min(m, in[x * channels + c] / std::max(airlight[c], kMinAirlight));
      }
      o[x] = m;
    }
  }
  return out;
}

DcpResult RunDarkChannelPrior(const DcpOptions& options, const cv::Mat& image, bool underwater,
                              const std::string& method) {
  ValidateImage(image, method);
  ThrowIfInvalid(options, method);
  DcpResult result;
  result.dark_channel = DarkChannel(image, options.patch_size, underwater);
  result.airlight_pixel =
      EstimateAirlight(image, result.dark_channel, options.airlight_fraction, &result.airlight);
  // He 2011 eq. 12: t = 1 - ω min_Ω min_c I^c / A^c. Clamped to [0,1]: where a pixel is brighter
  // than A the estimate goes negative, which no transmission can be.
  cv::Mat normalised_dark =
      MinFilter(NormalisedChannelMin(image, result.airlight, underwater), options.patch_size);
  result.raw_transmission = 1.0 - options.omega * normalised_dark;
  baselines_internal::ClampUnit(result.raw_transmission);
  if (options.refine) {
    result.transmission =
        GuidedSmooth(image, result.raw_transmission, options.guided_radius, options.guided_eps);
    baselines_internal::ClampUnit(result.transmission);
  } else {
    result.transmission = result.raw_transmission.clone();
  }
  result.image = RecoverRadiance(image, result.transmission, result.airlight, options.t0);
  return result;
}

}  // namespace

bool DcpOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!IsOddPositive(patch_size)) return fail("patch_size must be an odd integer >= 1");
  if (!(omega > 0.0 && omega <= 1.0)) return fail("omega must be in (0, 1]");
  if (!(t0 > 0.0 && t0 <= 1.0)) return fail("t0 must be in (0, 1]");
  if (!(airlight_fraction > 0.0 && airlight_fraction <= 1.0)) {
    return fail("airlight_fraction must be in (0, 1]");
  }
  if (guided_radius < 1) return fail("guided_radius must be >= 1");
  if (!(guided_eps > 0.0) || !std::isfinite(guided_eps)) return fail("guided_eps must be > 0");
  return true;
}

cv::Mat DarkChannel(const cv::Mat& image, int patch_size, bool skip_red) {
  CV_Assert(image.depth() == CV_32F && (image.channels() == 1 || image.channels() == 3));
  cv::Mat channel_min;
  if (image.channels() == 1) {
    channel_min = image.clone();
  } else {
    std::vector<cv::Mat> planes;
    cv::split(image, planes);
    channel_min = cv::min(planes[0], planes[1]);
    if (!skip_red) channel_min = cv::min(channel_min, planes[2]);
  }
  return MinFilter(channel_min, patch_size);
}

cv::Point EstimateAirlight(const cv::Mat& image, const cv::Mat& prior, double fraction,
                           cv::Vec3f* airlight) {
  CV_Assert(prior.type() == CV_32FC1 && prior.size() == image.size() && prior.isContinuous());
  const int total = static_cast<int>(prior.total());
  const int count = std::clamp(static_cast<int>(std::ceil(fraction * total)), 1, total);
  std::vector<int> order(total);
  std::iota(order.begin(), order.end(), 0);
  const float* p = prior.ptr<float>();
  auto brighter = [p](int a, int b) { return p[a] > p[b] || (p[a] == p[b] && a < b); };
  std::nth_element(order.begin(), order.begin() + (count - 1), order.end(), brighter);
  const int channels = image.channels();
  int best = -1;
  float best_sum = -1.0f;
  for (int i = 0; i < count; ++i) {
    const int index = order[i];
    const float* px = image.ptr<float>(index / image.cols) + (index % image.cols) * channels;
    float sum = 0.0f;
    for (int c = 0; c < channels; ++c) sum += px[c];
    if (sum > best_sum || (sum == best_sum && index < best)) {
      best_sum = sum;
      best = index;
    }
  }
  const cv::Point at(best % image.cols, best / image.cols);
  const float* px = image.ptr<float>(at.y) + at.x * channels;
  for (int c = 0; c < 3; ++c) (*airlight)[c] = px[channels == 3 ? c : 0];
  return at;
}

DcpResult DarkChannelPriorDetailed(const DcpOptions& options, const cv::Mat& image) {
  return RunDarkChannelPrior(options, image, /*underwater=*/false, "dcp");
}

cv::Mat DarkChannelPrior(const DcpOptions& options, const cv::Mat& image) {
  return DarkChannelPriorDetailed(options, image).image;
}

DcpResult UnderwaterDarkChannelPriorDetailed(const UdcpOptions& options, const cv::Mat& image) {
  return RunDarkChannelPrior(options, image, /*underwater=*/true, "udcp");
}

cv::Mat UnderwaterDarkChannelPrior(const UdcpOptions& options, const cv::Mat& image) {
  return UnderwaterDarkChannelPriorDetailed(options, image).image;
}

}  // namespace turbid
