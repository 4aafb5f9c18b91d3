#include "simulator/psf_small_angle.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "simulator/phase_function.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxForwardDepth = 80.0;  // b_f r beyond this: e^{-c r} is 0 in float

// The DFT response of the normalised sampled Gaussian of sigma px, periodised with period n, at
// frequency index k (real and even: the kernel is symmetric).
std::vector<float> GaussianResponse(int n, double sigma) {
  std::vector<float> h(static_cast<size_t>(n), 1.0f);
  if (n <= 1 || sigma <= 0.0) return h;
  if (sigma >= 1.0) {
    // Poisson summation: sum_i g(i) e^{-2 pi i nu i} = sigma sqrt(2 pi) sum_m g^(nu - m); terms
    // with |m| > 3 are below e^{-2 pi^2 6.25} of the leading one.
    auto sum = [&](double nu) {
      double s = 0.0;
      for (int m = -3; m <= 3; ++m)
        s += std::exp(-2.0 * kPi * kPi * sigma * sigma * (nu - m) * (nu - m));
      return s;
    };
    const double norm = sum(0.0);
    for (int k = 0; k < n; ++k) h[k] = static_cast<float>(sum(static_cast<double>(k) / n) / norm);
    return h;
  }
  const int radius = static_cast<int>(std::ceil(10.0 * sigma)) + 1;
  std::vector<double> g(static_cast<size_t>(radius) + 1);
  double norm = 0.0;
  for (int i = 0; i <= radius; ++i) {
    g[i] = std::exp(-0.5 * i * i / (sigma * sigma));
    norm += i == 0 ? g[i] : 2.0 * g[i];
  }
  for (int k = 0; k < n; ++k) {
    double s = g[0];
    for (int i = 1; i <= radius; ++i) s += 2.0 * g[i] * std::cos(2.0 * kPi * k * i / n);
    h[k] = static_cast<float>(s / norm);
  }
  return h;
}

// Each row of `plane` blurred by the normalised sampled Gaussian of sigma px under mirrored
// borders: the row extended by R = 8 sigma + 2 mirrored pixels each side (cv::borderInterpolate,
// repeated as often as R needs), zero-padded to a fast DFT length M >= W + 2R (so the circular
// convolution never wraps into the pixels read back), transformed, multiplied by the Gaussian's
// response and transformed back. The kernel's mass beyond 8 sigma (< 1e-15) is the only
// truncation.
cv::Mat BlurRows(const cv::Mat& plane, double sigma) {
  const int w = plane.cols, h = plane.rows;
  if (sigma <= 0.0 || w == 1) return plane.clone();
  const int radius = static_cast<int>(std::ceil(8.0 * sigma)) + 2;
  const int m = cv::getOptimalDFTSize(w + 2 * radius);
  std::vector<int> source(static_cast<size_t>(w + 2 * radius));
  for (int j = 0; j < w + 2 * radius; ++j)
    source[j] = cv::borderInterpolate(j - radius, w, cv::BORDER_REFLECT_101);
  cv::Mat ext(h, m, CV_32F, cv::Scalar(0));
  for (int y = 0; y < h; ++y) {
    const float* src = plane.ptr<float>(y);
    float* dst = ext.ptr<float>(y);
    for (int j = 0; j < w + 2 * radius; ++j) dst[j] = src[source[j]];
  }
  cv::Mat spectrum;
  cv::dft(ext, spectrum, cv::DFT_ROWS | cv::DFT_COMPLEX_OUTPUT);
  const std::vector<float> response = GaussianResponse(m, sigma);
  for (int y = 0; y < h; ++y) {
    cv::Vec2f* s = spectrum.ptr<cv::Vec2f>(y);
    for (int k = 0; k < m; ++k) s[k] *= response[k];
  }
  cv::Mat back;
  cv::dft(spectrum, back, cv::DFT_INVERSE | cv::DFT_ROWS | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  return back(cv::Rect(radius, 0, w, h)).clone();
}

// Separable: rows at sigma_x, then columns (as rows of the transpose) at sigma_y.
cv::Mat BlurPlane(const cv::Mat& plane, double sigma_x, double sigma_y) {
  const cv::Mat rows = BlurRows(plane, sigma_x);
  if (sigma_y <= 0.0 || plane.rows == 1) return rows;
  return BlurRows(rows.t(), sigma_y).t();
}

// Each pixel's level position: the level k at or below its sigma and the share w of level k + 1
// (linear in sigma^2); k = -1 where the pixel has no glow (NaN range).
struct LevelMap {
  cv::Mat lower;   // CV_32SC1
  cv::Mat weight;  // CV_32FC1
  cv::Mat factor;  // CV_32FC1: e^{b_f r} - 1
};

LevelMap MapLevels(const SmallAngleChannel& ch, const cv::Mat& range_m,
                   const std::vector<double>& sigma_rad) {
  LevelMap m{cv::Mat(range_m.size(), CV_32SC1), cv::Mat(range_m.size(), CV_32FC1),
             cv::Mat(range_m.size(), CV_32FC1)};
  const int levels = static_cast<int>(sigma_rad.size());
  const double log_lo = std::log(sigma_rad.front());
  const double step =
      levels > 1 ? std::log(sigma_rad.back() / sigma_rad.front()) / (levels - 1) : 1.0;
  for (int y = 0; y < range_m.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    int* k = m.lower.ptr<int>(y);
    float* w = m.weight.ptr<float>(y);
    float* f = m.factor.ptr<float>(y);
    for (int x = 0; x < range_m.cols; ++x) {
      if (std::isnan(r[x])) {
        k[x] = -1, w[x] = 0.0f, f[x] = 0.0f;
        continue;
      }
      f[x] = static_cast<float>(GlowFactor(ch, r[x]));
      if (levels == 1) {
        k[x] = 0, w[x] = 0.0f;
        continue;
      }
      const double v = 0.5 * GlowMeanSquareAngle(ch, r[x]);  // sigma^2, rad^2
      const double pos = (0.5 * std::log(v) - log_lo) / step;
      const int i = std::clamp(static_cast<int>(std::floor(pos)), 0, levels - 2);
      const double s0 = sigma_rad[i] * sigma_rad[i], s1 = sigma_rad[i + 1] * sigma_rad[i + 1];
      k[x] = i;
      w[x] = static_cast<float>(std::clamp((v - s0) / (s1 - s0), 0.0, 1.0));
    }
  }
  return m;
}

// The levels shared by the channels: glow_levels widths geometric in sigma over the image's
// pixels and channels, or one when they all have the same width.
std::vector<double> PlanLevels(const PsfOptions& options,
                               const std::vector<SmallAngleChannel>& channels, double min_r,
                               double max_r) {
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (const SmallAngleChannel& ch : channels) {
    if (ch.forward_per_m <= 0.0) continue;
    lo = std::min(lo, std::sqrt(0.5 * GlowMeanSquareAngle(ch, min_r)));
    hi = std::max(hi, std::sqrt(0.5 * GlowMeanSquareAngle(ch, max_r)));
  }
  if (!(hi > 0.0)) return {};
  if (hi <= lo * (1.0 + 1e-9)) return {hi};
  // No finer than 2 % per level (the glow is smooth in sigma^2; the reference test measures it).
  const int n =
      std::min(options.glow_levels,
               std::max(2, static_cast<int>(std::ceil(std::log(hi / lo) / std::log(1.02))) + 1));
  std::vector<double> sigma(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) sigma[i] = lo * std::pow(hi / lo, static_cast<double>(i) / (n - 1));
  sigma.back() = hi;
  return sigma;
}

// One channel: J + factor * sum over levels of the level's share times its blur.
void GlowChannel(const cv::Mat& plane, const LevelMap& m, const std::vector<double>& sigma_rad,
                 const CameraIntrinsics& camera, cv::Mat& out_plane) {
  const int levels = static_cast<int>(sigma_rad.size());
  // lower: (1 - w) G_k at pixels whose level is k; upper: w G_{k+1} at pixels whose level is k.
  cv::Mat lower(plane.size(), CV_32F, cv::Scalar(0)), upper(plane.size(), CV_32F, cv::Scalar(0));
  // Which levels any pixel needs (as its own or its upper level).
  std::vector<char> needed(static_cast<size_t>(levels), 0);
  for (int y = 0; y < plane.rows; ++y) {
    const int* k = m.lower.ptr<int>(y);
    const float* w = m.weight.ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x) {
      if (k[x] < 0) continue;
      if (w[x] < 1.0f) needed[k[x]] = 1;
      if (w[x] > 0.0f) needed[k[x] + 1] = 1;
    }
  }
  cv::parallel_for_(cv::Range(0, levels), [&](const cv::Range& range) {
    for (int level = range.start; level < range.end; ++level) {
      if (!needed[level]) continue;
      const cv::Mat blur = BlurPlane(plane, std::abs(camera.fx) * sigma_rad[level],
                                     std::abs(camera.fy) * sigma_rad[level]);
      for (int y = 0; y < plane.rows; ++y) {
        const int* k = m.lower.ptr<int>(y);
        const float* w = m.weight.ptr<float>(y);
        const float* b = blur.ptr<float>(y);
        float* lo = lower.ptr<float>(y);
        float* up = upper.ptr<float>(y);
        for (int x = 0; x < plane.cols; ++x) {
          if (k[x] == level) lo[x] = (1.0f - w[x]) * b[x];
          if (k[x] + 1 == level && k[x] >= 0) up[x] = w[x] * b[x];
        }
      }
    }
  });
  for (int y = 0; y < plane.rows; ++y) {
    const float* j = plane.ptr<float>(y);
    const float* f = m.factor.ptr<float>(y);
    const float* lo = lower.ptr<float>(y);
    const float* up = upper.ptr<float>(y);
    float* o = out_plane.ptr<float>(y);
    for (int x = 0; x < plane.cols; ++x) o[x] = j[x] + f[x] * (lo[x] + up[x]);
  }
}

}  // namespace

std::vector<SmallAngleChannel> SmallAngleChannels(const VeilWater& water) {
  const PhaseFunction phase(water.phase);
  const double forward_share = 1.0 - phase.BackscatterRatio();
  const double msa = phase.MeanSquareAngle(kPi / 2.0);
  std::vector<SmallAngleChannel> out;
  for (size_t c = 0; c < water.c_per_m.size(); ++c) {
    SmallAngleChannel ch;
    ch.c_per_m = water.c_per_m[c];
    ch.b_per_m = c < water.b_per_m.size() ? water.b_per_m[c] : 0.0;
    ch.forward_per_m = ch.b_per_m * forward_share;
    ch.mean_square_angle_rad2 = msa;
    out.push_back(ch);
  }
  return out;
}

double GlowMeanSquareAngle(const SmallAngleChannel& channel, double range_m) {
  const double x = channel.forward_per_m * std::max(range_m, 0.0);
  // x / (1 - e^{-x}) -> 1 + x/2 as x -> 0.
  const double ratio = x < 1e-8 ? 1.0 + 0.5 * x : x / -std::expm1(-x);
  return channel.mean_square_angle_rad2 * ratio / 3.0;
}

double GlowFactor(const SmallAngleChannel& channel, double range_m) {
  if (std::isnan(range_m)) return 0.0;
  return std::expm1(std::min(channel.forward_per_m * std::max(range_m, 0.0), kMaxForwardDepth));
}

cv::Mat MirroredGaussianBlur(const cv::Mat& plane, double sigma_x_px, double sigma_y_px) {
  CV_Assert(plane.type() == CV_32FC1);
  return BlurPlane(plane, sigma_x_px, sigma_y_px);
}

cv::Mat ApplySmallAnglePsf(const PsfOptions& options, const VeilWater& water,
                           const CameraIntrinsics& camera, const cv::Mat& range_m,
                           const cv::Mat& image, SmallAngleReport* report) {
  ThrowIfInvalid(options, "psf");
  const int channels = image.channels();
  CV_Assert(image.depth() == CV_32F && range_m.type() == CV_32FC1 &&
            range_m.size() == image.size() && static_cast<int>(water.c_per_m.size()) == channels);
  const std::vector<SmallAngleChannel> chans = SmallAngleChannels(water);
  double min_r = std::numeric_limits<double>::infinity(), max_r = 0.0;
  for (int y = 0; y < range_m.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    for (int x = 0; x < range_m.cols; ++x)
      if (!std::isnan(r[x]))
        min_r = std::min<double>(min_r, r[x]), max_r = std::max<double>(max_r, r[x]);
  }
  if (report) *report = SmallAngleReport{};
  if (!(max_r >= min_r)) return image.clone();  // open water only: t = 0 everywhere
  // A uniform range: each channel its own width (exact); else levels shared by the channels.
  const bool exact = min_r == max_r;
  const std::vector<double> shared = PlanLevels(options, chans, min_r, max_r);
  if (shared.empty()) return image.clone();  // no forward scattering
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  std::vector<cv::Mat> out_planes(static_cast<size_t>(channels));
  for (int c = 0; c < channels; ++c) {
    out_planes[c] = cv::Mat(image.size(), CV_32F);
    const SmallAngleChannel& ch = chans[c];
    if (ch.forward_per_m <= 0.0) {
      planes[c].copyTo(out_planes[c]);
      continue;
    }
    std::vector<double> sigma = shared;
    if (exact) sigma = {std::sqrt(0.5 * GlowMeanSquareAngle(ch, max_r))};
    const LevelMap m = MapLevels(ch, range_m, sigma);
    GlowChannel(planes[c], m, sigma, camera, out_planes[c]);
  }
  if (report) {
    report->sigma_rad = shared;
    report->exact = exact || shared.size() == 1;
    report->sigma_min_px = std::abs(camera.fx) * shared.front();
    report->sigma_max_px = std::abs(camera.fx) * shared.back();
  }
  cv::Mat out;
  cv::merge(out_planes, out);
  return out;
}

}  // namespace turbid
