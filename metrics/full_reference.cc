#include "metrics/full_reference.h"

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "metrics/image_checks.h"
#include "metrics/simd_dispatch.h"
#include "core/error.h"

namespace turbid {

bool PsnrOptions::Check(std::string* why) const {
  if (!(data_range >= 0.0) || !std::isfinite(data_range)) {
    if (why) *why = "data_range must be >= 0 (0 = from the pixel depth)";
    return false;
  }
  return true;
}

bool CnrOptions::Check(std::string* why) const {
  auto fail = [&](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (!(data_range >= 0.0) || !std::isfinite(data_range))
    return fail("data_range must be >= 0 (0 = from the pixel depth)");
  if (signal_mask.empty() != background_mask.empty())
    return fail("give both signal_mask and background_mask, or neither");
  for (const cv::Mat* mask : {&signal_mask, &background_mask})
    if (!mask->empty() && mask->type() != CV_8UC1) return fail("masks must be CV_8UC1");
  return true;
}

double Mse(const cv::Mat& reference, const cv::Mat& image) {
  CheckMetricPair(reference, image, "mse");
  if (reference.depth() != image.depth())
    throw Error("mse: reference and image have different pixel depths (convert one first)");
  const int cols = reference.cols * reference.channels();
  const double count = static_cast<double>(cols) * reference.rows;
  if (reference.depth() == CV_8U) {
    uint64_t sum = 0;
    for (int i = 0; i < reference.rows; ++i)
      sum += simd::SquaredDifferenceSumU8(reference.ptr<uint8_t>(i), image.ptr<uint8_t>(i),
                                          static_cast<size_t>(cols));
    return static_cast<double>(sum) / count;
  }
  if (reference.depth() == CV_32F) {
    double sum = 0.0;
    for (int i = 0; i < reference.rows; ++i)
      sum += simd::SquaredDifferenceSumF32(reference.ptr<float>(i), image.ptr<float>(i),
                                           static_cast<size_t>(cols));
    return sum / count;
  }
  // 16-bit and double: rarer, plain double arithmetic in row order.
  cv::Mat a, b;
  reference.reshape(1).convertTo(a, CV_64F);
  image.reshape(1).convertTo(b, CV_64F);
  double sum = 0.0;
  for (int i = 0; i < a.rows; ++i) {
    const double* pa = a.ptr<double>(i);
    const double* pb = b.ptr<double>(i);
    for (int j = 0; j < a.cols; ++j) sum += (pa[j] - pb[j]) * (pa[j] - pb[j]);
  }
  return sum / count;
}

double PsnrFromMse(double mse, double data_range) {
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(data_range * data_range / mse);
}

double Psnr(const PsnrOptions& options, const cv::Mat& reference, const cv::Mat& image) {
  ThrowIfInvalid(options, "psnr");
  const double mse = Mse(reference, image);
  const double range =
      options.data_range > 0.0 ? options.data_range : DefaultDataRange(reference.depth());
  return PsnrFromMse(mse, range);
}

cv::Mat Luminance(const cv::Mat& image) {
  cv::Mat as_float;
  image.convertTo(as_float, CV_MAKETYPE(CV_32F, image.channels()));
  if (image.channels() == 1) return as_float;
  std::vector<cv::Mat> planes;
  cv::split(as_float, planes);
  cv::Mat y(image.size(), CV_32F);
  // Rec. 601 luma in BGR order; weights as cv::cvtColor(BGR2GRAY).
  cv::addWeighted(planes[0], 0.114, planes[1], 0.587, 0.0, y);
  cv::scaleAdd(planes[2], 0.299, y, y);
  return y;
}

namespace {

// Mean and standard deviation of y over `signal` (mask != 0) and over its complement, in double,
// two passes; each sum adds its region's values in row-major order. A region without pixels keeps
// the result's defaults.
void ComplementaryStats(const cv::Mat& y, const cv::Mat& signal, CnrResult* result) {
  // Branch-free (noisy images have ragged regions): a pixel adds +0.0 to the other region's sum,
  // which leaves it unchanged (a sum starting at +0.0 never becomes -0.0).
  long long n_signal = 0, n_total = 0;
  double sum_signal = 0.0, sum_background = 0.0;
  for (int i = 0; i < y.rows; ++i) {
    const float* py = y.ptr<float>(i);
    const uint8_t* pm = signal.ptr<uint8_t>(i);
    for (int j = 0; j < y.cols; ++j) {
      const bool in = pm[j] != 0;
      const double v = py[j];
      sum_signal += in ? v : 0.0;
      sum_background += in ? 0.0 : v;
      n_signal += in;
    }
    n_total += y.cols;
  }
  const long long n_background = n_total - n_signal;
  const double mean_signal = n_signal > 0 ? sum_signal / static_cast<double>(n_signal) : 0.0;
  const double mean_background =
      n_background > 0 ? sum_background / static_cast<double>(n_background) : 0.0;
  double ss_signal = 0.0, ss_background = 0.0;
  for (int i = 0; i < y.rows; ++i) {
    const float* py = y.ptr<float>(i);
    const uint8_t* pm = signal.ptr<uint8_t>(i);
    for (int j = 0; j < y.cols; ++j) {
      const bool in = pm[j] != 0;
      const double ds = py[j] - mean_signal, db = py[j] - mean_background;
      ss_signal += in ? ds * ds : 0.0;
      ss_background += in ? 0.0 : db * db;
    }
  }
  result->signal_pixels = n_signal;
  result->background_pixels = n_background;
  if (n_signal > 0) {
    result->signal_mean = mean_signal;
    result->signal_std = std::sqrt(ss_signal / static_cast<double>(n_signal));
  }
  if (n_background > 0) {
    result->background_mean = mean_background;
    result->background_std = std::sqrt(ss_background / static_cast<double>(n_background));
  }
}

}  // namespace

CnrResult Cnr(const CnrOptions& options, const cv::Mat& image) {
  ThrowIfInvalid(options, "cnr");
  CheckMetricImage(image, "cnr");
  const cv::Mat y = Luminance(image);
  CnrResult result;
  cv::Mat signal, background;
  if (!options.signal_mask.empty()) {
    if (options.signal_mask.size() != image.size() ||
        options.background_mask.size() != image.size())
      throw Error("cnr: region masks must have the image's size");
    signal = options.signal_mask;
    background = options.background_mask;
  } else {
    const double range =
        options.data_range > 0.0 ? options.data_range : DefaultDataRange(image.depth());
    cv::Mat y8;
    y.convertTo(y8, CV_8U, 255.0 / range);  // saturating, rounds to nearest
    cv::Mat above;
    result.otsu_threshold =
        static_cast<int>(cv::threshold(y8, above, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU));
    signal = above;
    cv::bitwise_not(above, background);
  }
  // Two-pass mean / variance in double for accuracy.
  auto stats = [&](const cv::Mat& mask, double* mean, double* stddev) -> long long {
    long long n = 0;
    double sum = 0.0;
    for (int i = 0; i < y.rows; ++i) {
      const float* py = y.ptr<float>(i);
      const uint8_t* pm = mask.ptr<uint8_t>(i);
      for (int j = 0; j < y.cols; ++j)
        if (pm[j]) {
          sum += py[j];
          ++n;
        }
    }
    if (n == 0) return 0;
    *mean = sum / static_cast<double>(n);
    double ss = 0.0;
    for (int i = 0; i < y.rows; ++i) {
      const float* py = y.ptr<float>(i);
      const uint8_t* pm = mask.ptr<uint8_t>(i);
      for (int j = 0; j < y.cols; ++j)
        if (pm[j]) ss += (py[j] - *mean) * (py[j] - *mean);
    }
    *stddev = std::sqrt(ss / static_cast<double>(n));
    return n;
  };
  if (options.signal_mask.empty()) {
    // The Otsu regions split the image (background = not signal): one pass per statistic for both
    // regions, each region's sum still taking its terms in pixel order (the same values as two
    // calls of stats).
    ComplementaryStats(y, signal, &result);
  } else {
    result.signal_pixels = stats(signal, &result.signal_mean, &result.signal_std);
    result.background_pixels = stats(background, &result.background_mean, &result.background_std);
  }
  if (result.signal_pixels == 0 || result.background_pixels == 0) {
    result.cnr = 0.0;  // one region only: no contrast to measure
    return result;
  }
  const double contrast = std::abs(result.signal_mean - result.background_mean);
  const double noise = std::sqrt(result.signal_std * result.signal_std +
                                 result.background_std * result.background_std);
  if (noise == 0.0)
    result.cnr = contrast == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
  else
    result.cnr = contrast / noise;
  return result;
}

}  // namespace turbid
