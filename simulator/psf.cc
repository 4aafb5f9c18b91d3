#include "simulator/psf.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "scenes/error.h"

namespace turbid {
namespace {

// Series expansion of P(a, x), valid and fast for x < a + 1.
double GammaPSeries(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 100000; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::abs(term) < std::abs(sum) * 1e-16) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

// Continued fraction (modified Lentz) for Q(a, x), valid for x >= a + 1.
double GammaQContinuedFraction(double a, double x) {
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

// Q(a, x) = 1 - P(a, x), accurate in the tail.
double RegularizedGammaQ(double a, double x) {
  if (x <= 0.0) return 1.0;
  if (!std::isfinite(x)) return 0.0;
  if (x < a + 1.0) return 1.0 - GammaPSeries(a, x);
  return GammaQContinuedFraction(a, x);
}

bool InRange(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

// log A(p, sigma) = log sigma + 0.5 (lgamma(1/p) - lgamma(3/p)).
double LogScaleA(double p, double sigma_px) {
  return std::log(sigma_px) + 0.5 * (std::lgamma(1.0 / p) - std::lgamma(3.0 / p));
}

// exp(-(r/A)^p) from r^2 and log A, in logs so that p -> 0 and huge A stay finite.
double ProfileFromSquare(double p, double log_a, double r2) {
  if (r2 <= 0.0) return 1.0;
  const double exponent = p * (0.5 * std::log(r2) - log_a);
  if (exponent > 700.0) return 0.0;
  return std::exp(-std::exp(exponent));
}

}  // namespace

bool PsfOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!InRange(optical_thickness, 1e-4, 100.0))
    return fail("optical_thickness: must be in [1e-4, 100]");
  if (!InRange(forward_scatter, 1e-6, 1.0)) return fail("forward_scatter: must be in [1e-6, 1]");
  if (!InRange(pixels_per_unit, 1e-9, 1000.0) || pixels_per_unit <= 0.0)
    return fail("pixels_per_unit: must be in (0, 1000]");
  if (!InRange(tail_mass, 1e-12, 0.1)) return fail("tail_mass: must be in [1e-12, 0.1]");
  if (max_radius_px < 1 || max_radius_px > 512) return fail("max_radius_px: must be in [1, 512]");
  if (!InRange(delta_tolerance, 0.0, 0.5)) return fail("delta_tolerance: must be in [0, 0.5]");
  if (!InRange(reference_range_m, 1e-9, 1000.0) || reference_range_m <= 0.0)
    return fail("reference_range_m: must be in (0, 1000] m");
  if (depth_levels < 2 || depth_levels > 32) return fail("depth_levels: must be in [2, 32]");
  return true;
}

double RegularizedGammaP(double a, double x) {
  if (x <= 0.0) return 0.0;
  if (!std::isfinite(x)) return 1.0;
  if (x < a + 1.0) return GammaPSeries(a, x);
  return 1.0 - GammaQContinuedFraction(a, x);
}

double PsfProfile(double p, double scale_a_px, double r_px) {
  return ProfileFromSquare(p, std::log(scale_a_px), r_px * r_px);
}

Psf PsfKernel(const PsfOptions& options, double width_scale) {
  ThrowIfInvalid(options, "psf");
  if (!std::isfinite(width_scale) || width_scale < 0.0)
    throw Error("psf: width scale must be finite and >= 0");
  Psf psf;
  psf.p = std::sqrt(options.optical_thickness);
  psf.sigma_px = 0.5 / std::sqrt(options.forward_scatter) * options.pixels_per_unit * width_scale;
  psf.separable = psf.p == 2.0;
  if (psf.sigma_px <= 0.0) {
    psf.kernel = cv::Mat::ones(1, 1, CV_32F);
    psf.is_delta = true;
    if (psf.separable) psf.kernel_1d = psf.kernel.clone();
    return psf;
  }
  const double log_a = LogScaleA(psf.p, psf.sigma_px);
  psf.scale_a_px = std::exp(log_a);
  // Smallest radius whose outside mass P-complement is within tail_mass; capped.
  const double shape = 2.0 / psf.p;
  auto outside = [&](int radius) {
    const double x = std::exp(psf.p * (std::log(static_cast<double>(radius)) - log_a));
    return RegularizedGammaQ(shape, x);
  };
  int radius = 1;
  while (radius < options.max_radius_px && outside(radius) > options.tail_mass) ++radius;
  psf.radius_px = radius;
  psf.tail_mass_outside = outside(radius);

  const int size = 2 * radius + 1;
  cv::Mat kernel(size, size, CV_64F);
  for (int j = -radius; j <= radius; ++j)
    for (int i = -radius; i <= radius; ++i)
      kernel.at<double>(j + radius, i + radius) =
          ProfileFromSquare(psf.p, log_a, static_cast<double>(i * i + j * j));
  const double total = cv::sum(kernel)[0];
  kernel /= total;
  const double centre = kernel.at<double>(radius, radius);
  psf.is_delta = 1.0 - centre < options.delta_tolerance;
  if (psf.is_delta) {
    psf.kernel = cv::Mat::ones(1, 1, CV_32F);
    psf.radius_px = 0;
    if (psf.separable) psf.kernel_1d = psf.kernel.clone();
    return psf;
  }
  kernel.convertTo(psf.kernel, CV_32F);
  if (psf.separable) {
    cv::Mat k1(size, 1, CV_64F);
    for (int i = -radius; i <= radius; ++i)
      k1.at<double>(i + radius) = ProfileFromSquare(psf.p, log_a, static_cast<double>(i * i));
    k1 /= cv::sum(k1)[0];
    k1.convertTo(psf.kernel_1d, CV_32F);
  }
  return psf;
}

cv::Mat ApplyPsf(const Psf& psf, const cv::Mat& image) {
  CV_Assert(image.depth() == CV_32F);
  if (psf.is_delta || psf.kernel.empty() || psf.kernel.total() == 1) return image.clone();
  cv::Mat out;
  if (psf.separable && !psf.kernel_1d.empty()) {
    cv::sepFilter2D(image, out, CV_32F, psf.kernel_1d, psf.kernel_1d, cv::Point(-1, -1), 0.0,
                    cv::BORDER_REFLECT_101);
  } else {
    cv::filter2D(image, out, CV_32F, psf.kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT_101);
  }
  return out;
}

cv::Mat ApplyDepthDependentPsf(const PsfOptions& options, const cv::Mat& image,
                               const cv::Mat& range_m) {
  ThrowIfInvalid(options, "psf");
  CV_Assert(range_m.type() == CV_32FC1 && range_m.size() == image.size());
  double min_r = std::numeric_limits<double>::infinity(), max_r = 0.0;
  for (int y = 0; y < range_m.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    for (int x = 0; x < range_m.cols; ++x) {
      if (std::isnan(r[x])) continue;
      min_r = std::min<double>(min_r, r[x]);
      max_r = std::max<double>(max_r, r[x]);
    }
  }
  if (!(max_r > 0.0)) return ApplyPsf(PsfKernel(options), image);
  const double s_min = std::sqrt(min_r / options.reference_range_m);
  const double s_max = std::sqrt(max_r / options.reference_range_m);
  if (s_max - s_min < 1e-9) return ApplyPsf(PsfKernel(options, s_min), image);
  const int levels = options.depth_levels;
  std::vector<cv::Mat> blurred(levels);
  for (int i = 0; i < levels; ++i)
    blurred[i] = ApplyPsf(PsfKernel(options, s_min + (s_max - s_min) * i / (levels - 1)), image);
  cv::Mat out(image.size(), image.type());
  const int channels = image.channels();
  for (int y = 0; y < image.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      const double s = std::isnan(r[x]) ? s_max : std::sqrt(r[x] / options.reference_range_m);
      const double f = std::clamp((s - s_min) / (s_max - s_min) * (levels - 1), 0.0,
                                  static_cast<double>(levels - 1));
      const int i0 = std::min(static_cast<int>(f), levels - 2);
      const float w1 = static_cast<float>(f - i0), w0 = 1.0f - w1;
      const float* b0 = blurred[i0].ptr<float>(y) + x * channels;
      const float* b1 = blurred[i0 + 1].ptr<float>(y) + x * channels;
      for (int c = 0; c < channels; ++c) o[x * channels + c] = w0 * b0[c] + w1 * b1[c];
    }
  }
  return out;
}

}  // namespace turbid
