// Fast visibility restoration (Tarel & Hautière, ICCV 2009), with the white balance and the final
// gamma correction / tone mapping of the authors' reference implementation. See
// enhancer/baselines.h and docs/methods-baselines.md.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "enhancer/baselines.h"
#include "enhancer/baselines_common.h"
#include "scenes/error.h"

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
  if (image.channels() == 1) return image.clone();
  cv::Mat mean;
  cv::transform(image, mean, cv::Matx13f(1.0f / 3, 1.0f / 3, 1.0f / 3));
  return mean;
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

// Mean and sample standard deviation of log(v + 0.5/255) over the bottom third of the rows.
void BottomThirdLogStats(const cv::Mat& gray, double* mean, double* stddev) {
  const int first = std::min(gray.rows - 1, (2 * gray.rows) / 3);
  cv::Mat bottom = gray.rowRange(first, gray.rows).clone();
  cv::Mat logs;
  cv::log(bottom + 0.5 / 255.0, logs);
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
  const int half = size / 2;
  cv::Mat padded;
  cv::copyMakeBorder(image, padded, half, half, half, half, cv::BORDER_REFLECT);
  // Huang's sliding histogram on coarse bins finds the bin holding the median; the exact value is
  // then selected among the few window values in that bin. Exact, and ~10x faster than selecting
  // among all size^2 values per pixel.
  constexpr int kBins = 4096;
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(padded, &lo, &hi);
  const double scale = hi > lo ? (kBins - 1e-3) / (hi - lo) : 0.0;
  cv::Mat bins(padded.size(), CV_16UC1);
  for (int y = 0; y < padded.rows; ++y) {
    const float* v = padded.ptr<float>(y);
    uint16_t* b = bins.ptr<uint16_t>(y);
    for (int x = 0; x < padded.cols; ++x) {
      b[x] = static_cast<uint16_t>(std::min(kBins - 1, static_cast<int>((v[x] - lo) * scale)));
    }
  }
  cv::Mat out(image.size(), CV_32FC1);
  const int middle = (size * size) / 2;  // rank of the median, 0-based
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& rows) {
    std::vector<int> histogram(kBins);
    std::vector<float> candidates;
    candidates.reserve(static_cast<size_t>(size) * size);
    for (int y = rows.start; y < rows.end; ++y) {
      std::fill(histogram.begin(), histogram.end(), 0);
      for (int dy = 0; dy < size; ++dy) {
        const uint16_t* b = bins.ptr<uint16_t>(y + dy);
        for (int dx = 0; dx < size; ++dx) ++histogram[b[dx]];
      }
      int bin = 0;
      int below = 0;  // window values in bins < bin
      float* o = out.ptr<float>(y);
      for (int x = 0; x < image.cols; ++x) {
        if (x > 0) {
          for (int dy = 0; dy < size; ++dy) {
            const uint16_t* b = bins.ptr<uint16_t>(y + dy);
            const int gone = b[x - 1];
            const int added = b[x - 1 + size];
            --histogram[gone];
            if (gone < bin) --below;
            ++histogram[added];
            if (added < bin) ++below;
          }
        }
        while (below > middle) below -= histogram[--bin];
        while (below + histogram[bin] <= middle) below += histogram[bin++];
        candidates.clear();
        for (int dy = 0; dy < size; ++dy) {
          const uint16_t* b = bins.ptr<uint16_t>(y + dy) + x;
          const float* v = padded.ptr<float>(y + dy) + x;
          for (int dx = 0; dx < size; ++dx) {
            if (b[dx] == bin) candidates.push_back(v[dx]);
          }
        }
        const auto nth = candidates.begin() + (middle - below);
        std::nth_element(candidates.begin(), nth, candidates.end());
        o[x] = *nth;
      }
    }
  });
  return out;
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
  } else if (color && options.balance > 0.0) {
    local_factors = LocalBalanceFactors(image, options.sv, options.balance);
    cv::divide(image, local_factors, result.balanced);
  } else {
    result.balanced = image.clone();
  }
  // Balanced values above 1 would let the veil exceed 1 and the restoration divide by <= 0.
  baselines_internal::ClampUnit(result.balanced);

  // Tarel 2009 §4.3: A = median_sv(W); B = A - median_sv(|W - A|); V = p max(min(W, B), 0).
  result.whiteness = ChannelMin(result.balanced);
  const cv::Mat local_median = MedianFilter(result.whiteness, options.sv);
  const cv::Mat deviation = cv::abs(result.whiteness - local_median);
  const cv::Mat bound = local_median - MedianFilter(deviation, options.sv);
  result.veil = cv::max(cv::min(result.whiteness, bound), 0.0) * options.p;

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
    result.image = result.restored.clone();
    baselines_internal::ClampUnit(result.image);
    return result;
  }
  // Reference code: a gamma that matches the log-mean and log-spread of the bottom third of the
  // image to the input's, then u / (1 + (1 - 1/max u) u), which maps max u to 1.
  double mean_in, std_in, mean_out, std_out;
  BottomThirdLogStats(ChannelMean(result.balanced), &mean_in, &std_in);
  BottomThirdLogStats(ChannelMean(result.restored), &mean_out, &std_out);
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
    cv::Mat denominator = u * (1.0 - 1.0 / max_u) + cv::Scalar::all(1.0);
    cv::divide(u, denominator, result.image);
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
