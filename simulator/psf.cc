#include "simulator/psf.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/fast_math.h"

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

std::string PsfModelName(PsfModel model) {
  return model == PsfModel::kSmallAngle ? "small_angle" : "paper";
}

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
  if (thickness_levels < 2 || thickness_levels > 64)
    return fail("thickness_levels: must be in [2, 64]");
  if (glow_levels < 2 || glow_levels > 64) return fail("glow_levels: must be in [2, 64]");
  if (model == PsfModel::kSmallAngle && (turbidity_dependent || depth_dependent))
    return fail(
        "model small_angle sets the blur from the water's scattering; turbidity_dependent and "
        "depth_dependent are eq. 7's range models (use them with model paper)");
  if (turbidity_dependent && depth_dependent)
    return fail(
        "turbidity_dependent and depth_dependent are two range models of the blur; enable one");
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

namespace {

constexpr double kMinThickness = 1e-4, kMaxThickness = 100.0;

// g_T: eq. 7's kernel at T, its tail judged by the share (1 - e^{-T}) it carries; a glow whose
// spread share (1 - e^{-T}) (1 - centre) is below delta_tolerance is the identity.
Psf GlowKernel(const PsfOptions& options, double thickness) {
  PsfOptions o = options;
  o.turbidity_dependent = o.depth_dependent = false;
  o.optical_thickness = thickness;
  const double scattered = -std::expm1(-thickness);
  o.tail_mass = std::min(0.1, options.tail_mass / scattered);
  Psf g = PsfKernel(o);
  if (!g.is_delta && g.radius_px > 0) {
    // The tail criterion is the mass outside the disc of radius R: the kernel is that disc (the
    // square's corners carry less than tail_mass), renormalised.
    const int r = g.radius_px;
    for (int j = -r; j <= r; ++j)
      for (int i = -r; i <= r; ++i)
        if (i * i + j * j > r * r) g.kernel.at<float>(j + r, i + r) = 0.0f;
    g.kernel /= cv::sum(g.kernel)[0];
    g.kernel_1d = cv::Mat();
    g.separable = false;
  }
  if (!g.is_delta) {
    const double centre = g.kernel.at<float>(g.radius_px, g.radius_px);
    if (scattered * (1.0 - centre) < options.delta_tolerance) {
      g.kernel = cv::Mat::ones(1, 1, CV_32F);
      g.kernel_1d = g.separable ? g.kernel.clone() : cv::Mat();
      g.radius_px = 0;
      g.is_delta = true;
    }
  }
  return g;
}

// The smallest and largest non-NaN value (inf / -inf when there is none); 8 lanes so that the
// comparisons vectorise.
TURBID_ROW_KERNEL void MinMaxNotNaN(const float* t, size_t n, float* lo_out, float* hi_out) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  float lo[8], hi[8];
  for (int l = 0; l < 8; ++l) lo[l] = kInf, hi[l] = -kInf;
  size_t i = 0;
  for (; i + 8 <= n; i += 8)
    for (int l = 0; l < 8; ++l) {
      const float v = t[i + l];
      lo[l] = v < lo[l] ? v : lo[l];  // false for NaN: keeps the lane
      hi[l] = v > hi[l] ? v : hi[l];
    }
  for (; i < n; ++i) {
    lo[0] = t[i] < lo[0] ? t[i] : lo[0];
    hi[0] = t[i] > hi[0] ? t[i] : hi[0];
  }
  *lo_out = kInf, *hi_out = -kInf;
  for (int l = 0; l < 8; ++l) *lo_out = std::min(*lo_out, lo[l]), *hi_out = std::max(*hi_out, hi[l]);
}

// V(x) = up(x) + down(x).
TURBID_ROW_KERNEL void AddRows(const float* up, const float* down, int n, float* out) {
  for (int x = 0; x < n; ++x) out[x] = up[x] + down[x];
}

// For each run [x0, x1) of pixels at level k (runs: x0, x1, k triplets):
// o(x) += (s(x) g_k + sw(x) dg_k) S(x), g_k = table[k * stride], dg_k = step[k * stride], and S the
// sum of J over the offsets of class (a, b) (V_b: vertical pair sums at distance b; see
// ApplyTurbidityPsf).
TURBID_ROW_KERNEL void AccumulateClass(int a, int b, const float* v0, const float* va,
                                       const float* vb, const float* s, const float* sw,
                                       const float* table, const float* step, size_t stride,
                                       const int* runs, int n_runs, float* o) {
  for (int r = 0; r < n_runs; ++r) {
    const int x0 = runs[3 * r], x1 = runs[3 * r + 1];
    const float g = table[runs[3 * r + 2] * stride], dg = step[runs[3 * r + 2] * stride];
    if (g == 0.0f && dg == 0.0f) continue;
    if (a == 0) {
      for (int x = x0; x < x1; ++x) o[x] += (s[x] * g + sw[x] * dg) * v0[x];
    } else if (b == 0) {
      for (int x = x0; x < x1; ++x)
        o[x] += (s[x] * g + sw[x] * dg) * ((v0[x + a] + v0[x - a]) + va[x]);
    } else if (a == b) {
      for (int x = x0; x < x1; ++x) o[x] += (s[x] * g + sw[x] * dg) * (va[x + a] + va[x - a]);
    } else {
      for (int x = x0; x < x1; ++x)
        o[x] += (s[x] * g + sw[x] * dg) * ((vb[x + a] + vb[x - a]) + (va[x + b] + va[x - b]));
    }
  }
}

// s = 1 - e^{-T}, sw = s w, and the unscattered part of the output, e^{-T} J.
TURBID_ROW_KERNEL void StartRow(const float* direct, const float* weight, const float* j, int n,
                                float* s, float* sw, float* o) {
  for (int x = 0; x < n; ++x) {
    s[x] = 1.0f - direct[x];
    sw[x] = s[x] * weight[x];
    o[x] = direct[x] * j[x];
  }
}

// TurbidityPsf::Coefficients' loops.
TURBID_ROW_KERNEL void ExactCoefficients(const float* t, int count, const float* level, int levels,
                                         float nan_value, int* lower, float* weight,
                                         float* direct) {
  constexpr float kLo = static_cast<float>(kMinThickness), kHi = static_cast<float>(kMaxThickness);
  for (int i = 0; i < count; ++i) {
    const float v = t[i] == t[i] ? std::clamp(t[i], kLo, kHi) : nan_value;
    direct[i] = internal::ExpNonPositive(-v);
    int k = 0;
    for (int l = 1; l < levels; ++l) k += v >= level[l] ? 1 : 0;
    lower[i] = k;
    weight[i] = 0.0f;
  }
}

TURBID_ROW_KERNEL void SpacedCoefficients(const float* t, int count, float p_lo, float p_scale,
                                          int levels, float nan_value, int* lower, float* weight,
                                          float* direct) {
  constexpr float kLo = static_cast<float>(kMinThickness), kHi = static_cast<float>(kMaxThickness);
  const float top = static_cast<float>(levels - 1);
  for (int i = 0; i < count; ++i) {
    const float v = t[i] == t[i] ? std::clamp(t[i], kLo, kHi) : nan_value;
    direct[i] = internal::ExpNonPositive(-v);
    const float f = std::clamp((std::sqrt(v) - p_lo) * p_scale, 0.0f, top);
    const int i0 = std::min(static_cast<int>(f), levels - 2);
    lower[i] = i0;
    weight[i] = f - static_cast<float>(i0);
  }
}

}  // namespace

cv::Mat ThicknessFromRange(const cv::Mat& range_m, const std::vector<double>& beta_per_m) {
  CV_Assert(range_m.type() == CV_32FC1 && !beta_per_m.empty());
  const int ch = static_cast<int>(beta_per_m.size());
  cv::Mat out(range_m.size(), CV_32FC(ch));
  for (int y = 0; y < range_m.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < range_m.cols; ++x)
      for (int c = 0; c < ch; ++c) o[x * ch + c] = static_cast<float>(beta_per_m[c] * r[x]);
  }
  return out;
}

TurbidityPsf PlanTurbidityPsf(const PsfOptions& options, const cv::Mat& thickness) {
  ThrowIfInvalid(options, "psf");
  CV_Assert(thickness.depth() == CV_32F);
  const int ch = thickness.channels();
  const cv::Mat flat = thickness.isContinuous() ? thickness : thickness.clone();
  const float* t = flat.ptr<float>(0);
  const size_t values = flat.total() * static_cast<size_t>(ch);
  constexpr float kLo = static_cast<float>(kMinThickness), kHi = static_cast<float>(kMaxThickness);
  // The clamped range (NaN skipped: comparisons with NaN are false).
  float lo = 0.0f, hi = 0.0f;
  MinMaxNotNaN(t, values, &lo, &hi);
  TurbidityPsf plan;
  if (!(hi >= lo)) {  // no valid range at all: one level at the configured thickness
    lo = hi = static_cast<float>(std::clamp(options.optical_thickness, kMinThickness,
                                            kMaxThickness));
  }
  lo = std::clamp(lo, kLo, kHi);
  hi = std::clamp(hi, kLo, kHi);
  // The distinct clamped values while there are at most thickness_levels of them.
  std::vector<float> distinct;
  bool few = true;
  for (size_t i = 0; i < values && few; ++i) {
    if (std::isnan(t[i])) continue;
    const float v = std::clamp(t[i], kLo, kHi);
    if (std::find(distinct.begin(), distinct.end(), v) == distinct.end()) {
      distinct.push_back(v);
      few = static_cast<int>(distinct.size()) <= options.thickness_levels;
    }
  }
  if (distinct.empty()) distinct.push_back(hi);
  plan.exact = few;
  const int k_levels = few ? static_cast<int>(distinct.size()) : options.thickness_levels;
  if (few) {
    std::sort(distinct.begin(), distinct.end());
    for (float v : distinct) plan.thickness.push_back(v);
  } else {
    const double p_lo = std::sqrt(static_cast<double>(lo)), p_hi = std::sqrt(static_cast<double>(hi));
    for (int i = 0; i < k_levels; ++i) {
      const double p = p_lo + (p_hi - p_lo) * i / (k_levels - 1);
      plan.thickness.push_back(i == 0 ? lo : (i == k_levels - 1 ? hi : p * p));
    }
  }
  for (double v : plan.thickness) plan.glow.push_back(GlowKernel(options, v));
  plan.map = thickness;
  if (!few) {
    plan.p_lo = std::sqrt(lo);
    plan.p_scale = static_cast<float>(k_levels - 1) / (std::sqrt(hi) - plan.p_lo);
  }
  return plan;
}

void TurbidityPsf::Coefficients(const float* t, int count, int* lower, float* weight,
                                float* direct) const {
  const int levels = static_cast<int>(thickness.size());
  const float nan_value = static_cast<float>(thickness.back());  // NaN (open water): largest T
  if (exact) {
    float level[64];
    for (int l = 0; l < levels; ++l) level[l] = static_cast<float>(thickness[l]);
    ExactCoefficients(t, count, level, levels, nan_value, lower, weight, direct);
  } else {
    SpacedCoefficients(t, count, p_lo, p_scale, levels, nan_value, lower, weight, direct);
  }
}

cv::Mat TurbidityPsf::LevelKernel(int k) const {
  const Psf& g = glow.at(static_cast<size_t>(k));
  const double scattered = -std::expm1(-thickness[static_cast<size_t>(k)]);
  cv::Mat h = g.kernel * scattered;
  h.at<float>(g.radius_px, g.radius_px) += static_cast<float>(1.0 - scattered);
  return h;
}

cv::Mat TurbidityPsf::BlendLevels(const std::vector<cv::Mat>& per_level) const {
  CV_Assert(per_level.size() == thickness.size());
  const int ch = map.channels(), n = map.cols * ch;
  cv::Mat out(map.size(), CV_32FC(ch));
  const int last = static_cast<int>(per_level.size()) - 1;
  std::vector<int> li(static_cast<size_t>(n));
  std::vector<float> w(static_cast<size_t>(n)), d(static_cast<size_t>(n));
  for (int y = 0; y < out.rows; ++y) {
    Coefficients(map.ptr<float>(y), n, li.data(), w.data(), d.data());
    float* o = out.ptr<float>(y);
    for (int i = 0; i < n; ++i) {
      const float a = per_level[li[i]].ptr<float>(y)[i];
      const float b = li[i] < last ? per_level[li[i] + 1].ptr<float>(y)[i] : a;
      o[i] = (1.0f - w[i]) * a + w[i] * b;
    }
  }
  return out;
}

namespace {

// Every g_k is radially symmetric and zero outside its disc, so its weight at offset (dx, dy)
// depends only on the class (a, b) = (max(|dx|, |dy|), min(|dx|, |dy|)) with a^2 + b^2 <= R^2.
// table[k * classes + j] = g_k at class j, step = g_{k+1} - g_k.
struct ClassTables {
  struct Class {
    int a, b;
  };
  int radius = 0;
  std::vector<Class> classes;
  std::vector<float> table, step;
};

ClassTables MakeClassTables(const TurbidityPsf& plan) {
  ClassTables t;
  const int levels = static_cast<int>(plan.glow.size());
  for (const Psf& g : plan.glow) t.radius = std::max(t.radius, g.is_delta ? 0 : g.radius_px);
  for (int a = 0; a <= t.radius; ++a)
    for (int b = 0; b <= a; ++b)
      if (a * a + b * b <= t.radius * t.radius) t.classes.push_back({a, b});
  const size_t n_classes = t.classes.size();
  t.table.assign(static_cast<size_t>(levels) * n_classes, 0.0f);
  t.step.assign(t.table.size(), 0.0f);
  for (int k = 0; k < levels; ++k) {
    const Psf& g = plan.glow[static_cast<size_t>(k)];
    const int r = g.is_delta ? 0 : g.radius_px;
    for (size_t j = 0; j < n_classes; ++j) {
      const int a = t.classes[j].a, b = t.classes[j].b;
      if (a > r) continue;
      t.table[k * n_classes + j] = g.is_delta ? 1.0f : g.kernel.at<float>(r + b, r + a);
    }
  }
  for (int k = 0; k + 1 < levels; ++k)
    for (size_t j = 0; j < n_classes; ++j)
      t.step[k * n_classes + j] = t.table[(k + 1) * n_classes + j] - t.table[k * n_classes + j];
  return t;
}

// Per channel, a ring of the 2R + 1 source rows around the current row, mirrored by R columns
// each side (BORDER_REFLECT_101).
struct MirroredRing {
  const cv::Mat& image;
  int radius, ch, width, height, wide, ring;
  size_t plane;
  std::vector<float> source;

  MirroredRing(const cv::Mat& image_in, int radius_in)
      : image(image_in),
        radius(radius_in),
        ch(image_in.channels()),
        width(image_in.cols),
        height(image_in.rows),
        wide(image_in.cols + 2 * radius_in),
        ring(2 * radius_in + 1),
        plane(static_cast<size_t>(ring) * wide),
        source(plane * ch) {}

  float* Slot(int c, int yy) {
    return source.data() + c * plane + static_cast<size_t>((yy + ring * height) % ring) * wide;
  }
  void Load(int yy) {
    const float* src = image.ptr<float>(cv::borderInterpolate(yy, height, cv::BORDER_REFLECT_101));
    for (int c = 0; c < ch; ++c) {
      float* dst = Slot(c, yy);
      for (int x = 0; x < width; ++x) dst[radius + x] = src[x * ch + c];
      for (int i = 1; i <= radius; ++i) {
        dst[radius - i] = dst[radius + cv::borderInterpolate(-i, width, cv::BORDER_REFLECT_101)];
        dst[radius + width - 1 + i] =
            dst[radius + cv::borderInterpolate(width - 1 + i, width, cv::BORDER_REFLECT_101)];
      }
    }
  }
};

// Per-band scratch of the turbidity PSF.
struct TurbidityScratch {
  std::vector<float> v, s, sw, e, wc, tc, o;
  std::vector<int> k;
  std::vector<std::array<int, 3>> runs;  // [x0, x1), level
  TurbidityScratch(int radius, int wide, int width, int ch)
      : v(static_cast<size_t>(radius + 1) * wide),
        s(width),
        sw(width),
        e(width),
        wc(width),
        tc(static_cast<size_t>(width) * ch),
        o(static_cast<size_t>(width) * ch),
        k(width) {}
};

// One channel of output row y (into oc): e^{-T} J + s sum_classes ((1 - w) G_k + w G_{k+1}) S.
void TurbidityChannelRow(const TurbidityPsf& plan, const ClassTables& t, MirroredRing& ring, int c,
                         int y, TurbidityScratch& w, float* oc) {
  const int radius = t.radius, width = ring.width, wide = ring.wide;
  // V_b(x) = J(y + b, x) + J(y - b, x), V_0 = J(y, x), on the padded columns.
  const float* centre = ring.Slot(c, y);
  std::copy(centre, centre + wide, w.v.data());
  for (int b = 1; b <= radius; ++b)
    AddRows(ring.Slot(c, y - b), ring.Slot(c, y + b), wide,
            w.v.data() + static_cast<size_t>(b) * wide);
  plan.Coefficients(w.tc.data() + static_cast<size_t>(c) * width, width, w.k.data(), w.wc.data(),
                    w.e.data());
  StartRow(w.e.data(), w.wc.data(), centre + radius, width, w.s.data(), w.sw.data(), oc);
  w.runs.clear();
  int x0 = 0;
  for (int x = 1; x <= width; ++x) {
    if (x == width || w.k[x] != w.k[x0]) {
      w.runs.push_back({x0, x, w.k[x0]});
      x0 = x;
    }
  }
  const size_t n_classes = t.classes.size();
  for (size_t j = 0; j < n_classes; ++j) {
    const int a = t.classes[j].a, b = t.classes[j].b;
    const float* va = w.v.data() + static_cast<size_t>(a) * wide + radius;
    const float* vb = w.v.data() + static_cast<size_t>(b) * wide + radius;
    AccumulateClass(a, b, w.v.data() + radius, va, vb, w.s.data(), w.sw.data(), t.table.data() + j,
                    t.step.data() + j, n_classes, w.runs.data()->data(),
                    static_cast<int>(w.runs.size()), oc);
  }
}

}  // namespace

cv::Mat ApplyTurbidityPsf(const TurbidityPsf& plan, const cv::Mat& image) {
  CV_Assert(image.depth() == CV_32F && image.size() == plan.map.size() &&
            image.channels() == plan.map.channels() && plan.map.depth() == CV_32F);
  const int ch = image.channels(), width = image.cols;
  // Per pixel the whole kernel is e^{-T} delta + s ((1 - w) g_k + w g_{k+1}), s = 1 - e^{-T}, so
  //   out = e^{-T} J + s sum_classes ((1 - w) G_k + w G_{k+1}) S_class,
  // S_class the sum of J over the class's offsets: the sums do not depend on the level, and within
  // a run of pixels that share k the weights are two numbers per class (vectorised over the run).
  const ClassTables tables = MakeClassTables(plan);
  const int radius = tables.radius;
  cv::Mat out(image.size(), image.type());
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& rows) {
    MirroredRing ring(image, radius);
    TurbidityScratch w(radius, ring.wide, width, ch);
    for (int yy = rows.start - radius; yy < rows.start + radius; ++yy) ring.Load(yy);
    for (int y = rows.start; y < rows.end; ++y) {
      ring.Load(y + radius);
      const float* tr = plan.map.ptr<float>(y);
      for (int c = 0; c < ch; ++c)
        for (int x = 0; x < width; ++x) w.tc[static_cast<size_t>(c) * width + x] = tr[x * ch + c];
      for (int c = 0; c < ch; ++c)
        TurbidityChannelRow(plan, tables, ring, c, y, w,
                            w.o.data() + static_cast<size_t>(c) * width);
      float* dst = out.ptr<float>(y);
      for (int c = 0; c < ch; ++c)
        for (int x = 0; x < width; ++x) dst[x * ch + c] = w.o[static_cast<size_t>(c) * width + x];
    }
  });
  return out;
}

}  // namespace turbid
