#include "metrics/ssim.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "metrics/image_checks.h"
#include "metrics/simd_dispatch.h"
#include "metrics/ssim_double_kernel.h"

namespace turbid {

bool SsimOptions::Check(std::string* why) const {
  auto fail = [&](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (!(sigma > 0.0) || !std::isfinite(sigma)) return fail("sigma must be > 0");
  if (!(truncate > 0.0) || truncate > 20.0) return fail("truncate must be in (0, 20]");
  if (!(k1 > 0.0) || k1 >= 1.0) return fail("k1 must be in (0, 1)");
  if (!(k2 > 0.0) || k2 >= 1.0) return fail("k2 must be in (0, 1)");
  if (!(data_range >= 0.0) || !std::isfinite(data_range))
    return fail("data_range must be >= 0 (0 = from the pixel depth)");
  if (SsimRadius(*this) > 64) return fail("sigma * truncate too large (radius > 64 pixels)");
  return true;
}

int SsimRadius(const SsimOptions& options) {
  // scipy.ndimage.gaussian_filter1d: radius = int(truncate * sd + 0.5).
  return static_cast<int>(options.truncate * options.sigma + 0.5);
}

namespace {

// Normalised 1-D Gaussian taps, computed in double as scipy does, then rounded once to float.
std::vector<float> GaussianTaps(double sigma, int radius) {
  std::vector<double> taps(2 * radius + 1);
  double sum = 0.0;
  for (int k = -radius; k <= radius; ++k) {
    taps[k + radius] = std::exp(-0.5 / (sigma * sigma) * k * k);
    sum += taps[k + radius];
  }
  std::vector<float> out(taps.size());
  for (size_t k = 0; k < taps.size(); ++k) out[k] = static_cast<float>(taps[k] / sum);
  return out;
}

// scipy.ndimage mode 'reflect' (= OpenCV BORDER_REFLECT): -1 -> 0, n -> n - 1. One reflection is
// enough because Ssim() requires n >= 2 * radius + 1.
inline int Reflect(int i, int n) {
  if (i < 0) return -i - 1;
  if (i >= n) return 2 * n - i - 1;
  return i;
}

// SSIM of 8-bit images: four windowed moments, fused. The formula needs E[x], E[y], cov(x, y) and
// only the sum var(x) + var(y) = 2 cov(x, y) + var(x - y), so the moments filtered are x, y, xy
// (centred) and (x - y)^2: four instead of five, and var(x - y) without the cancellation of
// E[x^2] + E[y^2] - 2 E[xy]. Every input row is converted, centred and multiplied once into a ring
// of (2r + 4) rows (all four values are exact in float for 8-bit data); each group of four output
// rows is one vertical pass per moment (symmetric taps: pairs added before the multiply; input rows
// read once for all four outputs), then per row one horizontal pass of the four moments fused with
// the SSIM formula, so the filtered moments stay in registers. Centring by data_range / 2 keeps
// E[xy] - E[x] E[y] from cancelling badly in float32; the covariance is shift-invariant and the
// means get the offset back.
class SsimBand {
 public:
  SsimBand(const cv::Mat& ref, const cv::Mat& img, int channel, const std::vector<float>& taps,
           double offset, double c1, double c2)
      : ref_(ref),
        img_(img),
        channel_(channel),
        taps_(taps),
        radius_(static_cast<int>(taps.size() / 2)),
        width_(ref.cols),
        height_(ref.rows),
        offset_(offset),
        c1_(c1),
        c2_(c2) {
    const size_t n = static_cast<size_t>(width_);
    const size_t ring_rows = taps_.size() + kGroup - 1;
    ring_.assign(kMoments * ring_rows * n, 0.0f);
    padded_.assign(kGroup * kMoments * (n + 2 * radius_), 0.0f);
    ssim_row_.assign(n, 0.0);
  }

  // Computes output rows [row_begin, row_end); writes each row's cropped sum into row_sums[row]
  // (rows outside the crop get 0) and, when map is not empty, the map row. Rows go in groups of
  // four, then pairs: the vertical pass shares its input rows within a group (an odd last row
  // computes one row past row_end, reflected like any border row, and drops it). Every row takes
  // the same arithmetic whatever its group, so results do not depend on the banding.
  void Run(int row_begin, int row_end, int col_begin, int col_end, cv::Mat* map, double* row_sums) {
    const int taps = static_cast<int>(taps_.size());
    const size_t padded_width = static_cast<size_t>(width_ + 2 * radius_);
    // A band that continues the previous one keeps the ring rows it already holds.
    const int slots = taps + kGroup - 1;
    int next_virtual = row_begin - radius_;
    if (filled_end_ >= next_virtual && filled_end_ - slots <= next_virtual)
      next_virtual = filled_end_;
    const float* rows[kMaxTaps + 3];
    float* vertical[kGroup][kMoments];
    for (int t = 0; t < kGroup; ++t)
      for (int m = 0; m < kMoments; ++m)
        vertical[t][m] = padded_.data() + (t * kMoments + m) * padded_width + radius_;
    for (int i = row_begin; i < row_end;) {
      const int group = i + kGroup <= row_end ? kGroup : 2;
      for (; next_virtual <= i + group - 1 + radius_; ++next_virtual) FillRing(next_virtual);
      for (int m = 0; m < kMoments; ++m) {
        for (int k = 0; k < taps + group - 1; ++k) rows[k] = RingRow(i - radius_ + k, m);
        if (group == kGroup) {
          float* out[kGroup] = {vertical[0][m], vertical[1][m], vertical[2][m], vertical[3][m]};
          simd::SymmetricColumnQuad(rows, taps_.data(), taps, out, width_);
        } else {
          simd::SymmetricColumnPair(rows, taps_.data(), taps, vertical[0][m], vertical[1][m],
                                    width_);
        }
      }
      for (int t = 0; t < group && i + t < row_end; ++t)
        FinishRow(i + t, vertical[t], col_begin, col_end, map, row_sums);
      i += group;
    }
    filled_end_ = next_virtual;
  }

  static constexpr int kMaxTaps = 2 * 64 + 1;

 private:
  static constexpr int kMoments = 4;  // x, y, xy (centred), (x - y)^2
  static constexpr int kGroup = 4;    // output rows per vertical pass

  // Reflects the vertically filtered moments of one row into their borders, then the horizontal
  // pass and the formula; stores the map row and the cropped row sum.
  void FinishRow(int row, float* const* vertical, int col_begin, int col_end, cv::Mat* map,
                 double* row_sums) {
    const float* horizontal[kMoments];
    for (int m = 0; m < kMoments; ++m) {
      float* out = vertical[m];
      for (int p = 0; p < radius_; ++p) {
        out[-1 - p] = out[p];
        out[width_ + p] = out[width_ - 1 - p];
      }
      horizontal[m] = out + col_begin;
    }
    const int taps = static_cast<int>(taps_.size());
    simd::SsimHorizontalFormula(horizontal, taps_.data(), taps, col_end - col_begin, offset_, c1_,
                                c2_, ssim_row_.data() + col_begin);
    if (map != nullptr && !map->empty()) {
      float* map_row = map->ptr<float>(row);
      for (int j = col_begin; j < col_end; ++j) map_row[j] = static_cast<float>(ssim_row_[j]);
    }
    const bool inside = row >= radius_ && row < height_ - radius_;
    row_sums[row] =
        inside ? simd::OrderedSum(ssim_row_.data() + radius_, width_ - 2 * radius_) : 0.0;
  }

  float* RingRow(int virtual_row, int moment) {
    const int slots = static_cast<int>(taps_.size()) + kGroup - 1;  // one group's input rows
    const int slot = ((virtual_row % slots) + slots) % slots;
    return ring_.data() + (static_cast<size_t>(moment) * slots + slot) * width_;
  }

  void FillRing(int virtual_row) {
    const int row = Reflect(virtual_row, height_);
    simd::CentredMomentsU8(ref_.ptr<uint8_t>(row) + channel_, img_.ptr<uint8_t>(row) + channel_,
                           ref_.channels(), static_cast<float>(offset_), RingRow(virtual_row, 0),
                           RingRow(virtual_row, 1), RingRow(virtual_row, 2),
                           RingRow(virtual_row, 3), width_);
  }

  const cv::Mat& ref_;
  const cv::Mat& img_;
  int channel_;
  const std::vector<float>& taps_;
  int radius_;
  int width_;
  int height_;
  double offset_;
  double c1_;
  double c2_;
  std::vector<float> ring_;
  std::vector<float> padded_;
  std::vector<double> ssim_row_;
  int filled_end_ = INT_MIN;  // ring rows [filled_end_ - slots, filled_end_) are filled
};

// The plain double-precision path (SsimOptions::exact_double): five full-size CV_64F moment
// images from OpenCV's separable filter (BORDER_REFLECT = scipy 'reflect'), the formula in double.
// The straightforward transcription of scikit-image, kept as the cross-check of the fused kernels.
double PreciseChannel(const cv::Mat& ref, const cv::Mat& img, int channel,
                      const std::vector<double>& taps, int radius, double c1, double c2,
                      cv::Mat* map) {
  cv::Mat x, y;
  cv::extractChannel(ref, x, channel);
  cv::extractChannel(img, y, channel);
  x.convertTo(x, CV_64F);
  y.convertTo(y, CV_64F);
  const cv::Mat kernel(static_cast<int>(taps.size()), 1, CV_64F, const_cast<double*>(taps.data()));
  auto blur = [&](const cv::Mat& src) {
    cv::Mat out;
    cv::sepFilter2D(src, out, CV_64F, kernel, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
    return out;
  };
  const cv::Mat mx = blur(x), my = blur(y);
  const cv::Mat mxx = blur(x.mul(x)), myy = blur(y.mul(y)), mxy = blur(x.mul(y));
  cv::Mat s(x.size(), CV_64F);
  for (int i = 0; i < s.rows; ++i)
    for (int j = 0; j < s.cols; ++j) {
      const double ux = mx.at<double>(i, j), uy = my.at<double>(i, j);
      const double vx = mxx.at<double>(i, j) - ux * ux, vy = myy.at<double>(i, j) - uy * uy;
      const double vxy = mxy.at<double>(i, j) - ux * uy;
      s.at<double>(i, j) =
          (2 * ux * uy + c1) * (2 * vxy + c2) / ((ux * ux + uy * uy + c1) * (vx + vy + c2));
    }
  if (map != nullptr) s.convertTo(*map, CV_32F);
  double sum = 0.0;  // row order: deterministic
  for (int i = radius; i < s.rows - radius; ++i)
    sum += simd::OrderedSum(s.ptr<double>(i) + radius, s.cols - 2 * radius);
  return sum / (static_cast<double>(s.cols - 2 * radius) * (s.rows - 2 * radius));
}

// Rows per parallel task. Each task re-fills 2r ring rows, so bands are kept well above r.
constexpr int kRowsPerBand = 32;

}  // namespace

namespace {

// The one-line errors of Ssim's inputs (options, sizes, depths, the window's minimum size);
// returns the Gaussian window's radius.
int CheckSsimInputs(const SsimOptions& options, const cv::Mat& reference, const cv::Mat& image) {
  ThrowIfInvalid(options, "ssim");
  const int radius = SsimRadius(options);
  CheckMetricPair(reference, image, "ssim");
  if (reference.depth() != image.depth())
    throw Error("ssim: reference and image have different pixel depths (convert one first)");
  const int window = 2 * radius + 1;
  if (reference.cols < window || reference.rows < window)
    throw Error("ssim: image is " + std::to_string(reference.cols) + "x" +
                std::to_string(reference.rows) + " but the Gaussian window needs at least " +
                std::to_string(window) + "x" + std::to_string(window) + " pixels");
  return radius;
}

// The Gaussian taps in double, normalised to sum 1 (the exact and float64 paths).
std::vector<double> GaussianTaps64(double sigma, int radius) {
  std::vector<double> taps;
  double sum = 0.0;
  for (int k = -radius; k <= radius; ++k)
    sum += taps.emplace_back(std::exp(-0.5 / (sigma * sigma) * k * k));
  for (double& t : taps) t /= sum;
  return taps;
}

// One channel's mean SSIM by the 8-bit float32 fused kernel, in bands of rows run in parallel;
// the row sums are added in row order whatever the thread count (deterministic).
double FloatSsimChannel(const SsimOptions& options, const cv::Mat& reference, const cv::Mat& image,
                        int c, int radius, double range, double c1, double c2, cv::Mat* map) {
  const std::vector<float> taps = GaussianTaps(options.sigma, radius);
  const int width = reference.cols, height = reference.rows;
  // Without a map only the cropped region is ever averaged, so the border is not computed.
  const int row_begin = map ? 0 : radius;
  const int row_end = map ? height : height - radius;
  const int col_begin = map ? 0 : radius;
  const int col_end = map ? width : width - radius;
  const int bands = (row_end - row_begin + kRowsPerBand - 1) / kRowsPerBand;
  std::vector<double> row_sums(height, 0.0);
  if (map) map->create(height, width, CV_32F);
  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& range_of_bands) {
    SsimBand band(reference, image, c, taps, range / 2.0, c1, c2);
    for (int b = range_of_bands.start; b < range_of_bands.end; ++b) {
      const int begin = row_begin + b * kRowsPerBand;
      const int end = std::min(row_end, begin + kRowsPerBand);
      band.Run(begin, end, col_begin, col_end, map, row_sums.data());
    }
  });
  double sum = 0.0;
  for (int i = radius; i < height - radius; ++i) sum += row_sums[i];
  const double count = static_cast<double>(width - 2 * radius) * (height - 2 * radius);
  return sum / count;
}

}  // namespace

SsimResult Ssim(const SsimOptions& options, const cv::Mat& reference, const cv::Mat& image) {
  const int radius = CheckSsimInputs(options, reference, image);
  const double range =
      options.data_range > 0.0 ? options.data_range : DefaultDataRange(reference.depth());
  const double c1 = (options.k1 * range) * (options.k1 * range);
  const double c2 = (options.k2 * range) * (options.k2 * range);
  const int channels = reference.channels();
  SsimResult result;
  std::vector<cv::Mat> maps(channels);
  // 8-bit: float32 fused kernel (centred products exact in float). Other depths: the fused kernel
  // in float64 (metrics/ssim_double_kernel.cc says why). exact_double: the plain OpenCV path.
  const bool exact = options.exact_double;
  const bool fused_double = !exact && reference.depth() != CV_8U;
  const std::vector<double> taps64 = GaussianTaps64(options.sigma, radius);
  for (int c = 0; c < channels; ++c) {
    cv::Mat* map = options.compute_map ? &maps[c] : nullptr;
    if (exact) {
      result.per_channel.push_back(
          PreciseChannel(reference, image, c, taps64, radius, c1, c2, map));
    } else if (fused_double) {
      if (map) map->create(reference.rows, reference.cols, CV_32F);
      result.per_channel.push_back(ssim_internal::FusedDoubleSsimChannel(
          reference, image, c, taps64, range / 2.0, c1, c2, map));
    } else {
      result.per_channel.push_back(
          FloatSsimChannel(options, reference, image, c, radius, range, c1, c2, map));
    }
  }
  double total = 0.0;
  for (double v : result.per_channel) total += v;
  result.mean = total / channels;
  if (options.compute_map) {
    if (channels == 1)
      result.map = maps[0];
    else
      cv::merge(maps, result.map);
  }
  return result;
}

}  // namespace turbid
