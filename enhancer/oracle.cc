#include "enhancer/oracle.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "enhancer/deconvolution.h"
#include "enhancer/method.h"
#include "enhancer/oracle_internal.h"
#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/image_pool.h"
#include "simulator/kernels.h"
#include "simulator/light.h"
#include "simulator/noise.h"
#include "simulator/psf.h"
#include "simulator/render.h"
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

// Full-size buffers come from the renderer's recycling pool (simulator/image_pool.h): the
// oracle needs a few dozen per call, and fresh pages for each cost more than its arithmetic.
cv::Mat NewLike(const cv::Mat& m) { return internal::PooledMat(m.size(), m.type()); }

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

TURBID_ROW_KERNEL void ProductRow(const float* __restrict a, const float* __restrict b,
                                  float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = a[i] * b[i];
}

// out = m / max(w, 1e-30).
TURBID_ROW_KERNEL void QuotientRow(const float* __restrict w, const float* __restrict m,
                                   float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = m[i] / std::max(w[i], 1e-30f);
}

// The estimate and the posterior variance (into s) of HierarchicalMmse.
TURBID_ROW_KERNEL void EstimateRow(const float* __restrict a, const float* __restrict u,
                                   const float* __restrict p, float* __restrict s,
                                   float* __restrict e, int n) {
  for (int i = 0; i < n; ++i) {
    const float sa_px = s[i] * a[i];
    const float den = sa_px + 1.0f;
    const float gain = sa_px / den;
    s[i] = s[i] / den;
    e[i] = p[i] + gain * (u[i] - p[i]);
  }
}

TURBID_ROW_KERNEL void NoiseVarianceRow(const float* __restrict mean, float* __restrict v,
                                        float gain, float floor_var, int n) {
  for (int i = 0; i < n; ++i) v[i] = std::max(mean[i], 0.0f) * gain + floor_var;
}

// LocalSignalVariance's last step: max(sum - count, 0) / max(sum a, 1e-30), with the maxima as
// the vector loop of cv::max(image, scalar) takes them, x > floor ? x : floor (NaN gives the
// floor; std::max keeps it). The numerator's box sums are NaN once a (z - p)^2 overflowed (inf -
// inf in the running sums: z = m, the level mean, reaches ~1e21 where t E is at the 1e-12 floor
// and a window's sum of a is a negative rounding residue). Returns how many values had a NaN
// sum - count or sum a: cv::max's scalar loop (ScalarLoopValues) keeps those (FixScalarLoopNans).
TURBID_ROW_KERNEL int SignalVarianceRow(const float* __restrict sum, const float* __restrict w,
                                        const float* __restrict count, float* __restrict o, int n) {
  int nans = 0;
  for (int i = 0; i < n; ++i) {
    const float v = sum[i] - count[i];
    nans += (v != v) | (w[i] != w[i]);
    o[i] = (v > 0.0f ? v : 0.0f) / (w[i] > 1e-30f ? w[i] : 1e-30f);
  }
  return nans;
}

TURBID_ROW_KERNEL int SignalVarianceRowFull(const float* __restrict sum, const float* __restrict w,
                                            float full, float* __restrict o, int n) {
  int nans = 0;
  for (int i = 0; i < n; ++i) {
    const float v = sum[i] - full;
    nans += (v != v) | (w[i] != w[i]);
    o[i] = (v > 0.0f ? v : 0.0f) / (w[i] > 1e-30f ? w[i] : 1e-30f);
  }
  return nans;
}

// The values (flat indices, ascending) of a continuous rows x cols float image of ch channels
// that cv::max(image, cv::Scalar) leaves to its scalar loop, where a NaN stays NaN (std::max)
// instead of becoming the scalar (its vector loop): the last values of each block it splits the
// image into, which depend on OpenCV's block size and vector width, so found by asking cv::max
// (on NaNs) once per shape, only when a NaN is met. Per thread, the last shape's.
const std::vector<int>& ScalarLoopValues(int rows, int cols, int ch) {
  thread_local int shape[3] = {-1, -1, -1};
  thread_local std::vector<int> values;
  if (shape[0] != rows || shape[1] != cols || shape[2] != ch) {
    cv::Mat probe(rows, cols, CV_32FC(ch),
                  cv::Scalar::all(std::numeric_limits<double>::quiet_NaN()));
    cv::max(probe, cv::Scalar::all(0.0), probe);
    values.clear();
    const float* p = probe.ptr<float>(0);
    for (size_t k = 0; k < probe.total() * ch; ++k)
      if (std::isnan(p[k])) values.push_back(static_cast<int>(k));
    shape[0] = rows, shape[1] = cols, shape[2] = ch;
  }
  return values;
}

// Row y (n values) of SignalVarianceRow's output where it met NaNs: the values in cv::max's scalar
// loop get std::max's maxima (a NaN sum - count or sum a stays NaN). count null: full.
void FixScalarLoopNans(int rows, int cols, int ch, int y, const float* sum, const float* w,
                       const float* count, float full, float* o) {
  const int n = cols * ch;
  const std::vector<int>& values = ScalarLoopValues(rows, cols, ch);
  const auto first = std::lower_bound(values.begin(), values.end(), y * n);
  for (auto it = first; it != values.end() && *it < (y + 1) * n; ++it) {
    const int i = *it - y * n;
    const float v = sum[i] - (count != nullptr ? count[i] : full);
    o[i] = std::max(v, 0.0f) / std::max(w[i], 1e-30f);
  }
}

// Values of a row with no data (a > 0 false: 0, negative or NaN).
TURBID_ROW_KERNEL int NoDataRow(const float* __restrict a, int n) {
  int none = 0;
  for (int i = 0; i < n; ++i) none += a[i] > 0.0f ? 0 : 1;
  return none;
}

// Element-wise passes over images of the same size and type (any channel count, rows possibly
// strided): fn(i, pointers...) for every value i of a row. Every formula below is written as the
// OpenCV expressions it replaced evaluate it (one float rounding per operation, no FMA), so the
// values are the same; the passes fuse what were separate full-size temporaries.
template <typename Fn, typename... Mats>
void ForRows(const cv::Mat& shape, Fn fn, Mats&... mats) {
  const int n = shape.cols * shape.channels();
  for (int y = 0; y < shape.rows; ++y) fn(n, mats.template ptr<float>(y)...);
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

// The truth of a render. planes: also t, E, the veil and the snow layer as images (always with
// beta = 0, whose t is made as a whole image).
Truth ResolveTruth(const std::string& method, const cv::Mat& image, const Scene& scene,
                   const RenderRecord& sidecar, bool remove_snow, bool planes) {
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
  truth.scene = &scene;
  truth.width = image.cols;
  const std::vector<double> beta = ChannelValues(water.beta_rgb_per_m, water.beta_gray_per_m, ch);
  truth.beta = beta;
  const std::vector<double> ambient = ChannelValues(water.ambient_rgb, water.ambient_gray, ch);
  const bool zero_beta = truth.zero_beta =
      std::all_of(beta.begin(), beta.end(), [](double b) { return b == 0; });
  planes = planes || zero_beta;
  // The range: RangeFromDepth's rows (its values), into a pooled image first (the snow and the
  // rows' transmission read it).
  CV_Assert(scene.depth_m.type() == CV_32FC1);
  if (zero_beta) {
    truth.range_m = RangeFromDepth(scene.camera, scene.depth_m);
  } else {
    const std::vector<double> range_dx = RangeColumnTable(scene.camera, scene.depth_m.cols);
    truth.range_m = internal::PooledMat(scene.depth_m.size(), CV_32FC1);
    for (int y = 0; y < image.rows; ++y) {
      RangeFromDepthRow(scene.camera, range_dx, scene.depth_m.ptr<float>(y), y,
                        truth.range_m.ptr<float>(y));
    }
  }

  if (zero_beta) {
    // The renderer's beta = 0 path: t = 1 where depth is valid, 0 (open water) where it is NaN.
    cv::Mat valid = truth.range_m == truth.range_m;  // 255 where not NaN
    cv::Mat t1;
    valid.convertTo(t1, CV_32F, 1.0 / 255.0);
    std::vector<cv::Mat> t_planes(ch, t1);
    cv::merge(t_planes, truth.transmission);
  } else if (planes) {
    truth.transmission = NewLike(image);
  }
  cv::Scalar backscatter = cv::Scalar::all(0);
  truth.backscatter = water.backscatter;
  if (water.backscatter) {
    backscatter = ToScalar(ChannelValues(water.backscatter_rgb, water.backscatter_gray, ch));
    truth.steps.push_back("veil: (1 - t)(E_L + B_inf)");
  } else {
    truth.steps.push_back("veil: (1 - t) E_L");
  }
  const int w = image.cols;
  if (!ro.light.lights.empty()) {
    ThrowIfInvalid(ro.light, "light");
    truth.normals =
        scene.normals.empty() ? NormalsFromDepth(scene.camera, scene.depth_m) : scene.normals;
    CV_Assert(scene.depth_m.type() == CV_32FC1 && truth.normals.type() == CV_32FC3 &&
              truth.normals.size() == scene.depth_m.size());
    truth.context = internal::LightContextFor(ro.light, scene.camera, w);
    truth.lights = internal::LightConstantsFor(ro.light, ch);
  }
  for (int c = 0; c < ch; ++c) {
    truth.neg_beta[c] = -static_cast<float>(beta[c]);
    truth.ambient_f[c] = static_cast<float>(ambient[c]);
    truth.backscatter_f[c] = static_cast<float>(backscatter[c]);
  }
  if (remove_snow && ro.snow.enabled && ro.snow.density_per_m3 > 0) {
    // RenderMarineSnow's layer (its particles drawn row by row onto zeros).
    truth.splats = internal::DrawMarineSnow(ro.snow, ro.light, scene.camera, truth.range_m, beta,
                                            ambient, ro.seed);
    CV_Assert(truth.splats.channels == ch);
    truth.draw_snow = true;
    truth.steps.push_back("snow: " + std::to_string(truth.splats.visible) +
                          " particles re-rendered from the seed and subtracted");
  } else {
    truth.steps.push_back("snow: none subtracted");
  }
  if (planes) {
    truth.irradiance = NewLike(image);
    truth.veil = NewLike(image);
    truth.snow = NewLike(image);
    for (int y = 0; y < image.rows; ++y) {
      truth.Rows(y, truth.irradiance.ptr<float>(y), truth.transmission.ptr<float>(y),
                 truth.veil.ptr<float>(y), truth.snow.ptr<float>(y));
    }
  }
  truth.blur = MakeBlurModel(ro.psf, truth.range_m, beta);
  if (!truth.blur.active) {
    truth.steps.push_back("psf: none (disabled or a delta)");
  } else {
    truth.steps.push_back(
        std::string("psf: ") +
        (truth.blur.turbidity ? std::to_string(truth.blur.Count()) + " turbidity-dependent levels"
         : truth.blur.depth_dependent
             ? std::to_string(truth.blur.levels.size()) + " range-dependent levels"
             : "one kernel, radius " + std::to_string(truth.blur.levels[0].radius_px) + " px"));
  }
  return truth;
}

// MaskBelow's row for the oracle's stream: 255 where some channel of t is below floor (the
// threshold in float, as cv::compare converts it), else 0; returns how many.
TURBID_ROW_KERNEL int MaskRow1(const float* __restrict t, float floor, uchar* __restrict m,
                               int cols) {
  int count = 0;
  for (int x = 0; x < cols; ++x) {
    const bool below = t[x] < floor;
    m[x] = below ? 255 : 0;
    count += below ? 1 : 0;
  }
  return count;
}

int MaskRow(const float* t, float floor, int ch, int cols, uchar* m) {
  if (ch == 1) return MaskRow1(t, floor, m, cols);
  int count = 0;
  for (int x = 0; x < cols; ++x) {
    bool below = false;
    for (int c = 0; c < ch; ++c) below = below || t[x * ch + c] < floor;
    m[x] = below ? 255 : 0;
    count += below ? 1 : 0;
  }
  return count;
}

// Pixels where any channel of t is below `floor` (NaN depth has t = 0): CV_8UC1, 255 = masked.
cv::Mat MaskBelow(const cv::Mat& t, double floor) {
  if (t.channels() == 1) return t < floor;  // no copy of the one plane (cv::split would)
  std::vector<cv::Mat> planes;
  cv::split(t, planes);
  cv::Mat mask = planes[0] < floor;
  for (size_t c = 1; c < planes.size(); ++c) mask |= planes[c] < floor;
  return mask;
}

// ---- Box sums in cv::boxFilter's order -------------------------------------------------------
// cv::boxFilter on CV_32F (OpenCV 4.6, box_filter.simd.hpp) sums in double: per row (the row
// extended by its reflected border), a window of 3 or 5 as the direct sum s0 + s1 + ... left to
// right, any other as a running sum (s = 0, s += x_0 .. x_{k-1}, then s += (x_{i+k} - x_i) per
// step, the difference formed in double); then per column a running sum over the row sums (SUM =
// 0, SUM += h_0 .. h_{k-2}, then per output row s = SUM + h_{y+k-1}, out = float(s [* scale]), SUM
// = s - h_y). Those are serial chains, one per row and one per column. The same operations in the
// same order give the same doubles; what is new is only which independent chains run side by side:
// eight rows' running sums side by side in two four-row vectors (gray; four scalar rows in
// colour) instead of one row at a time, the column step vectorised across columns, and the row
// sums kept in a ring of k + 8 rows per plane.

// The direct sums of a window of 3 or 5 (values cn apart), left to right.
TURBID_ROW_KERNEL void BoxDirect3Row(const float* __restrict s, double* __restrict d, int cn,
                                     int n) {
  for (int i = 0; i < n; ++i) {
    d[i] = (static_cast<double>(s[i]) + static_cast<double>(s[i + cn])) +
           static_cast<double>(s[i + 2 * cn]);
  }
}

TURBID_ROW_KERNEL void BoxDirect5Row(const float* __restrict s, double* __restrict d, int cn,
                                     int n) {
  for (int i = 0; i < n; ++i) {
    d[i] = (((static_cast<double>(s[i]) + static_cast<double>(s[i + cn])) +
             static_cast<double>(s[i + 2 * cn])) +
            static_cast<double>(s[i + 3 * cn])) +
           static_cast<double>(s[i + 4 * cn]);
  }
}

// One output row of the column running sum: s = SUM + h_new, out = float(s), SUM = s - h_old.
TURBID_ROW_KERNEL void BoxColumnRow(double* __restrict sum, const double* __restrict add,
                                    const double* __restrict sub, float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) {
    const double s = sum[i] + add[i];
    out[i] = static_cast<float>(s);
    sum[i] = s - sub[i];
  }
}

TURBID_ROW_KERNEL void BoxColumnRowScaled(double* __restrict sum, const double* __restrict add,
                                          const double* __restrict sub, float* __restrict out,
                                          double scale, int n) {
  for (int i = 0; i < n; ++i) {
    const double s = sum[i] + add[i];
    out[i] = static_cast<float>(s * scale);
    sum[i] = s - sub[i];
  }
}

TURBID_ROW_KERNEL void BoxAccumulateRow(double* __restrict sum, const double* __restrict add,
                                        int n) {
  for (int i = 0; i < n; ++i) sum[i] += add[i];
}

// The running sums of four rows at once (independent chains side by side, the sums in
// registers): for each channel c, from the first sum h_r[c], h_r[(i + 1) cn + c] = h_r[i cn + c]
// + (double(e_r[(i + k) cn + c]) - double(e_r[i cn + c])) in order of i.
// The rows come as doubles (converted beforehand by vector conversions, exact): a scalar float
// to double conversion per value was the chains' bottleneck (one per cycle).
TURBID_ROW_KERNEL void BoxRunning4(const double* __restrict e0, const double* __restrict e1,
                                   const double* __restrict e2, const double* __restrict e3,
                                   double* __restrict h0, double* __restrict h1,
                                   double* __restrict h2, double* __restrict h3, int cn, int k,
                                   int steps) {
  const int ahead = k * cn;
  for (int c = 0; c < cn; ++c) {
    double s0 = h0[c], s1 = h1[c], s2 = h2[c], s3 = h3[c];
    for (int i = 0; i < steps; ++i) {
      const int j = i * cn + c;
      s0 = s0 + (e0[j + ahead] - e0[j]);
      s1 = s1 + (e1[j + ahead] - e1[j]);
      s2 = s2 + (e2[j + ahead] - e2[j]);
      s3 = s3 + (e3[j + ahead] - e3[j]);
      h0[j + cn] = s0;
      h1[j + cn] = s1;
      h2[j + cn] = s2;
      h3[j + cn] = s3;
    }
  }
}

// BoxRunning4 for eight rows of one channel (cn = 1) whose bordered rows are `stride` values
// apart (e + r stride): the same per-row operations in the same order, h_r[i + 1] = h_r[i] +
// (e_r[i + k] - e_r[i]), but each chain step is one vector add over four rows (two vectors: rows
// 0-3 and 4-7), so eight chains run side by side instead of four (the four scalar chains of
// BoxRunning4 are latency-bound at ~1 value per cycle). The differences of four columns are
// formed row-wise and transposed (4 x 4) into column vectors; the sums are transposed back into
// the rows, stored 32-byte aligned where the rows allow it (unaligned stores split cache lines).
TURBID_ROW_KERNEL void BoxRunning8Gray(const double* __restrict e, size_t stride,
                                       double* const* __restrict h, int k, int steps) {
  using V4d = double __attribute__((vector_size(32)));
  // The difference of four columns of one row: e_r[i + k ..] - e_r[i ..].
  auto diff = [k](V4d& d, const double* p) {
    V4d a, b;
    std::memcpy(&a, p + k, sizeof(a));
    std::memcpy(&b, p, sizeof(b));
    d = a - b;
  };
  auto transpose = [](V4d& r0, V4d& r1, V4d& r2, V4d& r3) {
    const V4d t0 = __builtin_shufflevector(r0, r1, 0, 4, 2, 6);
    const V4d t1 = __builtin_shufflevector(r0, r1, 1, 5, 3, 7);
    const V4d t2 = __builtin_shufflevector(r2, r3, 0, 4, 2, 6);
    const V4d t3 = __builtin_shufflevector(r2, r3, 1, 5, 3, 7);
    r0 = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
    r1 = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
    r2 = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
    r3 = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
  };
  double* hr[8];
  for (int r = 0; r < 8; ++r) hr[r] = h[r];
  // First the columns up to where the stores h_r + i + 1 are 32-byte aligned (when the eight
  // rows share their alignment), one row at a time.
  int i = 0;
  const auto misalign = [](const double* p) { return reinterpret_cast<uintptr_t>(p) % 32; };
  bool same = misalign(hr[0]) % sizeof(double) == 0;
  for (int r = 1; r < 8; ++r) same = same && misalign(hr[r]) == misalign(hr[0]);
  if (same) {
    while (i < steps && misalign(hr[0] + i + 1) != 0) ++i;
    for (int r = 0; r < 8; ++r) {
      const double* er = e + static_cast<size_t>(r) * stride;
      double sum = hr[r][0];
      for (int j = 0; j < i; ++j) {
        sum = sum + (er[j + k] - er[j]);
        hr[r][j + 1] = sum;
      }
    }
  }
  V4d s[2];
  for (int g = 0; g < 2; ++g)
    s[g] = V4d{hr[4 * g][i], hr[4 * g + 1][i], hr[4 * g + 2][i], hr[4 * g + 3][i]};
  for (; i + 4 <= steps; i += 4) {
    for (int g = 0; g < 2; ++g) {
      const double* eg = e + static_cast<size_t>(4 * g) * stride + i;
      V4d d0, d1, d2, d3;
      diff(d0, eg);
      diff(d1, eg + stride);
      diff(d2, eg + 2 * stride);
      diff(d3, eg + 3 * stride);
      transpose(d0, d1, d2, d3);  // now d_c: column i + c of the four rows
      V4d s0 = s[g] + d0;
      V4d s1 = s0 + d1;
      V4d s2 = s1 + d2;
      V4d s3 = s2 + d3;
      s[g] = s3;
      transpose(s0, s1, s2, s3);  // now s_r: columns i + 1 .. i + 4 of row 4 g + r
      std::memcpy(hr[4 * g] + i + 1, &s0, sizeof(s0));
      std::memcpy(hr[4 * g + 1] + i + 1, &s1, sizeof(s1));
      std::memcpy(hr[4 * g + 2] + i + 1, &s2, sizeof(s2));
      std::memcpy(hr[4 * g + 3] + i + 1, &s3, sizeof(s3));
    }
  }
  for (int r = 0; r < 8; ++r) {
    const double* er = e + static_cast<size_t>(r) * stride;
    double sum = s[r / 4][r % 4];
    for (int j = i; j < steps; ++j) {
      sum = sum + (er[j + k] - er[j]);
      hr[r][j + 1] = sum;
    }
  }
}

TURBID_ROW_KERNEL void WidenRow(const float* __restrict in, double* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = static_cast<double>(in[i]);
}

void BoxRunning1(const double* e, double* h, int cn, int k, int steps) {
  for (int c = 0; c < cn; ++c) {
    double s = h[c];
    for (int i = 0; i < steps; ++i) {
      const int j = i * cn + c;
      s = s + (e[j + k * cn] - e[j]);
      h[j + cn] = s;
    }
  }
}

// BoxStream's buffers, kept per thread between calls (fresh pages on every call would cost more
// than the sums): the rings of row sums, the bordered input rows, the column sums and the output
// rows. One set per thread: BoxStream calls do not nest.
struct BoxScratch {
  std::vector<double> ring, sum, ext_d;
  std::vector<float> ext, out;
};

BoxScratch& ThreadBoxScratch() {
  thread_local BoxScratch scratch;
  return scratch;
}

// At least `count` values of v from a 64-byte line on (std::vector's data of these sizes starts
// 16 bytes past a line, so every other 32-byte access would split one); v grows as needed.
template <typename T>
T* Aligned64(std::vector<T>& v, size_t count) {
  constexpr size_t kPad = 64 / sizeof(T);
  v.resize(std::max(v.size(), count + kPad));
  const uintptr_t p = reinterpret_cast<uintptr_t>(v.data());
  return v.data() + ((64 - p % 64) % 64) / sizeof(T);
}

// Values per buffer row: n rounded up to whole 64-byte lines (rows of an aligned block stay
// aligned).
template <typename T>
size_t LineStride(size_t n) {
  constexpr size_t kLine = 64 / sizeof(T);
  return (n + kLine - 1) / kLine * kLine;
}

// Box sums of kPlanes images of the same shape (rows x cols, cn channels) streamed a row at a
// time: produce(source_row, float* const* in) writes that row of each plane into in[p] (cols cn
// values; it may be asked for a row more than once, for the reflected border); consume(y, const
// float* const* out) receives output row y of each plane, in order of y. scale 1: sums;
// otherwise each sum times scale (cv::boxFilter's normalised mean). Only a ring of k + 8 row sums
// per plane is kept, so the planes need not exist as whole images.
// The reflected border columns of a bordered row whose interior (cols pixels of cn values) is
// already at e + radius cn: columns x < radius and x >= radius + cols of the cols + 2 radius,
// copied from the interior pixels xofs[x] (BORDER_REFLECT, as cv::borderInterpolate places them).
template <typename T>
void FillReflectedBorder(T* e, int cols, int cn, int radius, const std::vector<int>& xofs) {
  const int width = cols + 2 * radius;
  for (int x = 0; x < width; ++x) {
    if (x == radius) x = std::min(radius + cols, width);  // the interior is there
    if (x >= width) break;
    for (int c = 0; c < cn; ++c) e[x * cn + c] = e[(radius + xofs[x]) * cn + c];
  }
}

// Bordered row j (of rows + 2 radius) of every plane: produce(y, in) writes image row y =
// reflect(j - radius) into the planes' interiors, then their reflected borders are filled.
// ext_row(p) is plane p's bordered row.
template <int kPlanes, typename Produce, typename ExtRow>
void ProduceBorderedRow(Produce& produce, ExtRow&& ext_row, int j, int rows, int cols, int cn,
                        int radius, const std::vector<int>& xofs) {
  float* in[kPlanes];
  for (int p = 0; p < kPlanes; ++p) in[p] = ext_row(p) + radius * cn;
  produce(cv::borderInterpolate(j - radius, rows, cv::BORDER_REFLECT), in);
  for (int p = 0; p < kPlanes; ++p) FillReflectedBorder(ext_row(p), cols, cn, radius, xofs);
}

template <int kPlanes, typename Produce, typename Consume>
void BoxStream(int rows, int cols, int cn, int radius, double scale, Produce&& produce,
               Consume&& consume) {
  const int k = 2 * radius + 1;
  const int n = cols * cn;
  const int ext_n = (cols + k - 1) * cn;  // values per bordered row
  // Rows per batch: BoxRunning8Gray's eight chains in gray, BoxRunning4's four in colour (a
  // smaller ring).
  const int batch = cn == 1 ? 8 : 4;
  const int capacity = k + batch;
  const int total_rows = rows + k - 1;  // bordered rows j = 0 .. rows + k - 2
  // Reflected border columns (BORDER_REFLECT, as cv::borderInterpolate places them).
  std::vector<int> xofs(cols + k - 1);
  for (int j = 0; j < cols + k - 1; ++j)
    xofs[j] = cv::borderInterpolate(j - radius, cols, cv::BORDER_REFLECT);
  // Every buffer row starts on a 64-byte line (rows padded to whole lines).
  BoxScratch& scratch = ThreadBoxScratch();
  const size_t rn = LineStride<double>(n), on = LineStride<float>(n);
  const size_t en = LineStride<float>(ext_n), edn = LineStride<double>(ext_n);
  const size_t ring_n = static_cast<size_t>(capacity) * rn;
  double* const ring = Aligned64(scratch.ring, kPlanes * ring_n);
  double* const sums = Aligned64(scratch.sum, kPlanes * rn);
  std::fill(sums, sums + kPlanes * rn, 0.0);
  float* const ext = Aligned64(scratch.ext, kPlanes * batch * en);
  const bool running = k != 3 && k != 5;
  double* const ext_d = running ? Aligned64(scratch.ext_d, kPlanes * batch * edn) : nullptr;
  float* const outs = Aligned64(scratch.out, kPlanes * on);
  auto slot = [&](int p, int j) {
    return ring + p * ring_n + static_cast<size_t>(j % capacity) * rn;
  };
  auto ext_row = [&](int p, int b) { return ext + (static_cast<size_t>(p) * batch + b) * en; };
  auto ext_d_row = [&](int p, int b) { return ext_d + (static_cast<size_t>(p) * batch + b) * edn; };
  int produced = 0;  // bordered rows whose row sums are in the rings
  auto produce_batch = [&](int count) {
    for (int b = 0; b < count; ++b) {
      const int j = produced + b;
      ProduceBorderedRow<kPlanes>(
          produce, [&](int p) { return ext_row(p, b); }, j, rows, cols, cn, radius, xofs);
      for (int p = 0; p < kPlanes; ++p) {
        float* e = ext_row(p, b);
        double* h = slot(p, j);
        if (k == 3) {
          BoxDirect3Row(e, h, cn, n);
        } else if (k == 5) {
          BoxDirect5Row(e, h, cn, n);
        } else {
          for (int c = 0; c < cn; ++c) {
            double sum = 0;
            for (int i = 0; i < k; ++i) sum += static_cast<double>(e[i * cn + c]);
            h[c] = sum;
          }
          WidenRow(e, ext_d_row(p, b), ext_n);
        }
      }
    }
    if (running) {
      for (int p = 0; p < kPlanes; ++p) {
        int b = 0;
        for (; cn == 1 && b + 8 <= count; b += 8) {
          const int j = produced + b;
          double* h[8];
          for (int r = 0; r < 8; ++r) h[r] = slot(p, j + r);
          BoxRunning8Gray(ext_d_row(p, b), edn, h, k, cols - 1);
        }
        for (; b + 4 <= count; b += 4) {
          const int j = produced + b;
          BoxRunning4(ext_d_row(p, b), ext_d_row(p, b + 1), ext_d_row(p, b + 2),
                      ext_d_row(p, b + 3), slot(p, j), slot(p, j + 1), slot(p, j + 2),
                      slot(p, j + 3), cn, k, cols - 1);
        }
        for (; b < count; ++b) BoxRunning1(ext_d_row(p, b), slot(p, produced + b), cn, k, cols - 1);
      }
    }
    produced += count;
  };
  auto need = [&](int j) {
    while (produced <= j) produce_batch(std::min(batch, total_rows - produced));
  };
  for (int j = 0; j < k - 1; ++j) {
    need(j);
    for (int p = 0; p < kPlanes; ++p) BoxAccumulateRow(sums + p * rn, slot(p, j), n);
  }
  const float* out[kPlanes];
  for (int p = 0; p < kPlanes; ++p) out[p] = outs + p * on;
  for (int y = 0; y < rows; ++y) {
    need(y + k - 1);
    for (int p = 0; p < kPlanes; ++p) {
      double* sum = sums + p * rn;
      float* o = outs + p * on;
      if (scale != 1.0) {
        BoxColumnRowScaled(sum, slot(p, y + k - 1), slot(p, y), o, scale, n);
      } else {
        BoxColumnRow(sum, slot(p, y + k - 1), slot(p, y), o, n);
      }
    }
    consume(y, out);
  }
}

// BoxStream for two radii at once (sums, scale 1): the same box sums of the same planes over
// windows of radius `large` and `small` < large, from one pass over the input rows. The small
// window's bordered rows are a run of the large one's (bordered row j of the small window is row
// j + (large - small) of the large one's, the same source row, and its bordered columns are a
// run of the large one's), so each input row is produced and widened once. Each radius keeps its
// own ring of row sums and column sums and makes the same double operations in the same order as
// BoxStream; consume_large(y, out) and consume_small(y, out) each receive their rows in order of
// y (interleaved with each other). first_large(y) / first_small(y): where output row y of the
// first plane is written (out[0] points there).
template <int kPlanes, typename Produce, typename ConsumeLarge, typename ConsumeSmall,
          typename FirstLarge, typename FirstSmall>
void BoxStreamTwoRadii(int rows, int cols, int cn, int large, int small, Produce&& produce,
                       ConsumeLarge&& consume_large, ConsumeSmall&& consume_small,
                       FirstLarge&& first_large, FirstSmall&& first_small) {
  CV_Assert(small >= 1 && small < large);
  // Rows per batch: BoxRunning8Gray's eight chains in gray, BoxRunning4's four in colour (a
  // smaller ring).
  const int batch = cn == 1 ? 8 : 4;
  const int n = cols * cn;
  const int kl = 2 * large + 1;
  const int ext_n = (cols + kl - 1) * cn;
  const int offset = large - small;
  std::vector<int> xofs(cols + kl - 1);
  for (int j = 0; j < cols + kl - 1; ++j)
    xofs[j] = cv::borderInterpolate(j - large, cols, cv::BORDER_REFLECT);
  struct Window {
    int k = 0, capacity = 0, total = 0, produced = 0, accumulated = 0, emitted = 0;
    double* ring = nullptr;
    double* sum = nullptr;
  };
  Window win[2];
  win[0].k = kl;
  win[1].k = 2 * small + 1;
  // Every buffer row starts on a 64-byte line (rows padded to whole lines).
  BoxScratch& scratch = ThreadBoxScratch();
  const size_t rn = LineStride<double>(n), on = LineStride<float>(n);
  const size_t en = LineStride<float>(ext_n), edn = LineStride<double>(ext_n);
  size_t ring_total = 0;
  for (Window& w : win) {
    w.capacity = w.k + batch;
    w.total = rows + w.k - 1;
    ring_total += static_cast<size_t>(kPlanes) * w.capacity * rn;
  }
  win[0].ring = Aligned64(scratch.ring, ring_total);
  win[1].ring = win[0].ring + static_cast<size_t>(kPlanes) * win[0].capacity * rn;
  win[0].sum = Aligned64(scratch.sum, 2 * kPlanes * rn);
  std::fill(win[0].sum, win[0].sum + 2 * kPlanes * rn, 0.0);
  win[1].sum = win[0].sum + kPlanes * rn;
  float* const ext = Aligned64(scratch.ext, kPlanes * batch * en);
  double* const ext_d = Aligned64(scratch.ext_d, kPlanes * batch * edn);
  float* const out_rows = Aligned64(scratch.out, kPlanes * on);
  auto slot = [&](const Window& w, int p, int j) {
    return w.ring + (static_cast<size_t>(p) * w.capacity + j % w.capacity) * rn;
  };
  auto ext_row = [&](int p, int b) { return ext + (static_cast<size_t>(p) * batch + b) * en; };
  auto ext_d_row = [&](int p, int b) { return ext_d + (static_cast<size_t>(p) * batch + b) * edn; };
  // The row sums of bordered rows (count of them, from the batch's row `first`) of window w,
  // whose rows start `shift` values into the large window's bordered rows.
  auto row_sums = [&](Window& w, int first, int count, int shift) {
    for (int p = 0; p < kPlanes; ++p) {
      for (int b = first; b < first + count; ++b) {
        const float* e = ext_row(p, b) + shift;
        double* h = slot(w, p, w.produced + b - first);
        if (w.k == 3) {
          BoxDirect3Row(e, h, cn, n);
        } else if (w.k == 5) {
          BoxDirect5Row(e, h, cn, n);
        } else {
          for (int c = 0; c < cn; ++c) {
            double s = 0;
            for (int i = 0; i < w.k; ++i) s += static_cast<double>(e[i * cn + c]);
            h[c] = s;
          }
        }
      }
      if (w.k == 3 || w.k == 5) continue;
      int b = first;
      for (; cn == 1 && b + 8 <= first + count; b += 8) {
        double* h[8];
        for (int r = 0; r < 8; ++r) h[r] = slot(w, p, w.produced + b - first + r);
        BoxRunning8Gray(ext_d_row(p, b) + shift, edn, h, w.k, cols - 1);
      }
      for (; b + 4 <= first + count; b += 4) {
        const int j = w.produced + b - first;
        BoxRunning4(ext_d_row(p, b) + shift, ext_d_row(p, b + 1) + shift,
                    ext_d_row(p, b + 2) + shift, ext_d_row(p, b + 3) + shift, slot(w, p, j),
                    slot(w, p, j + 1), slot(w, p, j + 2), slot(w, p, j + 3), cn, w.k, cols - 1);
      }
      for (; b < first + count; ++b)
        BoxRunning1(ext_d_row(p, b) + shift, slot(w, p, w.produced + b - first), cn, w.k, cols - 1);
    }
    w.produced += count;
  };
  // The column steps that the rows produced so far allow, in order: the first k - 1 rows into the
  // column sums, then one output row per further row.
  auto columns = [&](Window& w, auto& consume, auto& first_plane) {
    while (w.accumulated < w.k - 1 && w.accumulated < w.produced) {
      for (int p = 0; p < kPlanes; ++p)
        BoxAccumulateRow(w.sum + p * rn, slot(w, p, w.accumulated), n);
      ++w.accumulated;
    }
    while (w.accumulated == w.k - 1 && w.emitted < rows && w.emitted + w.k - 1 < w.produced) {
      const int y = w.emitted;
      const float* outs[kPlanes];
      for (int p = 0; p < kPlanes; ++p) {
        float* o = p == 0 ? first_plane(y) : out_rows + p * on;
        BoxColumnRow(w.sum + p * rn, slot(w, p, y + w.k - 1), slot(w, p, y), o, n);
        outs[p] = o;
      }
      consume(y, outs);
      ++w.emitted;
    }
  };
  const int total = win[0].total;
  for (int j0 = 0; j0 < total; j0 += batch) {
    const int count = std::min(batch, total - j0);
    for (int b = 0; b < count; ++b) {
      ProduceBorderedRow<kPlanes>(
          produce, [&](int p) { return ext_row(p, b); }, j0 + b, rows, cols, cn, large, xofs);
      for (int p = 0; p < kPlanes; ++p) WidenRow(ext_row(p, b), ext_d_row(p, b), ext_n);
    }
    row_sums(win[0], 0, count, 0);
    // The small window's rows among these: bordered rows j - offset in [0, its total).
    const int first = std::max(0, offset - j0);
    const int last = std::min(count, offset + win[1].total - j0);  // exclusive
    if (last > first) row_sums(win[1], first, last - first, offset * cn);
    columns(win[1], consume_small, first_small);
    columns(win[0], consume_large, first_large);
  }
}

// A whole image through BoxStream.
template <typename Consume>
void BoxStreamImage(const cv::Mat& src, int radius, double scale, Consume&& consume) {
  const size_t bytes = sizeof(float) * src.cols * src.channels();
  BoxStream<1>(
      src.rows, src.cols, src.channels(), radius, scale,
      [&](int y, float* const* in) { std::memcpy(in[0], src.ptr<float>(y), bytes); },
      std::forward<Consume>(consume));
}

// One row of the data term: u = ((I - S) - veil) / sc and a = sc^2 / variance with
// sc = max(t E, 1e-12), both 0 where masked; a also 0 where I > clip_level (censored).
template <int kChannels>
TURBID_ROW_KERNEL void DataTermRowN(const float* __restrict in, const float* __restrict t,
                                    const float* __restrict e, const float* __restrict sn,
                                    const float* __restrict ve, const float* __restrict var,
                                    const uchar* __restrict mk, float clip_level, int cols,
                                    float* __restrict uu, float* __restrict aa) {
  // The selects as bit masks (max(p, 1e-12) as p < 1e-12 ? 1e-12 : p, the masked values' +0), so
  // that both quotients are formed for every value and the loop has no branch: GCC split sc * sc /
  // var into the two cases of the max, and under trapping math does not form a division that only
  // one branch uses, so it left this loop scalar (two scalar divisions per value).
  constexpr uint32_t kFloor = std::bit_cast<uint32_t>(1e-12f);
  for (int x = 0; x < cols; ++x) {
    const uint32_t keep = mk[x] != 0 ? 0u : ~0u;
    for (int c = 0; c < kChannels; ++c) {
      const int i = x * kChannels + c;
      const float te = t[i] * e[i];
      const uint32_t low = te < 1e-12f ? ~0u : 0u;  // std::max(te, 1e-12f)
      const float sc = std::bit_cast<float>((kFloor & low) | (std::bit_cast<uint32_t>(te) & ~low));
      const float ui = ((in[i] - sn[i]) - ve[i]) / sc;
      const float ai = (sc * sc) / var[i];
      const float high = in[i] > clip_level ? 1.0f : 0.0f;
      uu[i] = std::bit_cast<float>(std::bit_cast<uint32_t>(ui) & keep);
      aa[i] = std::bit_cast<float>(std::bit_cast<uint32_t>(ai) & keep) * (1.0f - high);
    }
  }
}

void DataTermRow(const float* in, const float* t, const float* e, const float* sn, const float* ve,
                 const float* var, const uchar* mk, float clip_level, int ch, int cols, float* uu,
                 float* aa) {
  if (ch == 1) {
    DataTermRowN<1>(in, t, e, sn, ve, var, mk, clip_level, cols, uu, aa);
  } else {
    DataTermRowN<3>(in, t, e, sn, ve, var, mk, clip_level, cols, uu, aa);
  }
}

// Pixels of a row with some channel above clip_level.
TURBID_ROW_KERNEL int CountClippedRow1(const float* __restrict in, float clip_level, int cols) {
  int count = 0;
  for (int x = 0; x < cols; ++x) count += in[x] > clip_level ? 1 : 0;
  return count;
}

int CountClipped(const float* in, float clip_level, int ch, int cols) {
  if (ch == 1) return CountClippedRow1(in, clip_level, cols);
  int count = 0;
  for (int x = 0; x < cols; ++x) {
    bool clipped = false;
    for (int c = 0; c < ch; ++c) clipped = clipped || in[x * ch + c] > clip_level;
    count += clipped ? 1 : 0;
  }
  return count;
}

// One row of LocalSignalVariance's numerator a (z - p)^2 (its box count of [a > 0] is made in
// integers: BoxCount).
TURBID_ROW_KERNEL void NumeratorOnlyRow(const float* __restrict zz, const float* __restrict aa,
                                        const float* __restrict pp, float* __restrict nn, int n) {
  for (int i = 0; i < n; ++i) {
    const float d = zz[i] - pp[i];
    nn[i] = aa[i] * (d * d);
  }
}

// out = p + S w / (S w + 1) (m - p): the shrink of the prior p towards the level mean m.
TURBID_ROW_KERNEL void ShrinkRowTo(const float* __restrict s, const float* __restrict w,
                                   const float* __restrict m, const float* __restrict p,
                                   float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) {
    const float sw = s[i] * w[i];
    const float gain = sw / (sw + 1.0f);
    out[i] = p[i] + gain * (m[i] - p[i]);
  }
}

// Per channel, the values of a row with no data (a > 0 false).
void NoDataPerChannel(const float* a, int cols, int ch, long long* none) {
  if (ch == 1) {
    none[0] += NoDataRow(a, cols);
    return;
  }
  for (int x = 0; x < cols; ++x)
    for (int c = 0; c < ch; ++c) none[c] += a[x * ch + c] > 0.0f ? 0 : 1;
}

// The censored values (I > clip_level) of the data term, per row, with their lower bounds on
// rho, (I - 2 sigma - S - veil) / max(t E, 1e-12): row y's are entries row_start[y] ..
// row_start[y + 1] - 1 (value index within the row, bound).
struct Censored {
  std::vector<int> row_start, index;
  std::vector<float> bound;
};

// x + 0 where x is finite, NaN elsewhere: the unclipped branch of the censoring step (its
// factor 0 times a finite difference).
TURBID_ROW_KERNEL void KeepFiniteRow(const float* __restrict x, float* __restrict out, int n) {
  // As bit masks, so that the sum is formed for every value and the loop has no branch.
  constexpr uint32_t kQuietNan = std::bit_cast<uint32_t>(std::numeric_limits<float>::quiet_NaN());
  for (int i = 0; i < n; ++i) {
    const uint32_t kept = std::bit_cast<uint32_t>(x[i] + 0.0f);
    const uint32_t finite = (std::bit_cast<uint32_t>(x[i]) & 0x7f800000u) != 0x7f800000u ? ~0u : 0u;
    out[i] = std::bit_cast<float>((kept & finite) | (kQuietNan & ~finite));
  }
}

// The censoring step on one row: listed values raised onto their bound, x + (max(x, bound) -
// x); the others x + 0 (KeepFiniteRow).
void CensorRow(const Censored& c, int y, const float* x, float* out, int n) {
  KeepFiniteRow(x, out, n);
  for (int j = c.row_start[y]; j < c.row_start[y + 1]; ++j) {
    const int i = c.index[j];
    out[i] = x[i] + (std::max(x[i], c.bound[j]) - x[i]);
  }
}

using DeblurStats = oracle_internal::DetailSums;

// One gray row of DetailAndStats: d = e - p, and over the values not masked the sums of v, d and
// d^2 in four partial sums, value x into sum x mod 4 (the partial sums side by side: one vector
// of four doubles each; a masked value adds +0, which leaves a sum started at +0 unchanged).
// Returns how many values are not masked.
TURBID_ROW_KERNEL int DetailStatsRow1(const float* __restrict e, const float* __restrict p,
                                      const float* __restrict v, const uchar* __restrict m,
                                      float* __restrict d, double* __restrict sp,
                                      double* __restrict sd, double* __restrict sq, int n) {
  for (int i = 0; i < n; ++i) d[i] = e[i] - p[i];
  // The four partial sums as one vector each (GCC vector extensions; masked values as +0 by
  // a bit mask).
  using V4d = double __attribute__((vector_size(32)));
  using V4f = float __attribute__((vector_size(16)));
  using V4l = int64_t __attribute__((vector_size(32)));
  V4d vp = {sp[0], sp[1], sp[2], sp[3]}, vd = {sd[0], sd[1], sd[2], sd[3]};
  V4d vq = {sq[0], sq[1], sq[2], sq[3]};
  V4l kept = {0, 0, 0, 0};
  int x = 0;
  for (; x + 4 <= n; x += 4) {
    V4f vf, df;
    std::memcpy(&vf, v + x, sizeof(vf));
    std::memcpy(&df, d + x, sizeof(df));
    const V4l keep = V4l{m[x], m[x + 1], m[x + 2], m[x + 3]} == 0;  // all ones where kept
    const V4d vv = __builtin_convertvector(vf, V4d), dd = __builtin_convertvector(df, V4d);
    const V4d dd2 = dd * dd;
    vp += reinterpret_cast<V4d>(reinterpret_cast<V4l>(vv) & keep);
    vd += reinterpret_cast<V4d>(reinterpret_cast<V4l>(dd) & keep);
    vq += reinterpret_cast<V4d>(reinterpret_cast<V4l>(dd2) & keep);
    kept -= keep;
  }
  int count = 0;
  for (int k = 0; k < 4; ++k) {
    sp[k] = vp[k];
    sd[k] = vd[k];
    sq[k] = vq[k];
    count += static_cast<int>(kept[k]);
  }
  for (; x < n; ++x) {
    if (m[x] != 0) continue;
    const int k = x & 3;
    const double dd = d[x];
    sp[k] += v[x];
    sd[k] += dd;
    sq[k] += dd * dd;
    ++count;
  }
  return count;
}

// One row of the detail d = e - p (float) and of DeblurStats (cols pixels, ch channels). Four
// partial sums per quantity for one channel (independent chains).
void DetailStatsRow(const float* e, const float* p, const float* v, const uchar* m, float* d,
                    int cols, int ch, DeblurStats& st) {
  const int n = cols * ch;
  if (ch == 1) {
    double sp[4] = {0, 0, 0, 0}, sd[4] = {0, 0, 0, 0}, sq[4] = {0, 0, 0, 0};
    st.count += DetailStatsRow1(e, p, v, m, d, sp, sd, sq, n);
    st.posterior[0] += (sp[0] + sp[1]) + (sp[2] + sp[3]);
    st.detail[0] += (sd[0] + sd[1]) + (sd[2] + sd[3]);
    st.detail_sq[0] += (sq[0] + sq[1]) + (sq[2] + sq[3]);
    return;
  }
  for (int i = 0; i < n; ++i) d[i] = e[i] - p[i];
  for (int x = 0; x < cols; ++x) {
    if (m[x] != 0) continue;
    for (int c = 0; c < ch; ++c) {
      const double dd = d[x * ch + c];
      st.posterior[c] += v[x * ch + c];
      st.detail[c] += dd;
      st.detail_sq[c] += dd * dd;
    }
    ++st.count;
  }
}

// HierarchicalMmse's optional output: detail = est - prior and its sums over the pixels not
// masked (OracleEnhance's Wiener ratio), made as the estimate's rows are.
struct DetailOut {
  cv::Mat masked;  // CV_8UC1, 255 = masked
  cv::Mat detail;  // the estimate's size and type
  DeblurStats sums;
};

// Box counts of [a > 0] over (2 radius + 1)^2 windows, reflected borders, streamed: Add(a) takes
// the source row of the next bordered row (in BoxStream's order: bordered rows 0, 1, ...),
// Output(y, out) writes output row y (in order of y, once rows up to y + 2 radius are in). The
// counts are integers, exact in any order of summation, so they equal the double box sums of the
// 0 / 1 indicator that they replace (and cost integer adds instead of a third double plane).
class BoxCount {
 public:
  BoxCount(int cols, int cn, int radius)
      : cols_(cols), cn_(cn), k_(2 * radius + 1), n_(cols * cn), capacity_(k_ + 8) {
    xofs_.resize(cols + k_ - 1);
    for (int j = 0; j < cols + k_ - 1; ++j)
      xofs_[j] = cv::borderInterpolate(j - radius, cols, cv::BORDER_REFLECT);
    bordered_.resize(static_cast<size_t>(cols + k_ - 1) * cn);
    prefix_.resize(bordered_.size() + 1);
    ring_.resize(static_cast<size_t>(capacity_) * n_);
    vertical_.assign(n_, 0);
  }
  void Add(const float* a) {
    // The bordered indicator row, then its window sums: direct for small windows, else as
    // differences of prefix sums (integers: any order gives the same counts).
    const int ext_n = (cols_ + k_ - 1) * cn_;
    int32_t* e = bordered_.data();
    IndicatorRow(a, e + (k_ / 2) * cn_, n_);
    FillReflectedBorder(e, cols_, cn_, k_ / 2, xofs_);
    int32_t* h = ring_.data() + static_cast<size_t>(added_ % capacity_) * n_;
    if (k_ <= 9) {
      WindowSumsDirect(e, h, cn_, k_, n_);
    } else {
      int32_t* prefix = prefix_.data();
      PrefixSums(e, prefix, ext_n);
      // Per channel c the window of value i = x cn + c is i, i + cn, ..., i + (k - 1) cn; with
      // one channel the prefix sums give it directly.
      if (cn_ == 1) {
        WindowSumsPrefix(prefix, h, k_, n_);
      } else {
        WindowSumsDirect(e, h, cn_, k_, n_);
      }
    }
    ++added_;
  }
  void Output(int y, float* out) {
    CV_Assert(added_ >= y + k_ && y + k_ + 8 > added_);
    if (y == 0) {
      std::fill(vertical_.begin(), vertical_.end(), 0);
      for (int j = 0; j < k_; ++j) AddRows(vertical_.data(), Row(j), nullptr, n_);
    } else {
      AddRows(vertical_.data(), Row(y + k_ - 1), Row(y - 1), n_);
    }
    IntToFloatRow(vertical_.data(), out, n_);
  }

 private:
  TURBID_ROW_KERNEL static void IndicatorRow(const float* __restrict a, int32_t* __restrict out,
                                             int n) {
    for (int i = 0; i < n; ++i) out[i] = a[i] > 0.0f ? 1 : 0;
  }
  TURBID_ROW_KERNEL static void WindowSumsDirect(const int32_t* __restrict e, int32_t* __restrict h,
                                                 int cn, int k, int n) {
    for (int i = 0; i < n; ++i) h[i] = 0;
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < n; ++i) h[i] += e[i + j * cn];
  }
  // prefix[0] = 0, prefix[i + 1] = prefix[i] + e[i]: eight values per step as an in-register
  // scan (shifts by 1, 2 and 4 lanes, plus the running total; integers, so the same sums as the
  // serial loop, which ran at about one value per cycle).
  TURBID_ROW_KERNEL static void PrefixSums(const int32_t* __restrict e, int32_t* __restrict prefix,
                                           int n) {
    using V8i = int32_t __attribute__((vector_size(32)));
    const V8i zero = {0, 0, 0, 0, 0, 0, 0, 0};
    V8i total = zero;
    prefix[0] = 0;
    int i = 0;
    for (; i + 8 <= n; i += 8) {
      V8i v;
      std::memcpy(&v, e + i, sizeof(v));
      v += __builtin_shufflevector(zero, v, 0, 8, 9, 10, 11, 12, 13, 14);
      v += __builtin_shufflevector(zero, v, 0, 1, 8, 9, 10, 11, 12, 13);
      v += __builtin_shufflevector(zero, v, 0, 1, 2, 3, 8, 9, 10, 11);
      v += total;
      std::memcpy(prefix + i + 1, &v, sizeof(v));
      total = __builtin_shufflevector(v, v, 7, 7, 7, 7, 7, 7, 7, 7);
    }
    for (; i < n; ++i) prefix[i + 1] = prefix[i] + e[i];
  }
  TURBID_ROW_KERNEL static void WindowSumsPrefix(const int32_t* __restrict prefix,
                                                 int32_t* __restrict h, int k, int n) {
    for (int i = 0; i < n; ++i) h[i] = prefix[i + k] - prefix[i];
  }
  TURBID_ROW_KERNEL static void AddRows(int32_t* __restrict v, const int32_t* __restrict add,
                                        const int32_t* __restrict sub, int n) {
    if (sub == nullptr) {
      for (int i = 0; i < n; ++i) v[i] += add[i];
    } else {
      for (int i = 0; i < n; ++i) v[i] += add[i] - sub[i];
    }
  }
  TURBID_ROW_KERNEL static void IntToFloatRow(const int32_t* __restrict v, float* __restrict out,
                                              int n) {
    for (int i = 0; i < n; ++i) out[i] = static_cast<float>(v[i]);
  }
  const int32_t* Row(int j) const { return ring_.data() + static_cast<size_t>(j % capacity_) * n_; }
  int cols_, cn_, k_, n_, capacity_;
  int added_ = 0;
  std::vector<int> xofs_;
  std::vector<int32_t> bordered_, prefix_, ring_, vertical_;
};

// Row buffers of HierarchicalMmse's streams (per thread, kept between calls).
struct MmseRows {
  std::vector<float> has, s, e, post, est;
};

MmseRows& ThreadMmseRows(int n) {
  thread_local MmseRows rows;
  for (std::vector<float>* v : {&rows.has, &rows.s, &rows.e, &rows.post, &rows.est})
    v->resize(std::max<size_t>(v->size(), static_cast<size_t>(n)));
  return rows;
}

// Local signal variance around the prior mean p of values z whose noise variances are 1 / a (a =
// 0: no data): max(box(a (z - p)^2) - box([a > 0]), 0) / box(a) over windows of `radius`.
// Unbiased for independent samples (E a (z - p)^2 = a S + 1). no_data: how many values of a
// have a > 0 false. Streamed: the box sums of a, of the numerator and (where some value has no
// data) of [a > 0] exist only as rows; consume(y) is called once row y of the variance is in
// s_row(y), in order of y. p_row(y): row y of p (asked for once or more per row, before the
// variance's row y). With data everywhere the box count of [a > 0] is the full (2r + 1)^2 window
// (reflected borders), a small integer, exact whatever the summation.
template <typename PRow, typename SRow, typename Consume>
void LocalSignalVariance(const cv::Mat& z, const cv::Mat& a, PRow&& p_row, int radius,
                         long long no_data, SRow&& s_row, Consume&& consume) {
  const int n = z.cols * z.channels();
  const size_t bytes = sizeof(float) * n;
  MmseRows& rows = ThreadMmseRows(n);
  const float full = static_cast<float>((2 * radius + 1) * (2 * radius + 1));
  if (no_data == 0) {
    BoxStream<2>(
        z.rows, z.cols, z.channels(), radius, 1.0,
        [&](int y, float* const* in) {
          std::memcpy(in[0], a.ptr<float>(y), bytes);
          NumeratorOnlyRow(z.ptr<float>(y), a.ptr<float>(y), p_row(y), in[1], n);
        },
        [&](int y, const float* const* o) {
          float* s = s_row(y);
          if (SignalVarianceRowFull(o[1], o[0], full, s, n) > 0)
            FixScalarLoopNans(z.rows, z.cols, z.channels(), y, o[1], o[0], nullptr, full, s);
          consume(y);
        });
  } else {
    // The box count of [a > 0] in integers beside the two double planes (BoxStream asks for its
    // bordered rows once each, in order).
    BoxCount count(z.cols, z.channels(), radius);
    BoxStream<2>(
        z.rows, z.cols, z.channels(), radius, 1.0,
        [&](int y, float* const* in) {
          std::memcpy(in[0], a.ptr<float>(y), bytes);
          NumeratorOnlyRow(z.ptr<float>(y), a.ptr<float>(y), p_row(y), in[1], n);
          count.Add(a.ptr<float>(y));
        },
        [&](int y, const float* const* o) {
          count.Output(y, rows.has.data());
          float* s = s_row(y);
          if (SignalVarianceRow(o[1], o[0], rows.has.data(), s, n) > 0)
            FixScalarLoopNans(z.rows, z.cols, z.channels(), y, o[1], o[0], rows.has.data(), 0, s);
          consume(y);
        });
  }
}

// The linear MMSE estimate of rho from u = rho + noise of variance v (a = 1 / v, 0 where
// masked), under a hierarchical local Gaussian prior (docs/methods.md, "oracle"). Writes the
// prior mean of the finest level to *prior and the posterior variance to *posterior.
// au = a u; a_no_data: how many values of a have a > 0 false; censored (may be null): the
// censoring step applied to the estimate and the prior (OracleMmse). images false: the estimate
// and the posterior variance only as rows (for the detail and its sums; both returned empty).
//
// Level 0 is a per-channel constant (the weighted global mean), level 1 (coarse) shrinks it
// towards the coarse local means with one per-channel signal variance (whole-image sums), level
// 2 (middle) towards the middle local means with the signal variance over coarse windows, and
// the estimate uses the signal variance over pixel windows. Each step is an epilogue of the box
// stream that makes its inputs; only the level means, weights and priors are images (a prior is
// written to a new image, since the stream that reads it re-reads rows for the bottom border).
cv::Mat HierarchicalMmse(const OracleOptions& o, const cv::Mat& u, const cv::Mat& a,
                         const cv::Mat& au, long long a_no_data, const Censored* censored,
                         cv::Mat* prior, cv::Mat* posterior, DetailOut* detail, bool images) {
  const int ch = u.channels();
  const int n = u.cols * ch;
  const size_t bytes = sizeof(float) * n;
  MmseRows& rows = ThreadMmseRows(n);
  // Level 0: the inverse-variance-weighted global mean (0.5 where a channel has no data), in
  // float as setTo stores it, as one row.
  const cv::Scalar sa = cv::sum(a), sau = cv::sum(au);
  std::vector<float> p0(n), s0(n);
  for (int i = 0; i < n; ++i) {
    const int c = i % ch;
    p0[i] = static_cast<float>(sa[c] > 0 ? sau[c] / sa[c] : 0.5);
  }
  // w = box sum of a; m = box sum of a u / max(w, 1e-30), the BLUE of the local mean (noise
  // 1 / w).
  auto level = [&](int y, const float* const* out, const cv::Mat& m) {
    QuotientRow(out[0], out[1], const_cast<cv::Mat&>(m).ptr<float>(y), n);
  };
  auto level_input = [&](int y, float* const* in) {
    std::memcpy(in[0], a.ptr<float>(y), bytes);
    std::memcpy(in[1], au.ptr<float>(y), bytes);
  };
  // The coarse and middle levels from one pass over a and a u (BoxStreamTwoRadii), with the
  // numerator of the coarse level's whole-image signal variance (z = m, weights w, p = the
  // level-0 constant).
  const cv::Mat wc = NewLike(u), mc = NewLike(u), num = NewLike(u);
  const cv::Mat wm = NewLike(u), mm = NewLike(u);
  long long wc_none[4] = {0, 0, 0, 0};
  long long wm_none = 0;
  BoxStreamTwoRadii<2>(
      u.rows, u.cols, ch, o.coarse_radius, o.middle_radius, level_input,
      [&](int y, const float* const* out) {
        level(y, out, mc);
        NumeratorOnlyRow(mc.ptr<float>(y), out[0], p0.data(),
                         const_cast<cv::Mat&>(num).ptr<float>(y), n);
        NoDataPerChannel(out[0], u.cols, ch, wc_none);
      },
      [&](int y, const float* const* out) {
        level(y, out, mm);
        wm_none += NoDataRow(out[0], n);
      },
      [&](int y) { return const_cast<cv::Mat&>(wc).ptr<float>(y); },  // w written in place
      [&](int y) { return const_cast<cv::Mat&>(wm).ptr<float>(y); });
  // max(sum w (m - p)^2 - sum [w > 0], 0) / sum w per channel; the count of [w > 0] is an
  // integer, exact in double whatever the order of its sum.
  const cv::Scalar sw = cv::sum(wc), sn = cv::sum(num);
  const double values = static_cast<double>(u.rows) * u.cols;
  for (int i = 0; i < n; ++i) {
    const int c = i % ch;
    const double sh = values - static_cast<double>(wc_none[c]);
    s0[i] = static_cast<float>(sw[c] > 0 ? std::max(sn[c] - sh, 0.0) / sw[c] : 0.0);
  }
  // The middle level's signal variance over coarse windows around p1, the coarse shrink p1 = p0 +
  // S w / (S w + 1) (m - p0) (w = 0 keeps p), made as the stream first asks for its rows (again
  // for the reflected border: the same values); then the middle shrink into p2.
  // p1 only as a ring of rows (slot y mod ring_rows): the stream asks for source rows at most
  // coarse_radius + its batch (8) rows ahead of the output row it emits, and again near the borders
  // (the same values, made again), so a ring of 2 coarse_radius + 17 rows keeps every row until
  // its output row has read it.
  const cv::Mat p2 = NewLike(u);
  const int ring_rows = 2 * o.coarse_radius + 17;
  thread_local std::vector<float> p1_ring;
  p1_ring.resize(std::max(p1_ring.size(), static_cast<size_t>(ring_rows) * n));
  auto p1_slot = [&](int y) { return p1_ring.data() + static_cast<size_t>(y % ring_rows) * n; };
  auto p1_row = [&](int y) {
    float* row = p1_slot(y);
    ShrinkRowTo(s0.data(), wc.ptr<float>(y), mc.ptr<float>(y), p0.data(), row, n);
    return row;
  };
  LocalSignalVariance(
      mm, wm, p1_row, o.coarse_radius, wm_none, [&](int) { return rows.s.data(); },
      [&](int y) {
        ShrinkRowTo(rows.s.data(), wm.ptr<float>(y), mm.ptr<float>(y), p1_slot(y),
                    const_cast<cv::Mat&>(p2).ptr<float>(y), n);
      });
  // Gain S / (S + v) = S a / (S a + 1), 0 where masked (a = 0); posterior variance
  // S v / (S + v) = S / (S a + 1), S where masked.
  cv::Mat post, est;
  if (images) {
    post = NewLike(u);
    est = NewLike(u);
  }
  auto post_row = [&](int y) { return images ? post.ptr<float>(y) : rows.post.data(); };
  auto est_row = [&](int y) { return images ? est.ptr<float>(y) : rows.est.data(); };
  cv::Mat prior_out = censored != nullptr ? NewLike(u) : p2;
  LocalSignalVariance(
      u, a, [&](int y) { return p2.ptr<float>(y); }, o.pixel_radius, a_no_data, post_row,
      [&](int y) {
        float* s = post_row(y);
        if (censored == nullptr) {
          EstimateRow(a.ptr<float>(y), u.ptr<float>(y), p2.ptr<float>(y), s, est_row(y), n);
        } else {
          EstimateRow(a.ptr<float>(y), u.ptr<float>(y), p2.ptr<float>(y), s, rows.e.data(), n);
          CensorRow(*censored, y, rows.e.data(), est_row(y), n);
          CensorRow(*censored, y, p2.ptr<float>(y), prior_out.ptr<float>(y), n);
        }
        if (detail != nullptr) {
          DetailStatsRow(est_row(y), prior_out.ptr<float>(y), s, detail->masked.ptr<uchar>(y),
                         detail->detail.ptr<float>(y), u.cols, ch, detail->sums);
        }
      });
  *prior = prior_out;
  *posterior = post;
  return est;
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

void BoxFilterReflect(const cv::Mat& source, cv::Mat& dst, int radius, bool normalize) {
  CV_Assert(source.depth() == CV_32F && radius >= 1);
  const cv::Mat src = source;                 // a header of its own: dst may be the same Mat object
  if (dst.data == src.data) dst = cv::Mat();  // rows of src are read after rows of dst are written
  dst.create(src.size(), src.type());
  const int k = 2 * radius + 1;
  const size_t bytes = sizeof(float) * src.cols * src.channels();
  BoxStreamImage(src, radius, normalize ? 1.0 / (k * k) : 1.0, [&](int y, const float* const* out) {
    std::memcpy(dst.ptr<float>(y), out[0], bytes);
  });
}

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

OracleMmseResult OracleMmse(const OracleOptions& o, const cv::Mat& image,
                            const cv::Mat& transmission, const cv::Mat& irradiance,
                            const cv::Mat& snow, const cv::Mat& veil, double shot_gain,
                            double floor_var, double clip_level, bool with_detail) {
  return OracleMmse(
      o, image,
      [&](int y, const float*& t, const float*& e, const float*& sn, const float*& ve) {
        t = transmission.ptr<float>(y);
        e = irradiance.ptr<float>(y);
        sn = snow.ptr<float>(y);
        ve = veil.ptr<float>(y);
      },
      shot_gain, floor_var, clip_level, with_detail);
}

OracleMmseResult OracleMmse(const OracleOptions& o, const cv::Mat& image,
                            const TruthRowFn& truth_row, double shot_gain, double floor_var,
                            double clip_level_d, bool with_detail, bool keep_estimate) {
  const float gain_f = static_cast<float>(shot_gain), floor_f = static_cast<float>(floor_var);

  // u = (I - S - veil) / (t (E_A + E_L)) ~ h * rho, with variance v = var / (t E)^2; a = 1 / v,
  // 0 where masked. Clipped samples (I at 1 in a channel) are not Gaussian data: they get no
  // weight. A sample clipped at 1 still bounds rho from below, (1 - 2 sigma - S - veil) / (t E):
  // the estimate is raised onto that bound where it falls short (docs/methods.md).
  OracleMmseResult r;
  r.masked = internal::PooledMat(image.size(), CV_8UC1);  // made row by row in the stream below
  const cv::Mat& masked = r.masked;
  const float mask_floor = static_cast<float>(o.mask_transmission);  // as cv::compare takes it
  const float clip_level = static_cast<float>(clip_level_d);
  const int ch = image.channels();
  // One streamed pass: the 7 x 7 mean of I (cv::boxFilter's, bit for bit), the variance from it
  // (a row only), the data term, a u, the counts, and the censored values with their bounds
  // (est += (max(est, bound) - est) where clipped, applied as the estimate is made).
  cv::Mat u = NewLike(image), a = NewLike(image), au = NewLike(image);
  int censored = 0;
  long long a_no_data = 0;
  const int n = image.cols * ch;
  thread_local std::vector<float> variance_row;
  variance_row.resize(std::max<size_t>(variance_row.size(), n));
  thread_local Censored clipped;
  clipped.row_start.assign(1, 0);
  clipped.index.clear();
  clipped.bound.clear();
  BoxStreamImage(image, 3, 1.0 / 49.0, [&](int y, const float* const* mean) {
    float* var = variance_row.data();
    NoiseVarianceRow(mean[0], var, gain_f, floor_f, n);
    const float* in = image.ptr<float>(y);
    const float *t = nullptr, *e = nullptr, *sn = nullptr, *ve = nullptr;
    truth_row(y, t, e, sn, ve);
    float* uu = u.ptr<float>(y);
    float* aa = a.ptr<float>(y);
    uchar* mk = const_cast<cv::Mat&>(masked).ptr<uchar>(y);
    r.masked_pixels += MaskRow(t, mask_floor, ch, image.cols, mk);
    DataTermRow(in, t, e, sn, ve, var, mk, clip_level, ch, image.cols, uu, aa);
    const int clipped_here = CountClipped(in, clip_level, ch, image.cols);
    censored += clipped_here;
    for (int i = 0; clipped_here > 0 && i < n; ++i) {
      if (!(in[i] > clip_level)) continue;
      const float sc = std::max(t[i] * e[i], 1e-12f);
      clipped.index.push_back(i);
      clipped.bound.push_back((((in[i] - 2.0f * std::sqrt(var[i])) - sn[i]) - ve[i]) / sc);
    }
    clipped.row_start.push_back(static_cast<int>(clipped.index.size()));
    ProductRow(aa, uu, au.ptr<float>(y), n);
    a_no_data += NoDataRow(aa, n);
  });
  r.censored_pixels = censored;
  DetailOut detail_out;
  if (with_detail) {
    detail_out.masked = masked;
    detail_out.detail = NewLike(image);
  }
  r.estimate = HierarchicalMmse(o, u, a, au, a_no_data, censored > 0 ? &clipped : nullptr, &r.prior,
                                &r.posterior, with_detail ? &detail_out : nullptr,
                                !with_detail || keep_estimate);
  if (with_detail) {
    r.detail = detail_out.detail;
    r.detail_sums = detail_out.sums;
  }
  return r;
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

OracleResult OracleEnhance(const OracleOptions& o, const cv::Mat& image, const Scene& scene,
                           const RenderRecord& sidecar) {
  ThrowIfInvalid(o, "oracle");
  // The truth maps as rows made where the data term reads them (E also as an image for target
  // lit, whose last step multiplies by it).
  const bool lit = o.target == "lit";
  Truth truth = ResolveTruth("oracle", image, scene, sidecar, o.remove_snow, false);
  OracleResult result;
  result.steps = truth.steps;
  const RenderOptions& ro = truth.render;
  // Noise variance of I per pixel (Foi et al. 2008): signal / photons + read^2, plus the
  // quantisation step's 1/12 step^2.
  const bool sensor = ro.sensor.enabled;
  const double read2 = sensor ? ro.sensor.read_noise * ro.sensor.read_noise : 0.0;
  const double gain =
      sensor && ro.sensor.photons_at_white > 0 ? 1.0 / ro.sensor.photons_at_white : 0.0;
  const int bits = ro.camera.bit_depth;
  const double step = bits == 32 ? 0.0 : 1.0 / ((1 << bits) - 1);
  const double floor_var = read2 + step * step / 12.0 + 1e-12;
  // The signal in the shot-noise term is the local mean of I (7x7 box) rather than I itself: a
  // variance read from the noisy value weights the darker draws more and biases every weighted
  // mean low.
  const double half_step = bits == 32 ? 0.0 : 0.5 * step;
  const BlurModel& blur = truth.blur;
  if (lit && truth.irradiance.empty()) truth.irradiance = NewLike(image);
  const int n = image.cols * image.channels();
  thread_local std::vector<float> truth_rows;
  truth_rows.resize(std::max<size_t>(truth_rows.size(), 4 * static_cast<size_t>(n)));
  auto truth_row = [&](int y, const float*& t, const float*& e, const float*& sn,
                       const float*& ve) {
    if (!truth.transmission.empty()) {  // the images (beta = 0)
      t = truth.transmission.ptr<float>(y);
      e = truth.irradiance.ptr<float>(y);
      sn = truth.snow.ptr<float>(y);
      ve = truth.veil.ptr<float>(y);
      return;
    }
    float* e_row = lit ? truth.irradiance.ptr<float>(y) : truth_rows.data();
    float* t_row = truth_rows.data() + n;
    float* sn_row = t_row + n;
    float* ve_row = sn_row + n;
    truth.Rows(y, e_row, t_row, ve_row, sn_row);
    t = t_row;
    e = e_row;
    sn = sn_row;
    ve = ve_row;
  };
  oracle_internal::OracleMmseResult mmse = oracle_internal::OracleMmse(
      o, image, truth_row, gain, floor_var, 1.0 - half_step - 1e-7, blur.active && o.deblur,
      /*keep_estimate=*/false);
  result.steps.push_back("noise: variance I / " + std::to_string(ro.sensor.photons_at_white) +
                         " + read^2 + step^2 / 12" + (sensor ? "" : " (sensor off)"));
  result.masked_pixels = mmse.masked_pixels;
  const cv::Mat& masked = mmse.masked;
  cv::Mat est = mmse.estimate, prior = mmse.prior;  // est: empty on the deblur path
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
    // Wiener on the deviation from the prior mean (the signal's mean; smooth, so h * P = P to
    // the blur's width): K = (noise left after the MMSE) / (variance of the deviation), both over
    // the data pixels — the MMSE filter for a white deviation of that variance (Gonzalez & Woods
    // §5.8). A constant-K Wiener on est itself would scale its mean by 1 / (1 + K).
    // detail = est - prior, and over the data pixels the mean of the posterior variance and the
    // variance of detail, made with the estimate's rows (OracleMmse; sums in double, as cv::mean
    // / cv::meanStdDev form them, in another order: the ratio agrees to ~1e-15).
    const cv::Mat& detail = mmse.detail;
    const DeblurStats& stats = mmse.detail_sums;
    double noise = 0, signal = 0;
    for (int c = 0; c < truth.channels; ++c) {
      const double n = static_cast<double>(stats.count);
      const double pm = stats.count > 0 ? stats.posterior[c] / n : 0.0;
      const double mean = stats.count > 0 ? stats.detail[c] / n : 0.0;
      const double var =
          stats.count > 0 ? std::max(stats.detail_sq[c] / n - mean * mean, 0.0) : 0.0;
      noise += pm;
      signal += var;
    }
    result.deblur_nsr = std::clamp(signal > 0 ? noise / signal : 10.0, 1e-8, 10.0);
    DeconvolutionOptions d;
    d.nsr = result.deblur_nsr;
    // est = prior + the deblurred detail, the prior where masked, then the target and the clamp:
    // one pass, fed by the streamed deconvolution where it has one (one kernel, spatial path).
    const Finisher finish{truth.channels, true, lit};
    cv::Mat out = NewLike(image);
    int negative_zeros = 0;
    auto emit = [&](int y, const float* row) {
      negative_zeros +=
          finish(prior.ptr<float>(y), row, masked.ptr<uchar>(y),
                 lit ? truth.irradiance.ptr<float>(y) : nullptr, out.ptr<float>(y), out.cols);
    };
    if (blur.Count() != 1 || blur.depth_dependent ||
        !DeconvolveRows(d, detail, blur.Kernel(0), emit)) {
      std::vector<cv::Mat> per_level;
      for (size_t i = 0; i < blur.Count(); ++i)
        per_level.push_back(Deconvolve(d, detail, blur.Kernel(i)));
      const cv::Mat deblurred = blur.depth_dependent ? blur.Blend(per_level) : per_level[0];
      for (int y = 0; y < out.rows; ++y) emit(y, deblurred.ptr<float>(y));
    }
    result.steps.push_back("deblur: Wiener, NSR " + std::to_string(result.deblur_nsr));
    if (negative_zeros > 0) cv::max(out, 0.0, out);
    result.image = out;
    return result;
  }
  oracle_internal::FinishImage(est, cv::Mat(), masked, lit ? truth.irradiance : cv::Mat(), est);
  result.image = est;
  return result;
}

// ---------------------------------------------------------------------------------------------

namespace {

constexpr const char* kInputs =
    "sidecar: water (beta, E_A, B_inf), LED lights with their power, PSF, snow and seed, sensor "
    "noise and bit depth; scene: depth (range, normals), camera";

MethodEntry OracleExactEntry() {
  const OracleExactOptions d;
  MethodEntry e;
  e.info.name = "oracle_exact";
  e.info.summary = "algebraic inverse of the simulator with every true parameter (no noise model)";
  e.info.source = "turbid's forward model (docs/model.md), paper eq. 2";
  e.info.needs_geometry = true;
  e.info.needs_sidecar = true;
  e.info.privileged = true;
  e.info.inputs = kInputs;
  e.info.params = {
      Param("target", d.target, "clean: recover rho (ground truth) | lit: recover J"),
      Param("remove_snow", d.remove_snow, "re-render the marine snow from the seed and subtract"),
      Param("min_transmission", d.min_transmission, "floor on t when dividing, (0, 1]"),
      Param("min_irradiance", d.min_irradiance, "floor on E_A + E_L when dividing, > 0"),
      Param("max_iterations", d.max_iterations,
            "range-dependent PSF: fixed-point iterations, [1, 1000]"),
      Param("tolerance", d.tolerance, "range-dependent PSF: residual to stop at, [0, 1]"),
  };
  e.run = [](const nlohmann::json& params, const EnhanceInput& in) {
    OracleExactOptions o;
    ParamBinder b("oracle_exact", params);
    b.Bind("target", &o.target);
    b.Bind("remove_snow", &o.remove_snow);
    b.Bind("min_transmission", &o.min_transmission);
    b.Bind("min_irradiance", &o.min_irradiance);
    b.Bind("max_iterations", &o.max_iterations);
    b.Bind("tolerance", &o.tolerance);
    b.Finish(o);
    if (in.scene == nullptr) throw Error("oracle_exact: needs the scene (--scene)");
    if (in.sidecar == nullptr) throw Error("oracle_exact: needs the render's sidecar (--sidecar)");
    return OracleExactEnhance(o, in.image, *in.scene, *in.sidecar).image;
  };
  return e;
}

MethodEntry OracleEntry() {
  const OracleOptions d;
  MethodEntry e;
  e.info.name = "oracle";
  e.info.summary =
      "MMSE inverse of the simulator with every true parameter and the noise model (the ceiling)";
  e.info.source =
      "turbid's forward model (docs/model.md); adaptive Wiener (Lee 1980, Kuan et al. 1985) with "
      "the Poisson-Gaussian variance (Foi et al. 2008); Wiener deconvolution";
  e.info.needs_geometry = true;
  e.info.needs_sidecar = true;
  e.info.privileged = true;
  e.info.inputs = kInputs;
  e.info.params = {
      Param("target", d.target, "clean: recover rho (ground truth) | lit: recover J"),
      Param("remove_snow", d.remove_snow, "re-render the marine snow from the seed and subtract"),
      Param("mask_transmission", d.mask_transmission,
            "pixels with t below this are masked (prior mean), (0, 1)"),
      Param("coarse_radius", d.coarse_radius, "prior's coarse window radius, px",
            SizeBound::kRadius),
      Param("middle_radius", d.middle_radius, "prior's middle window radius, px (< coarse)",
            SizeBound::kRadius),
      Param("pixel_radius", d.pixel_radius, "window of the per-pixel prior variance, px",
            SizeBound::kRadius),
      Param("deblur", d.deblur, "Wiener deconvolution of the true PSF after the MMSE estimate"),
  };
  e.run = [](const nlohmann::json& params, const EnhanceInput& in) {
    OracleOptions o;
    ParamBinder b("oracle", params);
    b.Bind("target", &o.target);
    b.Bind("remove_snow", &o.remove_snow);
    b.Bind("mask_transmission", &o.mask_transmission);
    b.Bind("coarse_radius", &o.coarse_radius);
    b.Bind("middle_radius", &o.middle_radius);
    b.Bind("pixel_radius", &o.pixel_radius);
    b.Bind("deblur", &o.deblur);
    b.Finish(o);
    if (in.scene == nullptr) throw Error("oracle: needs the scene (--scene)");
    if (in.sidecar == nullptr) throw Error("oracle: needs the render's sidecar (--sidecar)");
    return OracleEnhance(o, in.image, *in.scene, *in.sidecar).image;
  };
  return e;
}

}  // namespace

std::vector<MethodEntry> OracleMethodEntries() { return {OracleEntry(), OracleExactEntry()}; }

}  // namespace turbid
