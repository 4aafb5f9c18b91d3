#include "enhancer/oracle/oracle.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "core/error.h"
#include "core/row_kernel.h"
#include "enhancer/blocks/deconvolution.h"
#include "enhancer/method.h"
#include "enhancer/oracle/oracle_internal.h"
#include "enhancer/params.h"
#include "simulator/image_pool.h"
#include "simulator/kernels.h"
#include "simulator/light.h"
#include "simulator/models.h"
#include "simulator/noise.h"
#include "simulator/psf.h"
#include "simulator/render.h"
#include "simulator/veil.h"
#include "simulator/water.h"

namespace turbid {
namespace {

bool Fail(std::string* why, const std::string& message) {
  *why = message;
  return false;
}

// Element-wise max(m, v) on every channel.
cv::Mat MaxAll(const cv::Mat& m, double v) {
  cv::Mat out;
  cv::max(m, cv::Scalar::all(v), out);
  return out;
}

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

using oracle_internal::MaskBelow;
using oracle_internal::NewLike;

// Row kernels of the passes below (TURBID_ROW_KERNEL: vectorised, an AVX2 clone; the same float
// operations in the same order as the loops they replaced, so the same values).
TURBID_ROW_KERNEL void VeilRow(const float* __restrict t, const float* __restrict src,
                               float* __restrict v, int n) {
  for (int i = 0; i < n; ++i) v[i] = (1.0f - t[i]) * src[i];
}

// out = a + v per channel (cv::add of an image and a scalar: the scalar in float).
TURBID_ROW_KERNEL void AddScalarRow1(const float* __restrict a, float v, float* __restrict out,
                                     int n) {
  for (int i = 0; i < n; ++i) out[i] = a[i] + v;
}

void AddPerChannelRow(const float* a, const float* v, int ch, float* out, int cols) {
  if (ch == 1) {
    AddScalarRow1(a, v[0], out, cols);
    return;
  }
  for (int x = 0; x < cols; ++x)
    for (int c = 0; c < ch; ++c) out[x * ch + c] = a[x * ch + c] + v[c];
}

// Every true parameter of a render: the range (and the blur model) as images, and the per-pixel
// maps t, E, veil and snow in the image's channel order, either as images (ResolveTruth's
// `planes`) or made a row at a time by Rows() where they are read (OracleEnhance's data-term
// stream: no full-size maps written and read back).
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

  // The row pass's inputs (Rows).
  const Scene* scene = nullptr;
  int width = 0;
  bool zero_beta = false, backscatter = false, draw_snow = false;
  std::vector<double> beta;
  float neg_beta[3] = {0, 0, 0}, ambient_f[3] = {0, 0, 0}, backscatter_f[3] = {0, 0, 0};
  cv::Mat normals;
  std::optional<internal::LightRowContext> context;
  std::vector<internal::LightRowConstants> lights;
  internal::SnowSplats splats;

  // Row y of E, t, the veil and the snow layer (width * channels values each) into e, t, veil and
  // snow: the lights' irradiance E_L (IrradianceMap's row kernels: each light's distance and
  // geometric factor, accumulated onto zeros), E = E_L + E_A, t (TransmissionMap's row kernel,
  // from the range; with beta = 0, t is read from the transmission image, not written), the veil
  // (1 - t)(E_L [+ B_inf]) and the snow layer's row drawn onto zeros (RenderMarineSnow's splats),
  // with the float operations of the whole-image functions and of cv::add with a scalar (the
  // scalar in float); E_L, the lights' geometry and E_L + B_inf exist only as rows.
  void Rows(int y, float* e, float* t, float* v, float* sn) const {
    const int w = width, ch = channels, n = w * ch;
    thread_local std::vector<float> rows;
    rows.resize(std::max<size_t>(rows.size(), static_cast<size_t>(2 * n + 7 * w)));
    float* e_l = rows.data();
    float* source = e_l + n;
    float* l_row = source + n;
    float* g_row = l_row + w;
    float* cos_scratch = g_row + w;
    std::fill(e_l, e_l + n, 0.0f);
    for (const internal::LightRowConstants& light : lights) {
      internal::LightGeometryRow(*context, light, context->RayY(scene->camera, y),
                                 scene->depth_m.ptr<float>(y), normals.ptr<cv::Vec3f>(y), w, l_row,
                                 g_row, cos_scratch);
      internal::AccumulateLightRow(l_row, g_row, w, ch, neg_beta, light.color, false, e_l);
    }
    AddPerChannelRow(e_l, ambient_f, ch, e, w);
    if (!zero_beta) TransmissionRows(range_m.ptr<float>(y), w, beta, t);
    const float* src = e_l;
    if (backscatter) {
      AddPerChannelRow(e_l, backscatter_f, ch, source, w);
      src = source;
    }
    VeilRow(t, src, v, n);
    std::fill(sn, sn + n, 0.0f);
    if (draw_snow) internal::AddSnowRow(splats, y, w, source, sn);
  }
};

void CheckTruthInputs(const std::string& method, const cv::Mat& image, const Scene& scene,
                      const RenderRecord& sidecar) {
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
}

// RangeFromDepth's values: a whole image at beta = 0, else its rows into a pooled image (the
// snow and the rows' transmission read it).
cv::Mat TruthRange(const Scene& scene, bool zero_beta) {
  CV_Assert(scene.depth_m.type() == CV_32FC1);
  if (zero_beta) return RangeFromDepth(scene.camera, scene.depth_m);
  const std::vector<double> range_dx = RangeColumnTable(scene.camera, scene.depth_m.cols);
  cv::Mat range_m = internal::PooledMat(scene.depth_m.size(), CV_32FC1);
  for (int y = 0; y < range_m.rows; ++y) {
    RangeFromDepthRow(scene.camera, range_dx, scene.depth_m.ptr<float>(y), y,
                      range_m.ptr<float>(y));
  }
  return range_m;
}

// The renderer's beta = 0 transmission: 1 where depth is valid, 0 (open water) where it is NaN.
cv::Mat ZeroBetaTransmission(const cv::Mat& range_m, int channels) {
  cv::Mat valid = range_m == range_m;  // 255 where not NaN
  cv::Mat t1, out;
  valid.convertTo(t1, CV_32F, 1.0 / 255.0);
  cv::merge(std::vector<cv::Mat>(channels, t1), out);
  return out;
}

std::string BlurStep(const BlurModel& blur) {
  if (!blur.active) return "psf: none (disabled or a delta)";
  return std::string("psf: ") +
         (blur.turbidity ? std::to_string(blur.Count()) + " turbidity-dependent levels"
          : blur.depth_dependent
              ? std::to_string(blur.levels.size()) + " range-dependent levels"
              : "one kernel, radius " + std::to_string(blur.levels[0].radius_px) + " px");
}

// Eq. 2 with eq. 2's veil: the row pass's inputs (lights, snow splats) of Truth::Rows.
void SetUpPaperRows(Truth& truth, const Scene& scene, const WaterOptions& water,
                    const std::vector<double>& ambient, bool remove_snow) {
  const RenderOptions& ro = truth.render;
  const int ch = truth.channels;
  cv::Scalar backscatter = cv::Scalar::all(0);
  truth.backscatter = water.backscatter;
  if (water.backscatter) {
    backscatter = ToScalar(ChannelValues(water.backscatter_rgb, water.backscatter_gray, ch));
    truth.steps.push_back("veil: (1 - t)(E_L + B_inf)");
  } else {
    truth.steps.push_back("veil: (1 - t) E_L");
  }
  if (!ro.light.lights.empty()) {
    ThrowIfInvalid(ro.light, "light");
    truth.normals =
        scene.normals.empty() ? NormalsFromDepth(scene.camera, scene.depth_m) : scene.normals;
    CV_Assert(scene.depth_m.type() == CV_32FC1 && truth.normals.type() == CV_32FC3 &&
              truth.normals.size() == scene.depth_m.size());
    truth.context = internal::LightContextFor(ro.light, scene.camera, truth.width);
    truth.lights = internal::LightConstantsFor(ro.light, ch);
  }
  for (int c = 0; c < ch; ++c) {
    truth.neg_beta[c] = -static_cast<float>(truth.beta[c]);
    truth.ambient_f[c] = static_cast<float>(ambient[c]);
    truth.backscatter_f[c] = static_cast<float>(backscatter[c]);
  }
  if (remove_snow && ro.snow.enabled && ro.snow.density_per_m3 > 0) {
    // RenderMarineSnow's layer (its particles drawn row by row onto zeros).
    truth.splats = internal::DrawMarineSnow(ro.snow, ro.light, scene.camera, truth.range_m,
                                            truth.beta, ambient, ro.seed);
    CV_Assert(truth.splats.channels == ch);
    truth.draw_snow = true;
    truth.steps.push_back("snow: " + std::to_string(truth.splats.visible) +
                          " particles re-rendered from the seed and subtracted");
  } else {
    truth.steps.push_back("snow: none subtracted");
  }
}

// Any other model, veil, ambient or snow ("revised", "uwcnn" linear, veil "single_scatter",
// ambient "derived", snow.mode "world"): the truth maps are
// the simulator's own, from one render of the scene with reflectance 1 everywhere, noise-free,
// unblurred and unquantised: its J is E (what multiplies the reflectance), its maps give t, the
// veil actually added and the snow layer (the noise map with the sensor off). Never re-derived.
void TruthPlanesFromRenderer(Truth& truth, const Scene& scene, bool remove_snow) {
  const RenderOptions& ro = truth.render;
  if (ro.model == ImageModel::kUwcnn && ro.uwcnn.domain == UwcnnDomain::kEncoded) {
    throw Error(
        "oracle: model uwcnn with domain \"encoded\" applies the recipe to sRGB codes, which is "
        "not a linear image model to invert (render with uwcnn.domain \"linear\")");
  }
  Scene white = scene;
  white.image = cv::Mat(scene.image.size(), scene.image.type(), cv::Scalar::all(1.0));
  RenderOptions o = ro;
  o.sensor.enabled = false;
  o.psf.enabled = false;
  o.snow.enabled = remove_snow && ro.snow.enabled;
  o.camera.bit_depth = 32;
  o.maps = MapSelection{};
  o.maps.transmission = o.maps.veil = o.maps.noise = true;
  o.rgb_image = false;
  const RenderResult r = Renderer(white).Render(o);
  truth.transmission = r.transmission;
  truth.irradiance = r.lit;
  truth.veil = r.veil;
  truth.snow =
      o.snow.enabled ? r.noise : cv::Mat(scene.image.size(), r.noise.type(), cv::Scalar::all(0));
  CV_Assert(truth.transmission.size() == scene.image.size() &&
            truth.veil.size() == scene.image.size() &&
            truth.irradiance.size() == scene.image.size());
  truth.steps.push_back("truth maps: the simulator's own (model " + ImageModelName(ro.model) +
                        ", veil " + VeilModelName(ro.veil) + ", ambient " +
                        AmbientModelName(ro.ambient) +
                        "): t, E and the veil from a noise-free render at reflectance 1");
  truth.steps.push_back(o.snow.enabled ? "snow: re-rendered from the seed and subtracted"
                                       : "snow: none subtracted");
}

// The truth of a render. planes: also t, E, the veil and the snow layer as images (always with
// beta = 0, whose t is made as a whole image, and for models other than eq. 2 with its veil).
Truth ResolveTruth(const std::string& method, const cv::Mat& image, const Scene& scene,
                   const RenderRecord& sidecar, bool remove_snow, bool planes) {
  CheckTruthInputs(method, image, scene, sidecar);
  Truth truth;
  truth.render = *sidecar.options;
  const RenderOptions& ro = truth.render;
  const WaterOptions water = ResolveWater(ro.water);
  const int ch = truth.channels = image.channels();
  truth.scene = &scene;
  truth.width = image.cols;
  const std::vector<double> beta = ChannelValues(water.beta_rgb_per_m, water.beta_gray_per_m, ch);
  truth.beta = beta;
  const bool zero_beta = truth.zero_beta =
      std::all_of(beta.begin(), beta.end(), [](double b) { return b == 0; });
  truth.range_m = TruthRange(scene, zero_beta);
  if (ro.psf.enabled && ro.psf.model == PsfModel::kSmallAngle) {
    // Its per-pixel glow is not one of the blurs BlurModel inverts.
    throw Error(method + ": psf.model \"small_angle\" is not inverted (render with the paper PSF)");
  }
  if (ro.model != ImageModel::kPaper || ro.veil != VeilModel::kPaper ||
      ro.ambient != AmbientModel::kTyped || ro.snow.mode != "per_frame") {
    TruthPlanesFromRenderer(truth, scene, remove_snow);
  } else {
    planes = planes || zero_beta;
    if (zero_beta) {
      truth.transmission = ZeroBetaTransmission(truth.range_m, ch);
    } else if (planes) {
      truth.transmission = NewLike(image);
    }
    SetUpPaperRows(truth, scene, water, ChannelValues(water.ambient_rgb, water.ambient_gray, ch),
                   remove_snow);
    if (planes) {
      truth.irradiance = NewLike(image);
      truth.veil = NewLike(image);
      truth.snow = NewLike(image);
      for (int y = 0; y < image.rows; ++y) {
        truth.Rows(y, truth.irradiance.ptr<float>(y), truth.transmission.ptr<float>(y),
                   truth.veil.ptr<float>(y), truth.snow.ptr<float>(y));
      }
    }
  }
  truth.blur = MakeBlurModel(ro.psf, truth.range_m, beta);
  truth.steps.push_back(BlurStep(truth.blur));
  return truth;
}

// The oracle's last steps on one row (kCh channels): v = p + d where not masked, p where masked
// (kDeblur: p + the deblurred detail, then the prior copied back onto the masked pixels), or v =
// the estimate p (!kDeblur); times E (kLit: target lit); then cv::patchNaNs(v, 0), cv::min(v, 1)
// and max(v, 0) (0 for v < 0). Returns how many values are -0: cv::max's vector loop makes them
// +0, its scalar loop (a row's last few values) keeps them, so the caller leaves those to cv::max
// (which leaves every other value as it is).
template <int kCh, bool kDeblur, bool kLit>
TURBID_ROW_KERNEL int FinishRowN(const float* __restrict p, const float* __restrict d,
                                 const uchar* __restrict m, const float* __restrict e,
                                 float* __restrict out, int cols) {
  int negative_zeros = 0;
  for (int x = 0; x < cols; ++x) {
    for (int c = 0; c < kCh; ++c) {
      const int i = x * kCh + c;
      float v = p[i];
      if constexpr (kDeblur) {
        // As bit masks, so that the sum is formed for every value and the loop has no branch.
        const uint32_t sum = std::bit_cast<uint32_t>(p[i] + d[i]);
        const uint32_t keep = m[x] != 0 ? ~0u : 0u;
        v = std::bit_cast<float>((std::bit_cast<uint32_t>(p[i]) & keep) | (sum & ~keep));
      }
      if constexpr (kLit) v = v * e[i];
      v = std::isnan(v) ? 0.0f : v;
      v = 1.0f < v ? 1.0f : v;
      // v < 0 ? 0 : v on the bits (v is not NaN here): negative values other than -0 become +0.
      const uint32_t bits = std::bit_cast<uint32_t>(v);
      negative_zeros += bits == 0x80000000u ? 1 : 0;
      out[i] = std::bit_cast<float>(bits > 0x80000000u ? 0u : bits);
    }
  }
  return negative_zeros;
}

struct Finisher {
  int ch;
  bool deblur, lit;
  template <int kCh>
  int Run(const float* p, const float* d, const uchar* m, const float* e, float* out,
          int cols) const {
    if (deblur) {
      return lit ? FinishRowN<kCh, true, true>(p, d, m, e, out, cols)
                 : FinishRowN<kCh, true, false>(p, d, m, e, out, cols);
    }
    return lit ? FinishRowN<kCh, false, true>(p, d, m, e, out, cols)
               : FinishRowN<kCh, false, false>(p, d, m, e, out, cols);
  }
  int operator()(const float* p, const float* d, const uchar* m, const float* e, float* out,
                 int cols) const {
    return ch == 1 ? Run<1>(p, d, m, e, out, cols) : Run<3>(p, d, m, e, out, cols);
  }
};

}  // namespace

namespace oracle_internal {

void FinishImage(const cv::Mat& prior, const cv::Mat& detail, const cv::Mat& masked,
                 const cv::Mat& irradiance, cv::Mat& out) {
  CV_Assert(prior.depth() == CV_32F && (prior.channels() == 1 || prior.channels() == 3));
  const Finisher finish{prior.channels(), !detail.empty(), !irradiance.empty()};
  if (out.data != prior.data) out.create(prior.size(), prior.type());
  int negative_zeros = 0;
  for (int y = 0; y < prior.rows; ++y) {
    negative_zeros += finish(prior.ptr<float>(y), detail.empty() ? nullptr : detail.ptr<float>(y),
                             detail.empty() ? nullptr : masked.ptr<uchar>(y),
                             irradiance.empty() ? nullptr : irradiance.ptr<float>(y),
                             out.ptr<float>(y), prior.cols);
  }
  if (negative_zeros > 0) cv::max(out, 0.0, out);
}

}  // namespace oracle_internal

bool OracleExactOptions::Check(std::string* why) const {
  if (target != "clean" && target != "lit") return Fail(why, "target must be 'clean' or 'lit'");
  if (!std::isfinite(min_transmission) || min_transmission <= 0 || min_transmission > 1) {
    return Fail(why, "min_transmission must be in (0, 1]");
  }
  if (!std::isfinite(min_irradiance) || min_irradiance <= 0) {
    return Fail(why, "min_irradiance must be > 0");
  }
  if (max_iterations < 1 || max_iterations > 1000) {
    return Fail(why, "max_iterations must be in [1, 1000]");
  }
  if (!std::isfinite(tolerance) || tolerance < 0 || tolerance > 1) {
    return Fail(why, "tolerance must be in [0, 1]");
  }
  return true;
}

bool OracleOptions::Check(std::string* why) const {
  if (target != "clean" && target != "lit") return Fail(why, "target must be 'clean' or 'lit'");
  if (!std::isfinite(mask_transmission) || mask_transmission <= 0 || mask_transmission >= 1) {
    return Fail(why, "mask_transmission must be in (0, 1)");
  }
  if (pixel_radius < 1 || middle_radius < 1 || coarse_radius <= middle_radius ||
      coarse_radius > 256) {
    return Fail(why,
                "radii must satisfy 1 <= middle_radius < coarse_radius <= 256, pixel_radius >= 1");
  }
  if (pixel_radius > 64) return Fail(why, "pixel_radius must be <= 64");
  return true;
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
  Truth truth = ResolveTruth("oracle_exact", image, scene, sidecar, o.remove_snow, true);
  OracleResult result;
  result.steps = truth.steps;
  const cv::Mat masked = MaskBelow(truth.transmission, o.min_transmission);
  result.masked_pixels = cv::countNonZero(masked);
  // b = J * h where t >= the floor.
  cv::Mat b = (image - truth.snow - truth.veil) / MaxAll(truth.transmission, o.min_transmission);
  if (result.masked_pixels > 0) {
    // No data there: the mean of the rest, so the deblurring does not spread a huge value.
    b.setTo(cv::mean(b, ~masked), masked);
    result.steps.push_back("masked: " + std::to_string(result.masked_pixels) + " pixels with t < " +
                           std::to_string(o.min_transmission));
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
  cv::Mat out = o.target == "lit" ? lit.clone() : lit / MaxAll(truth.irradiance, o.min_irradiance);
  cv::patchNaNs(out, 0.0);
  cv::min(out, 1.0, out);
  cv::max(out, 0.0, out);
  result.image = out;
  return result;
}

namespace {

// The noise model of I per pixel (Foi et al. 2008): signal / photons + read^2, plus the
// quantisation noise of the camera's codes, (step s)^2 / 12 with s the decoding slope at the
// code of the local mean (oracle_internal::CodedQuantisation).
struct NoiseModel {
  bool sensor = false;
  double gain = 0.0, floor_var = 0.0, half_step = 0.0;
  oracle_internal::CodedQuantisation quantisation;

  explicit NoiseModel(const RenderOptions& ro) {
    sensor = ro.sensor.enabled;
    const double read2 = sensor ? ro.sensor.read_noise * ro.sensor.read_noise : 0.0;
    gain = sensor && ro.sensor.photons_at_white > 0 ? 1.0 / ro.sensor.photons_at_white : 0.0;
    const int bits = ro.camera.bit_depth;
    const double step = bits == 32 ? 0.0 : 1.0 / ((1 << bits) - 1);
    floor_var = read2 + 1e-12;
    quantisation.step_var = static_cast<float>(step * step / 12.0);
    quantisation.srgb = bits != 32 && ro.camera.encoding == CameraEncoding::kSrgb;
    half_step = bits == 32 ? 0.0 : 0.5 * step;
  }
  std::string Step(const RenderOptions& ro) const {
    return "noise: variance I / " + std::to_string(ro.sensor.photons_at_white) +
           " + read^2 + (step s)^2 / 12, s the " + (quantisation.srgb ? "sRGB" : "linear") +
           " decoding slope" + (sensor ? "" : " (sensor off)");
  }
};

// Row y of the truth maps for OracleMmse: the images where the truth has them (beta = 0, other
// models), else made by Truth::Rows into per-thread rows (E into the irradiance image for target
// lit, whose last step multiplies by it).
oracle_internal::TruthRowFn TruthRows(Truth& truth, int n, bool lit) {
  return [&truth, n, lit](int y, const float*& t, const float*& e, const float*& sn,
                          const float*& ve) {
    if (!truth.transmission.empty()) {
      t = truth.transmission.ptr<float>(y);
      e = truth.irradiance.ptr<float>(y);
      sn = truth.snow.ptr<float>(y);
      ve = truth.veil.ptr<float>(y);
      return;
    }
    thread_local std::vector<float> rows;
    rows.resize(std::max<size_t>(rows.size(), 4 * static_cast<size_t>(n)));
    float* e_row = lit ? truth.irradiance.ptr<float>(y) : rows.data();
    float* t_row = rows.data() + n;
    float* sn_row = t_row + n;
    float* ve_row = sn_row + n;
    truth.Rows(y, e_row, t_row, ve_row, sn_row);
    t = t_row;
    e = e_row;
    sn = sn_row;
    ve = ve_row;
  };
}

// Wiener on the deviation from the prior mean (the signal's mean; smooth, so h * P = P to the
// blur's width): K = (noise left after the MMSE) / (variance of the deviation), both over the
// data pixels — the MMSE filter for a white deviation of that variance (Gonzalez & Woods §5.8). A
// constant-K Wiener on est itself would scale its mean by 1 / (1 + K). The sums are the mean of
// the posterior variance and the variance of detail = est - prior over the data pixels, made
// with the estimate's rows (OracleMmse; in double, as cv::mean / cv::meanStdDev form them, in
// another order: the ratio agrees to ~1e-15).
double DeblurNsr(const oracle_internal::DetailSums& stats, int channels) {
  double noise = 0, signal = 0;
  for (int c = 0; c < channels; ++c) {
    const double n = static_cast<double>(stats.count);
    const double pm = stats.count > 0 ? stats.posterior[c] / n : 0.0;
    const double mean = stats.count > 0 ? stats.detail[c] / n : 0.0;
    const double var = stats.count > 0 ? std::max(stats.detail_sq[c] / n - mean * mean, 0.0) : 0.0;
    noise += pm;
    signal += var;
  }
  return std::clamp(signal > 0 ? noise / signal : 10.0, 1e-8, 10.0);
}

// est = prior + the deblurred detail, the prior where masked, then the target and the clamp: one
// pass, fed by the streamed deconvolution where it has one (one kernel, spatial path).
cv::Mat DeblurAndFinish(const Truth& truth, const oracle_internal::OracleMmseResult& mmse,
                        double nsr, bool lit, const cv::Mat& image) {
  const BlurModel& blur = truth.blur;
  DeconvolutionOptions d;
  d.nsr = nsr;
  const Finisher finish{truth.channels, true, lit};
  cv::Mat out = NewLike(image);
  int negative_zeros = 0;
  auto emit = [&](int y, const float* row) {
    negative_zeros +=
        finish(mmse.prior.ptr<float>(y), row, mmse.masked.ptr<uchar>(y),
               lit ? truth.irradiance.ptr<float>(y) : nullptr, out.ptr<float>(y), out.cols);
  };
  if (blur.Count() != 1 || blur.depth_dependent ||
      !DeconvolveRows(d, mmse.detail, blur.Kernel(0), emit)) {
    std::vector<cv::Mat> per_level;
    for (size_t i = 0; i < blur.Count(); ++i)
      per_level.push_back(Deconvolve(d, mmse.detail, blur.Kernel(i)));
    const cv::Mat deblurred = blur.depth_dependent ? blur.Blend(per_level) : per_level[0];
    for (int y = 0; y < out.rows; ++y) emit(y, deblurred.ptr<float>(y));
  }
  if (negative_zeros > 0) cv::max(out, 0.0, out);
  return out;
}

}  // namespace

OracleResult OracleEnhance(const OracleOptions& o, const cv::Mat& image, const Scene& scene,
                           const RenderRecord& sidecar) {
  ThrowIfInvalid(o, "oracle");
  const bool lit = o.target == "lit";
  Truth truth = ResolveTruth("oracle", image, scene, sidecar, o.remove_snow, false);
  OracleResult result;
  result.steps = truth.steps;
  const NoiseModel noise(truth.render);
  // The signal in the shot-noise term is the local mean of I (7x7 box) rather than I itself: a
  // variance read from the noisy value weights the darker draws more and biases every weighted
  // mean low.
  const BlurModel& blur = truth.blur;
  if (lit && truth.irradiance.empty()) truth.irradiance = NewLike(image);
  const oracle_internal::OracleMmseResult mmse = oracle_internal::OracleMmse(
      o, image, TruthRows(truth, image.cols * image.channels(), lit), noise.gain, noise.floor_var,
      1.0 - noise.half_step - 1e-7, blur.active && o.deblur,
      /*keep_estimate=*/false, noise.quantisation);
  result.steps.push_back(noise.Step(truth.render));
  result.masked_pixels = mmse.masked_pixels;
  if (mmse.censored_pixels > 0) {
    result.steps.push_back("censored: " + std::to_string(mmse.censored_pixels) +
                           " pixels clipped at 0 or 1 in some channel: no weight");
  }
  result.steps.push_back("mmse: hierarchical local Gaussian prior, windows " +
                         std::to_string(o.coarse_radius) + " / " + std::to_string(o.middle_radius) +
                         " / " + std::to_string(o.pixel_radius) + " px");
  if (result.masked_pixels > 0) {
    result.steps.push_back("masked: " + std::to_string(result.masked_pixels) + " pixels with t < " +
                           std::to_string(o.mask_transmission) + ", set to the prior mean");
  }
  if (blur.active && o.deblur) {
    result.deblur_nsr = DeblurNsr(mmse.detail_sums, truth.channels);
    result.image = DeblurAndFinish(truth, mmse, result.deblur_nsr, lit, image);
    result.steps.push_back("deblur: Wiener, NSR " + std::to_string(result.deblur_nsr));
    return result;
  }
  cv::Mat est = mmse.estimate;
  oracle_internal::FinishImage(est, cv::Mat(), mmse.masked, lit ? truth.irradiance : cv::Mat(),
                               est);
  result.image = est;
  return result;
}

}  // namespace turbid
