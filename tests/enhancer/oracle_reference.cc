// The oracles as they were before the optimisation of issue 18 (enhancer/oracle.cc at commit
// 6722196, the registry entries and the options' Check left out), compiled into the tests as
// the reference that today's oracle and oracle_exact must equal bit for bit (oracle_test.cc).
#include "tests/enhancer/oracle_reference.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <opencv2/imgproc.hpp>

#include "enhancer/blocks/deconvolution.h"
#include "enhancer/method.h"
#include "core/error.h"
#include "simulator/light.h"
#include "simulator/noise.h"
#include "simulator/psf.h"
#include "simulator/render.h"
#include "simulator/water.h"

namespace turbid::oracle_reference {
namespace {

// Element-wise max(m, v) and m + v on every channel (cv::Mat + double adds to channel 0 only).
cv::Mat MaxAll(const cv::Mat& m, double v) {
  cv::Mat out;
  cv::max(m, cv::Scalar::all(v), out);
  return out;
}
cv::Mat PlusAll(const cv::Mat& m, double v) { return m + cv::Scalar::all(v); }

cv::Scalar ToScalar(const std::vector<double>& values) {
  cv::Scalar s;
  for (size_t c = 0; c < values.size() && c < 4; ++c) s[static_cast<int>(c)] = values[c];
  return s;
}

// How the render blurred J: one kernel, or the range-dependent blend of ApplyDepthDependentPsf
// (levels at widths s_min .. s_max, linear weights in s = sqrt(r / reference), NaN range at the
// widest level), reproduced here so the inverse can blend the levels' inverses the same way.
struct BlurModel {
  bool active = false;
  bool depth_dependent = false;  // several levels blended per pixel (range- or turbidity-dependent)
  PsfOptions options;
  std::vector<Psf> levels;  // one kernel, or depth_levels kernels
  cv::Mat level;            // CV_32SC1: lower level index per pixel (depth-dependent)
  cv::Mat upper_weight;     // CV_32FC1: weight of level + 1
  // psf.turbidity_dependent: the render's per-pixel kernels, and each level's whole kernel.
  std::optional<TurbidityPsf> turbidity;
  std::vector<cv::Mat> turbidity_kernels;

  size_t Count() const { return turbidity ? turbidity_kernels.size() : levels.size(); }
  const cv::Mat& Kernel(size_t i) const {
    return turbidity ? turbidity_kernels[i] : levels[i].kernel;
  }
  cv::Mat Forward(const cv::Mat& x, const cv::Mat& range_m) const {
    if (!active) return x.clone();
    if (turbidity) return ApplyTurbidityPsf(*turbidity, x);
    return depth_dependent ? ApplyDepthDependentPsf(options, x, range_m) : ApplyPsf(levels[0], x);
  }
  // Blend of per-level inverses (exact for one kernel; a preconditioner otherwise).
  cv::Mat Inverse(const cv::Mat& b, double nsr) const {
    if (!active) return b.clone();
    if (Count() == 1) return DeconvolveReflect101(b, Kernel(0), nsr);
    std::vector<cv::Mat> inv;
    for (size_t i = 0; i < Count(); ++i) inv.push_back(DeconvolveReflect101(b, Kernel(i), nsr));
    return Blend(inv);
  }
  cv::Mat Blend(const std::vector<cv::Mat>& per_level) const {
    if (turbidity) return turbidity->BlendLevels(per_level);
    cv::Mat out(per_level[0].size(), per_level[0].type());
    const int ch = out.channels();
    for (int y = 0; y < out.rows; ++y) {
      const int* li = level.ptr<int>(y);
      const float* w = upper_weight.ptr<float>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < out.cols; ++x) {
        const float* a = per_level[li[x]].ptr<float>(y) + x * ch;
        const float* b = per_level[li[x] + 1].ptr<float>(y) + x * ch;
        for (int c = 0; c < ch; ++c) o[x * ch + c] = (1.0f - w[x]) * a[c] + w[x] * b[c];
      }
    }
    return out;
  }
};

BlurModel MakeBlurModel(const PsfOptions& options, const cv::Mat& range_m,
                        const std::vector<double>& beta) {
  BlurModel m;
  m.options = options;
  if (!options.enabled) return m;
  if (options.turbidity_dependent) {
    m.turbidity = PlanTurbidityPsf(options, ThicknessFromRange(range_m, beta));
    for (size_t k = 0; k < m.turbidity->thickness.size(); ++k)
      m.turbidity_kernels.push_back(m.turbidity->LevelKernel(static_cast<int>(k)));
    m.active = true;
    // The iterative inverse below also when the plan is exact: the levels differ per pixel.
    m.depth_dependent = m.turbidity_kernels.size() > 1 || !m.turbidity->exact;
    if (!m.depth_dependent && m.turbidity_kernels[0].total() == 1) m.active = false;
    return m;
  }
  const Psf base = PsfKernel(options);
  if (!options.depth_dependent) {
    m.active = !base.is_delta;
    m.levels = {base};
    return m;
  }
  m.active = true;
  double min_r = std::numeric_limits<double>::infinity(), max_r = 0.0;
  for (int y = 0; y < range_m.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    for (int x = 0; x < range_m.cols; ++x) {
      if (std::isnan(r[x])) continue;
      min_r = std::min<double>(min_r, r[x]);
      max_r = std::max<double>(max_r, r[x]);
    }
  }
  if (!(max_r > 0.0)) {
    m.levels = {base};
    return m;
  }
  const double s_min = std::sqrt(min_r / options.reference_range_m);
  const double s_max = std::sqrt(max_r / options.reference_range_m);
  if (s_max - s_min < 1e-9) {
    m.levels = {PsfKernel(options, s_min)};
    return m;
  }
  m.depth_dependent = true;
  const int levels = options.depth_levels;
  for (int i = 0; i < levels; ++i)
    m.levels.push_back(PsfKernel(options, s_min + (s_max - s_min) * i / (levels - 1)));
  m.level.create(range_m.size(), CV_32SC1);
  m.upper_weight.create(range_m.size(), CV_32FC1);
  for (int y = 0; y < range_m.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    for (int x = 0; x < range_m.cols; ++x) {
      const double s = std::isnan(r[x]) ? s_max : std::sqrt(r[x] / options.reference_range_m);
      const double f = std::clamp((s - s_min) / (s_max - s_min) * (levels - 1), 0.0,
                                  static_cast<double>(levels - 1));
      const int i0 = std::min(static_cast<int>(f), levels - 2);
      m.level.at<int>(y, x) = i0;
      m.upper_weight.at<float>(y, x) = static_cast<float>(f - i0);
    }
  }
  return m;
}

// Every true parameter of a render, as image-sized maps in the image's channel order.
struct Truth {
  RenderOptions render;
  int channels = 1;
  cv::Mat range_m;       // CV_32FC1, NaN where depth is invalid
  cv::Mat transmission;  // t per channel (1 where beta = 0 and depth is valid; 0 at NaN depth)
  cv::Mat irradiance;    // E_A + E_L per channel
  cv::Mat veil;          // (1 - t)(E_L + B_inf) per channel
  cv::Mat snow;          // marine snow layer (zeros when none or not removed)
  BlurModel blur;
  std::vector<std::string> steps;
};

Truth ResolveTruth(const std::string& method, const cv::Mat& image, const Scene& scene,
                   const RenderRecord& sidecar, bool remove_snow) {
  ValidateEnhanceImage(image, method);
  if (!sidecar.options) {
    throw Error(method + ": the sidecar has no \"options\" object (not a turbid render sidecar?)");
  }
  if (scene.image.size() != image.size() || scene.channels() != image.channels()) {
    throw Error(method + ": the scene (" + std::to_string(scene.width()) + "x" +
                std::to_string(scene.height()) + ", " + std::to_string(scene.channels()) +
                " channels) does not match the image (" + std::to_string(image.cols) + "x" +
                std::to_string(image.rows) + ", " + std::to_string(image.channels()) + ")");
  }
  Truth truth;
  truth.render = *sidecar.options;
  const RenderOptions& ro = truth.render;
  const WaterOptions water = ResolveWater(ro.water);
  const int ch = truth.channels = image.channels();
  const std::vector<double> beta = ChannelValues(water.beta_rgb_per_m, water.beta_gray_per_m, ch);
  const std::vector<double> ambient = ChannelValues(water.ambient_rgb, water.ambient_gray, ch);
  const bool zero_beta = std::all_of(beta.begin(), beta.end(), [](double b) { return b == 0; });
  truth.range_m = RangeFromDepth(scene.camera, scene.depth_m);

  cv::Mat e_l(image.size(), image.type(), cv::Scalar::all(0));
  if (!ro.light.lights.empty()) {
    const cv::Mat normals =
        scene.normals.empty() ? NormalsFromDepth(scene.camera, scene.depth_m) : scene.normals;
    e_l = IrradianceMap(ro.light, scene.camera, scene.depth_m, normals, beta);
  }
  truth.irradiance = e_l + ToScalar(ambient);
  if (zero_beta) {
    // The renderer's beta = 0 path: t = 1 where depth is valid, 0 (open water) where it is NaN.
    cv::Mat valid = truth.range_m == truth.range_m;  // 255 where not NaN
    cv::Mat t1;
    valid.convertTo(t1, CV_32F, 1.0 / 255.0);
    std::vector<cv::Mat> planes(ch, t1);
    cv::merge(planes, truth.transmission);
  } else {
    truth.transmission = TransmissionMap(truth.range_m, beta);
  }
  cv::Mat source = e_l.clone();
  if (water.backscatter) {
    source += ToScalar(ChannelValues(water.backscatter_rgb, water.backscatter_gray, ch));
    truth.steps.push_back("veil: (1 - t)(E_L + B_inf)");
  } else {
    truth.steps.push_back("veil: (1 - t) E_L");
  }
  const cv::Mat one(image.size(), image.type(), cv::Scalar::all(1));
  truth.veil = (one - truth.transmission).mul(source);
  truth.snow = cv::Mat(image.size(), image.type(), cv::Scalar::all(0));
  if (remove_snow && ro.snow.enabled && ro.snow.density_per_m3 > 0) {
    const MarineSnow snow =
        RenderMarineSnow(ro.snow, ro.light, scene.camera, truth.range_m, beta, ambient, ro.seed);
    truth.snow = snow.layer;
    truth.steps.push_back("snow: " + std::to_string(snow.visible) +
                          " particles re-rendered from the seed and subtracted");
  } else {
    truth.steps.push_back("snow: none subtracted");
  }
  truth.blur = MakeBlurModel(ro.psf, truth.range_m, beta);
  if (!truth.blur.active) {
    truth.steps.push_back("psf: none (disabled or a delta)");
  } else {
    truth.steps.push_back(std::string("psf: ") +
                          (truth.blur.turbidity
                               ? std::to_string(truth.blur.Count()) +
                                     " turbidity-dependent levels"
                           : truth.blur.depth_dependent
                               ? std::to_string(truth.blur.levels.size()) + " range-dependent levels"
                               : "one kernel, radius " +
                                     std::to_string(truth.blur.levels[0].radius_px) + " px"));
  }
  return truth;
}

// Per-pixel max / min over the channels (CV_32FC1).
cv::Mat ReduceChannels(const cv::Mat& m, int op) {
  if (m.channels() == 1) return m;
  cv::Mat out;
  cv::reduce(m.reshape(1, static_cast<int>(m.total())), out, 1, op);
  return out.reshape(1, m.rows);
}
cv::Mat MaxOverChannels(const cv::Mat& m) { return ReduceChannels(m, cv::REDUCE_MAX); }

// Pixels where any channel of t is below `floor` (NaN depth has t = 0): CV_8UC1, 255 = masked.
cv::Mat MaskBelow(const cv::Mat& t, double floor) {
  std::vector<cv::Mat> planes;
  cv::split(t, planes);
  cv::Mat mask = planes[0] < floor;
  for (size_t c = 1; c < planes.size(); ++c) mask |= planes[c] < floor;
  return mask;
}

cv::Mat BoxSum(const cv::Mat& m, int radius) {
  cv::Mat out;
  cv::boxFilter(m, out, -1, cv::Size(2 * radius + 1, 2 * radius + 1), cv::Point(-1, -1), false,
                cv::BORDER_REFLECT);
  return out;
}

// Local signal variance around the prior mean p of values z whose noise variances are 1 / a (a =
// 0: no data): max(sum a (z - p)^2 - sum [a > 0], 0) / sum a over a window of `radius` (0: the
// whole image). Unbiased for independent samples (E a (z - p)^2 = a S + 1).
cv::Mat LocalSignalVariance(const cv::Mat& z, const cv::Mat& a, const cv::Mat& p, int radius) {
  cv::Mat d = z - p;
  cv::Mat num = a.mul(d.mul(d));
  cv::Mat has;
  cv::threshold(a, has, 0.0, 1.0, cv::THRESH_BINARY);
  if (radius <= 0) {
    const cv::Scalar sa = cv::sum(a), sn = cv::sum(num), sh = cv::sum(has);
    cv::Scalar s;
    for (int c = 0; c < z.channels(); ++c)
      s[c] = sa[c] > 0 ? std::max(sn[c] - sh[c], 0.0) / sa[c] : 0.0;
    return cv::Mat(z.size(), z.type(), s);
  }
  cv::Mat sa = BoxSum(a, radius);
  cv::Mat v = BoxSum(num, radius) - BoxSum(has, radius);
  v = MaxAll(v, 0.0);
  cv::Mat out;
  cv::divide(v, MaxAll(sa, 1e-30), out);
  return out;
}

// The linear MMSE estimate of rho from u = rho + noise of variance v (a = 1 / v, 0 where
// masked), under a hierarchical local Gaussian prior (docs/methods.md, "oracle"). Writes the
// prior mean of the finest level to *prior and the posterior variance to *posterior.
cv::Mat HierarchicalMmse(const OracleOptions& o, const cv::Mat& u, const cv::Mat& a, cv::Mat* prior,
                         cv::Mat* posterior) {
  const int ch = u.channels();
  cv::Mat au = a.mul(u);
  // Level 0: the inverse-variance-weighted global mean (0.5 where a channel has no data).
  const cv::Scalar sa = cv::sum(a), sau = cv::sum(au);
  cv::Scalar m0;
  for (int c = 0; c < ch; ++c) m0[c] = sa[c] > 0 ? sau[c] / sa[c] : 0.5;
  cv::Mat p(u.size(), u.type(), m0);
  int prev_radius = 0;  // 0: global
  for (const int radius : {o.coarse_radius, o.middle_radius}) {
    const cv::Mat w = BoxSum(a, radius);
    cv::Mat m;
    cv::divide(BoxSum(au, radius), MaxAll(w, 1e-30), m);  // BLUE of the local mean; noise 1 / w
    const cv::Mat s = LocalSignalVariance(m, w, p, prev_radius);
    // p += S / (S + 1/w) (m - p) = S w / (S w + 1) (m - p); w = 0 keeps p.
    cv::Mat sw = s.mul(w);
    cv::Mat gain;
    cv::divide(sw, PlusAll(sw, 1.0), gain);
    p += gain.mul(m - p);
    prev_radius = radius;
  }
  const cv::Mat s = LocalSignalVariance(u, a, p, o.pixel_radius);
  cv::Mat sa_px = s.mul(a);
  cv::Mat gain;
  cv::divide(sa_px, PlusAll(sa_px, 1.0), gain);  // S / (S + v); 0 where masked (a = 0)
  *prior = p;
  // Posterior variance S v / (S + v) = S / (S a + 1); S where masked.
  cv::divide(s, PlusAll(sa_px, 1.0), *posterior);
  return p + gain.mul(u - p);
}

}  // namespace

// The data term and MMSE alone, on given truth maps (oracle_test.cc's reference for
// oracle_internal::OracleMmse): the same operations as OracleEnhance below.
oracle_internal::OracleMmseResult OracleMmse(const OracleOptions& o, const cv::Mat& image,
                                             const cv::Mat& transmission, const cv::Mat& irradiance,
                                             const cv::Mat& snow, const cv::Mat& veil, double gain,
                                             double floor_var, double clip_level) {
  oracle_internal::OracleMmseResult r;
  cv::Mat local_mean;
  cv::boxFilter(image, local_mean, -1, cv::Size(7, 7), cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  cv::Mat variance = PlusAll(MaxAll(local_mean, 0.0) * gain, floor_var);
  r.masked = MaskBelow(transmission, o.mask_transmission);
  r.masked_pixels = cv::countNonZero(r.masked);
  cv::Mat scale = transmission.mul(irradiance);
  scale = MaxAll(scale, 1e-12);
  cv::Mat u = (image - snow - veil) / scale;
  cv::Mat a;
  cv::divide(scale.mul(scale), variance, a);
  a.setTo(cv::Scalar::all(0), r.masked);
  u.setTo(cv::Scalar::all(0), r.masked);
  cv::Mat high;
  cv::threshold(image, high, clip_level, 1.0, cv::THRESH_BINARY);
  cv::Mat clipped = high;
  r.censored_pixels = cv::countNonZero(MaxOverChannels(clipped) > 0);
  cv::Mat sigma;
  cv::sqrt(variance, sigma);
  const cv::Mat bound = (image - 2.0 * sigma - snow - veil) / scale;
  a = a.mul(cv::Scalar::all(1.0) - clipped);
  cv::Mat est = HierarchicalMmse(o, u, a, &r.prior, &r.posterior);
  if (r.censored_pixels > 0) {
    cv::Mat raised;
    cv::max(est, bound, raised);
    est += (raised - est).mul(high);
    cv::max(r.prior, bound, raised);
    r.prior += (raised - r.prior).mul(high);
  }
  r.estimate = est;
  return r;
}

cv::Mat DeconvolveReflect101(const cv::Mat& image, const cv::Mat& kernel, double nsr) {
  CV_Assert(image.depth() == CV_32F && kernel.type() == CV_32FC1 && kernel.rows == kernel.cols &&
            kernel.rows % 2 == 1);
  if (kernel.total() == 1) return image.clone();
  const int rows = image.rows, cols = image.cols;
  const int pr = std::max(2 * rows - 2, 1), pc = std::max(2 * cols - 2, 1);
  // The kernel's DFT on the period grid (centre at the origin, wrapped); real for a symmetric
  // kernel.
  const int r = kernel.rows / 2;
  cv::Mat k(pr, pc, CV_64F, cv::Scalar(0));
  for (int j = -r; j <= r; ++j)
    for (int i = -r; i <= r; ++i)
      k.at<double>(((j % pr) + pr) % pr, ((i % pc) + pc) % pc) += kernel.at<float>(j + r, i + r);
  cv::Mat kf;
  cv::dft(k, kf, cv::DFT_COMPLEX_OUTPUT);
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (cv::Mat& plane : planes) {
    cv::Mat d, e;
    plane.convertTo(d, CV_64F);
    cv::copyMakeBorder(d, e, 0, pr - rows, 0, pc - cols, cv::BORDER_REFLECT_101);
    cv::Mat ef;
    cv::dft(e, ef, cv::DFT_COMPLEX_OUTPUT);
    for (int y = 0; y < pr; ++y) {
      cv::Vec2d* f = ef.ptr<cv::Vec2d>(y);
      const cv::Vec2d* kv = kf.ptr<cv::Vec2d>(y);
      for (int x = 0; x < pc; ++x) {
        const double kr = kv[x][0];
        const double g = kr / (kr * kr + nsr);
        f[x] *= g;
      }
    }
    cv::Mat back;
    cv::dft(ef, back, cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
    back(cv::Rect(0, 0, cols, rows)).convertTo(plane, CV_32F);
  }
  cv::Mat out;
  cv::merge(planes, out);
  return out;
}

OracleResult OracleExactEnhance(const OracleExactOptions& o, const cv::Mat& image,
                                const Scene& scene, const RenderRecord& sidecar) {
  ThrowIfInvalid(o, "oracle_exact");
  Truth truth = ResolveTruth("oracle_exact", image, scene, sidecar, o.remove_snow);
  OracleResult result;
  result.steps = truth.steps;
  const cv::Mat masked = MaskBelow(truth.transmission, o.min_transmission);
  result.masked_pixels = cv::countNonZero(masked);
  // b = J * h where t >= the floor.
  cv::Mat b = (image - truth.snow - truth.veil) / MaxAll(truth.transmission, o.min_transmission);
  if (result.masked_pixels > 0) {
    // No data there: the mean of the rest, so the deblurring does not spread a huge value.
    b.setTo(cv::mean(b, ~masked), masked);
    result.steps.push_back("masked: " + std::to_string(result.masked_pixels) +
                           " pixels with t < " + std::to_string(o.min_transmission));
  }
  cv::Mat lit = b;
  const BlurModel& blur = truth.blur;
  if (blur.active) {
    constexpr double kNsr = 1e-12;  // regularises only numerically zero frequencies
    lit = blur.Inverse(b, kNsr);
    if (blur.depth_dependent) {
      // x += P (b - A x): P blends the levels' exact inverses as A blends the levels' blurs.
      for (result.iterations = 1; result.iterations <= o.max_iterations; ++result.iterations) {
        const cv::Mat residual = b - blur.Forward(lit, truth.range_m);
        double lo = 0, hi = 0;
        cv::minMaxLoc(residual.reshape(1), &lo, &hi);
        result.residual = std::max(-lo, hi);
        if (result.residual <= o.tolerance) break;
        lit += blur.Inverse(residual, kNsr);
      }
      result.iterations = std::min(result.iterations, o.max_iterations);
      result.steps.push_back("deblur: range-dependent PSF, " + std::to_string(result.iterations) +
                             " fixed-point iterations, residual " +
                             std::to_string(result.residual));
    } else {
      result.steps.push_back("deblur: exact reflect-101 inverse of the PSF");
    }
  }
  cv::Mat out = o.target == "lit" ? lit.clone()
                                  : lit / MaxAll(truth.irradiance, o.min_irradiance);
  cv::patchNaNs(out, 0.0);
  cv::min(out, 1.0, out);
  cv::max(out, 0.0, out);
  result.image = out;
  return result;
}

OracleResult OracleEnhance(const OracleOptions& o, const cv::Mat& image, const Scene& scene,
                           const RenderRecord& sidecar) {
  ThrowIfInvalid(o, "oracle");
  Truth truth = ResolveTruth("oracle", image, scene, sidecar, o.remove_snow);
  OracleResult result;
  result.steps = truth.steps;
  const RenderOptions& ro = truth.render;
  // Noise variance of I per pixel (Foi et al. 2008): signal / photons + read^2, plus the
  // quantisation step's 1/12 step^2.
  const bool sensor = ro.sensor.enabled;
  const double read2 = sensor ? ro.sensor.read_noise * ro.sensor.read_noise : 0.0;
  const double gain = sensor && ro.sensor.photons_at_white > 0 ? 1.0 / ro.sensor.photons_at_white
                                                              : 0.0;
  const int bits = ro.camera.bit_depth;
  const double step = bits == 32 ? 0.0 : 1.0 / ((1 << bits) - 1);
  const double floor_var = read2 + 1e-12;
  // The signal in the shot-noise term is the local mean of I (7x7 box) rather than I itself: a
  // variance read from the noisy value weights the darker draws more and biases every weighted
  // mean low.
  cv::Mat local_mean;
  cv::boxFilter(image, local_mean, -1, cv::Size(7, 7), cv::Point(-1, -1), true,
                cv::BORDER_REFLECT);
  cv::Mat variance = PlusAll(MaxAll(local_mean, 0.0) * gain, floor_var);
  // The quantisation noise in the coded domain (oracle_internal::CodedQuantisation, tested
  // against the decoding curve in oracle_quantisation_test.cc).
  oracle_internal::CodedQuantisation quantisation;
  quantisation.step_var = static_cast<float>(step * step / 12.0);
  quantisation.srgb = bits != 32 && ro.camera.encoding == CameraEncoding::kSrgb;
  if (step > 0.0)
    for (int y = 0; y < variance.rows; ++y)
      for (int i = 0; i < variance.cols * variance.channels(); ++i)
        variance.ptr<float>(y)[i] += quantisation.Variance(local_mean.ptr<float>(y)[i]);
  result.steps.push_back("noise: variance I / " + std::to_string(ro.sensor.photons_at_white) +
                         " + read^2 + (step s)^2 / 12, s the " +
                         (quantisation.srgb ? "sRGB" : "linear") + " decoding slope" +
                         (sensor ? "" : " (sensor off)"));

  // u = (I - S - veil) / (t (E_A + E_L)) ~ h * rho, with variance v = var / (t E)^2.
  const cv::Mat masked = MaskBelow(truth.transmission, o.mask_transmission);
  result.masked_pixels = cv::countNonZero(masked);
  cv::Mat scale = truth.transmission.mul(truth.irradiance);
  scale = MaxAll(scale, 1e-12);
  cv::Mat u = (image - truth.snow - truth.veil) / scale;
  cv::Mat a;  // 1 / v, 0 where masked
  cv::divide(scale.mul(scale), variance, a);
  a.setTo(cv::Scalar::all(0), masked);
  u.setTo(cv::Scalar::all(0), masked);
  // Clipped samples (I at 0 or 1 in a channel) are not Gaussian data: they get no weight. A
  // sample clipped at 1 still bounds rho from below, (1 - 2 sigma - S - veil) / (t E): the
  // estimate is raised onto that bound where it falls short (docs/methods.md).
  const double half_step = bits == 32 ? 0.0 : 0.5 * step;
  cv::Mat high, low;  // CV_32FC(ch): 1 where clipped
  cv::threshold(image, high, 1.0 - half_step - 1e-7, 1.0, cv::THRESH_BINARY);
  cv::threshold(image, low, half_step + 1e-7, 1.0, cv::THRESH_BINARY_INV);
  cv::Mat clipped = high;
  const int censored = cv::countNonZero(MaxOverChannels(clipped) > 0);
  cv::Mat sigma;
  cv::sqrt(variance, sigma);
  const cv::Mat bound = (image - 2.0 * sigma - truth.snow - truth.veil) / scale;
  a = a.mul(cv::Scalar::all(1.0) - clipped);
  cv::Mat prior, posterior;
  cv::Mat est = HierarchicalMmse(o, u, a, &prior, &posterior);
  if (censored > 0) {
    cv::Mat raised;
    cv::max(est, bound, raised);
    est += (raised - est).mul(high);
    cv::max(prior, bound, raised);
    prior += (raised - prior).mul(high);
    result.steps.push_back("censored: " + std::to_string(censored) +
                           " pixels clipped at 0 or 1 in some channel: no weight");
  }
  result.steps.push_back("mmse: hierarchical local Gaussian prior, windows " +
                         std::to_string(o.coarse_radius) + " / " + std::to_string(o.middle_radius) +
                         " / " + std::to_string(o.pixel_radius) + " px");
  if (result.masked_pixels > 0) {
    result.steps.push_back("masked: " + std::to_string(result.masked_pixels) +
                           " pixels with t < " + std::to_string(o.mask_transmission) +
                           ", set to the prior mean");
  }
  const BlurModel& blur = truth.blur;
  if (blur.active && o.deblur) {
    // Wiener on the deviation from the prior mean (the signal's mean; smooth, so h * P = P to
    // the blur's width): K = (noise left after the MMSE) / (variance of the deviation), both over
    // the data pixels — the MMSE filter for a white deviation of that variance (Gonzalez & Woods
    // §5.8). A constant-K Wiener on est itself would scale its mean by 1 / (1 + K).
    const cv::Mat data = ~masked;
    const cv::Mat detail = est - prior;
    double noise = 0, signal = 0;
    const cv::Scalar pm = cv::mean(posterior, data);
    cv::Scalar mean, dev;
    cv::meanStdDev(detail, mean, dev, data);
    for (int c = 0; c < truth.channels; ++c) noise += pm[c], signal += dev[c] * dev[c];
    result.deblur_nsr = std::clamp(signal > 0 ? noise / signal : 10.0, 1e-8, 10.0);
    DeconvolutionOptions d;
    d.nsr = result.deblur_nsr;
    std::vector<cv::Mat> per_level;
    for (size_t i = 0; i < blur.Count(); ++i)
      per_level.push_back(Deconvolve(d, detail, blur.Kernel(i)));
    est = prior + (blur.depth_dependent ? blur.Blend(per_level) : per_level[0]);
    prior.copyTo(est, masked);
    result.steps.push_back("deblur: Wiener, NSR " + std::to_string(result.deblur_nsr));
  }
  cv::Mat out = o.target == "lit" ? est.mul(truth.irradiance) : est;
  cv::patchNaNs(out, 0.0);
  cv::min(out, 1.0, out);
  cv::max(out, 0.0, out);
  result.image = out;
  return result;
}

}  // namespace turbid::oracle_reference
