// Fast visibility restoration (Tarel & Hautière, ICCV 2009), with the white balance and the final
// gamma correction / tone mapping of the authors' reference implementation. See
// enhancer/baselines/tarel.h and docs/methods-baselines.md.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "enhancer/baselines/median.h"
#include "enhancer/baselines/tarel.h"
#include "enhancer/baselines/common.h"
#include "core/error.h"

namespace turbid {
namespace {

using baselines_internal::IsOddPositive;

// Smallest white / local-balance factor we divide by: keeps a channel that is nearly absent from
// blowing up (values are clamped to [0,1] after the division anyway).
constexpr float kMinBalance = 1e-3f;

cv::Mat ChannelMin(const cv::Mat& image) {
  if (image.channels() == 1) return image.clone();
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  return cv::min(cv::min(planes[0], planes[1]), planes[2]);
}

cv::Mat ChannelMean(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat mean;
  cv::transform(image, mean, cv::Matx13f(1.0f / 3, 1.0f / 3, 1.0f / 3));
  return mean;
}

// [0,1]-clamped copy (max with 0, then min with 1, as ClampUnit).
cv::Mat ClampedCopy(const cv::Mat& image) {
  cv::Mat out(image.size(), image.type());
  const int n = image.cols * image.channels();
  for (int y = 0; y < image.rows; ++y) {
    const float* in = image.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < n; ++x) o[x] = std::min(std::max(in[x], 0.0f), 1.0f);
  }
  return out;
}

// |a - b|, one pass.
cv::Mat AbsDifference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat out(a.size(), CV_32FC1);
  for (int y = 0; y < a.rows; ++y) {
    const float* pa = a.ptr<float>(y);
    const float* pb = b.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < a.cols; ++x) o[x] = std::fabs(pa[x] - pb[x]);
  }
  return out;
}

// V = p max(min(W, A - D), 0) with A = med(W), D = med|W - A|, one pass, written over A (A is
// not needed afterwards; each element is read before it is written).
cv::Mat VeilOverMedian(const cv::Mat& w, cv::Mat& a, const cv::Mat& d, double p) {
  // In float, as OpenCV scales a float matrix by a double (the reference implementation did).
  const float pf = static_cast<float>(p);
  for (int y = 0; y < w.rows; ++y) {
    const float* pw = w.ptr<float>(y);
    float* pa = a.ptr<float>(y);
    const float* pd = d.ptr<float>(y);
    for (int x = 0; x < w.cols; ++x) {
      const float bound = pa[x] - pd[x];
      pa[x] = std::max(std::min(pw[x], bound), 0.0f) * pf;
    }
  }
  return a;
}

// Global balance (reference code, balance == 0): the mean colour of the pixels whose whiteness
// reaches its 99th percentile (nearest rank), scaled so its largest channel is 1.
cv::Vec3f GlobalWhite(const cv::Mat& image) {
  const cv::Mat w = ChannelMin(image);
  std::vector<float> values(w.begin<float>(), w.end<float>());
  const size_t rank =
      static_cast<size_t>(std::floor(0.99 * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + rank, values.end());
  const float threshold = values[rank];
  cv::Vec3d sum(0, 0, 0);
  int count = 0;
  for (int y = 0; y < image.rows; ++y) {
    const cv::Vec3f* px = image.ptr<cv::Vec3f>(y);
    const float* wy = w.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      if (wy[x] >= threshold) {
        sum += cv::Vec3d(px[x][0], px[x][1], px[x][2]);
        ++count;
      }
    }
  }
  const double top = std::max({sum[0], sum[1], sum[2]});
  if (count == 0 || top <= 0.0) return cv::Vec3f(1, 1, 1);
  cv::Vec3f white;
  for (int c = 0; c < 3; ++c) white[c] = std::max(static_cast<float>(sum[c] / top), kMinBalance);
  return white;
}

// Local balance (reference code, balance > 0): per-pixel colour of the sv-median image, its
// deviation from gray raised to `strength`, renormalised to mean 1 over the channels.
cv::Mat LocalBalanceFactors(const cv::Mat& image, int sv, double strength) {
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (auto& plane : planes) plane = MedianFilter(plane, sv);
  cv::Mat factors(image.size(), CV_32FC3);
  for (int y = 0; y < image.rows; ++y) {
    cv::Vec3f* f = factors.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.cols; ++x) {
      cv::Vec3d m(planes[0].at<float>(y, x), planes[1].at<float>(y, x), planes[2].at<float>(y, x));
      const double mean = (m[0] + m[1] + m[2]) / 3.0;
      if (mean <= 0.0) {
        f[x] = cv::Vec3f(1, 1, 1);
        continue;
      }
      for (int c = 0; c < 3; ++c) m[c] = std::pow(m[c] / mean, strength);
      const double renorm = (m[0] + m[1] + m[2]) / 3.0;
      for (int c = 0; c < 3; ++c) {
        f[x][c] = std::max(static_cast<float>(renorm > 0.0 ? m[c] / renorm : 1.0), kMinBalance);
      }
    }
  }
  return factors;
}

// Mean and sample standard deviation of log(v + 0.5/255) over the bottom third of the rows, v the
// channel mean (only those rows are averaged).
void BottomThirdLogStats(const cv::Mat& image, double* mean, double* stddev) {
  const int first = std::min(image.rows - 1, (2 * image.rows) / 3);
  const cv::Mat bottom = ChannelMean(image.rowRange(first, image.rows));
  cv::Mat logs = bottom + 0.5 / 255.0;
  cv::log(logs, logs);
  cv::Scalar m, s;
  cv::meanStdDev(logs, m, s);
  const double n = static_cast<double>(logs.total());
  *mean = m[0];
  *stddev = n > 1 ? s[0] * std::sqrt(n / (n - 1)) : 0.0;
}

}  // namespace

bool TarelOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!(p > 0.0 && p < 1.0)) return fail("p must be in (0, 1)");
  if (!IsOddPositive(sv)) return fail("sv must be an odd integer >= 1");
  if (!std::isfinite(balance)) return fail("balance must be finite");
  if (!(gamma_factor > 0.0) || !std::isfinite(gamma_factor)) {
    return fail("gamma_factor must be > 0");
  }
  return true;
}

cv::Mat MedianFilter(const cv::Mat& image, int size) {
  CV_Assert(image.type() == CV_32FC1 && IsOddPositive(size));
  if (size == 1) return image.clone();
  return baselines_internal::NetworkMedian(image, size);
}

TarelResult TarelDetailed(const TarelOptions& options, const cv::Mat& image) {
  baselines_internal::ValidateImage(image, "tarel");
  ThrowIfInvalid(options, "tarel");
  TarelResult result;
  result.white = cv::Vec3f(1, 1, 1);
  const bool color = image.channels() == 3;
  cv::Mat local_factors;
  if (color && options.balance == 0.0) {
    result.white = GlobalWhite(image);
    cv::divide(image, cv::Scalar(result.white[0], result.white[1], result.white[2]),
               result.balanced);
    // Balanced values above 1 would let the veil exceed 1 and the restoration divide by <= 0.
    baselines_internal::ClampUnit(result.balanced);
  } else if (color && options.balance > 0.0) {
    local_factors = LocalBalanceFactors(image, options.sv, options.balance);
    cv::divide(image, local_factors, result.balanced);
    baselines_internal::ClampUnit(result.balanced);
  } else {
    result.balanced = ClampedCopy(image);
  }

  // Tarel 2009 §4.3: A = median_sv(W); B = A - median_sv(|W - A|); V = p max(min(W, B), 0).
  // Gray: W is the balanced image itself (one buffer).
  result.whiteness = color ? ChannelMin(result.balanced) : result.balanced;
  cv::Mat local_median = MedianFilter(result.whiteness, options.sv);
  const cv::Mat deviation_median =
      MedianFilter(AbsDifference(result.whiteness, local_median), options.sv);
  result.veil = VeilOverMedian(result.whiteness, local_median, deviation_median, options.p);

  // Tarel 2009 eq. 9 with the sky intensity I_s = 1 (after white balance): R = (I - V) / (1 - V).
  // V <= p W < 1, so the divisor is at least 1 - p and R >= 0.
  const int channels = image.channels();
  result.restored.create(image.size(), image.type());
  for (int y = 0; y < image.rows; ++y) {
    const float* in = result.balanced.ptr<float>(y);
    const float* v = result.veil.ptr<float>(y);
    float* r = result.restored.ptr<float>(y);
    const cv::Vec3f* f = local_factors.empty() ? nullptr : local_factors.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.cols; ++x) {
      for (int c = 0; c < channels; ++c) {
        float value = (in[x * channels + c] - v[x]) / (1.0f - v[x]);
        value *= f != nullptr ? f[x][c] : result.white[color ? c : 0];
        r[x * channels + c] = std::max(value, 0.0f);
      }
    }
  }

  if (!options.tone_map) {
    result.image = ClampedCopy(result.restored);
    return result;
  }
  // Reference code: a gamma that matches the log-mean and log-spread of the bottom third of the
  // image to the input's, then u / (1 + (1 - 1/max u) u), which maps max u to 1.
  double mean_in, std_in, mean_out, std_out;
  BottomThirdLogStats(result.balanced, &mean_in, &std_in);
  BottomThirdLogStats(result.restored, &mean_out, &std_out);
  // A flat bottom third has no spread to match: keep the exponent at 1 instead of 0 or infinity.
  const double exponent =
      (std_in > 1e-6 && std_out > 1e-6) ? options.gamma_factor * std_in / std_out : 1.0;
  const double scale = std::exp(mean_in - mean_out * exponent);
  cv::Mat u;
  cv::pow(result.restored, exponent, u);
  u *= scale;
  double max_u = 0.0;
  cv::minMaxLoc(u.reshape(1), nullptr, &max_u);
  if (max_u > 1e-12 && std::isfinite(max_u)) {
    // The quotient goes over the denominator (one buffer less).
    cv::Mat denominator = u * (1.0 - 1.0 / max_u) + cv::Scalar::all(1.0);
    cv::divide(u, denominator, denominator);
    result.image = denominator;
  } else {
    result.image = u;
  }
  baselines_internal::ClampUnit(result.image);
  return result;
}

cv::Mat Tarel(const TarelOptions& options, const cv::Mat& image) {
  return TarelDetailed(options, image).image;
}

}  // namespace turbid
