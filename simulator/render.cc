#include "simulator/render.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <utility>

#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/image_pool.h"
#include "simulator/kernels.h"
#include "simulator/psf_small_angle.h"
#include "simulator/render_plan.h"
#include "simulator/veil.h"
#include "simulator/wide_kernel.h"
#include "turbid_version.h"

namespace turbid {
namespace {

using nlohmann::json;

// ---- rendering helpers --------------------------------------------------------------------------

// Range along the viewing ray for one row: r = z sqrt(dx^2 + dy^2 + 1) in double, as
// RangeFromDepth computes it (same bytes), with dx^2 per column precomputed.
TURBID_ROW_KERNEL void RangeRow(const float* z, const double* dx2, double dy2, int width,
                                float* r) {
  for (int x = 0; x < width; ++x) r[x] = static_cast<float>(z[x] * std::sqrt(dx2[x] + dy2 + 1.0));
}

// Smallest and largest non-NaN value of rows of ranges (all > 0) and how many there are. Positive
// floats order like their bit patterns, so the reductions run on integers (vectorisable without
// fast-math); NaN lanes are replaced by the neutral element.
struct RangeStats {
  uint32_t lo = std::numeric_limits<uint32_t>::max();
  uint32_t hi = 0;
  int64_t count = 0;
  // Values that are neither NaN nor positive and finite: zero, negative or infinite depth (or a
  // finite depth so large that the range overflows), which Scene::Validate decides on.
  int64_t suspect = 0;
};

TURBID_ROW_KERNEL void RangeStatsRow(const float* r, int width, RangeStats* stats) {
  // As unsigned integers, valid ranges lie in (0, 0x7f800000] (+inf at most) and every NaN above:
  // the minimum ignores NaN by itself, the maximum masks it to 0. One reduction per loop.
  const uint32_t* bits = reinterpret_cast<const uint32_t*>(r);  // NOLINT: float bits
  constexpr uint32_t kInf = 0x7f800000u;
  uint32_t lo = stats->lo, hi = stats->hi;
  int count = 0;
  for (int x = 0; x < width; ++x) lo = std::min(lo, bits[x]);
  for (int x = 0; x < width; ++x)
    hi = std::max(hi, bits[x] & (0u - static_cast<uint32_t>(bits[x] <= kInf)));
  for (int x = 0; x < width; ++x) count += bits[x] <= kInf;
  // Positive finite is bits in [1, 0x7f7fffff]; NaN is (bits & 0x7fffffff) > 0x7f800000.
  int suspect = 0;
  for (int x = 0; x < width; ++x) {
    suspect += static_cast<int>(bits[x] - 1u >= 0x7f7fffffu) &
               static_cast<int>((bits[x] & 0x7fffffffu) <= kInf);
  }
  stats->lo = lo;
  stats->hi = hi;
  stats->count += count;
  stats->suspect += suspect;
}

// J = (E_A + E_L) rho for one row; e == nullptr: no artificial light.
template <int kChannels>
TURBID_WIDE_KERNEL void LitRow(const float* rho, const float* e, const float* ambient, int width,
                               float* out) {
  if (!e) {
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < kChannels; ++c)
        out[x * kChannels + c] = (ambient[c] + 0.0f) * rho[x * kChannels + c];
    return;
  }
  for (int x = 0; x < width; ++x)
    for (int c = 0; c < kChannels; ++c)
      out[x * kChannels + c] = (ambient[c] + e[x * kChannels + c]) * rho[x * kChannels + c];
}

// The separable PSF on rows of J, vertical pass then horizontal pass, mirrored borders
// (BORDER_REFLECT_101, as ApplyPsf). The kernel is symmetric: k[0] at the centre and k[j] at +-j,
// so each tap pair is added before it is weighted. Sums run in tap order j = 0 .. R.
struct SeparableBlur {
  int radius = 0;
  int channels = 1;
  std::vector<float> k;        // k[0 .. R]
  std::vector<int> row_of;     // source row for rows -R .. H + R - 1 (index + R)
  std::vector<int> column_of;  // source column for columns -R .. -1 and W .. W + R - 1

  SeparableBlur(const Psf& psf, int width, int height, int channels_in)
      : radius(psf.radius_px), channels(channels_in) {
    for (int j = 0; j <= radius; ++j) k.push_back(psf.kernel_1d.at<float>(radius + j));
    for (int y = -radius; y < height + radius; ++y)
      row_of.push_back(cv::borderInterpolate(y, height, cv::BORDER_REFLECT_101));
    for (int x = -radius; x < 0; ++x)
      column_of.push_back(cv::borderInterpolate(x, width, cv::BORDER_REFLECT_101));
    for (int x = width; x < width + radius; ++x)
      column_of.push_back(cv::borderInterpolate(x, width, cv::BORDER_REFLECT_101));
  }
};

// out = k0 c[i] + sum_j k_j (a_j[i] + b_j[i]) with a_j, b_j = rows (vertical) or shifted views of
// one padded row (horizontal); one vectorised pass per tap pair.
TURBID_WIDE_KERNEL void TapCentre(const float* c, float k0, int n, float* out) {
  for (int i = 0; i < n; ++i) out[i] = k0 * c[i];
}

TURBID_WIDE_KERNEL void TapPair(const float* a, const float* b, float kj, int n, float* out) {
  for (int i = 0; i < n; ++i) out[i] += kj * (a[i] + b[i]);
}

// The centre and three tap pairs in one pass (the paper's kernel has R = 3): the same sums in the
// same order as TapCentre and three TapPair passes.
TURBID_WIDE_KERNEL void Taps3(const float* c, const float* a1, const float* b1, const float* a2,
                              const float* b2, const float* a3, const float* b3, const float* k,
                              int n, float* out) {
  for (int i = 0; i < n; ++i)
    out[i] =
        ((k[0] * c[i] + k[1] * (a1[i] + b1[i])) + k[2] * (a2[i] + b2[i])) + k[3] * (a3[i] + b3[i]);
}

// One row of J * h from the 2R + 1 rows of J around it (rows[R] is the centre row, borders
// already mirrored); scratch `padded` has (W + 2R) * C floats.
void BlurRow(const SeparableBlur& blur, const float* const* rows, int width, float* padded,
             float* out) {
  const int r = blur.radius, ch = blur.channels, n = width * ch;
  float* middle = padded + r * ch;
  auto row = [&](int dy) { return rows[r + dy]; };
  if (r == 3) {
    Taps3(row(0), row(-1), row(1), row(-2), row(2), row(-3), row(3), blur.k.data(), n, middle);
  } else {
    TapCentre(row(0), blur.k[0], n, middle);
    for (int j = 1; j <= r; ++j) TapPair(row(-j), row(j), blur.k[j], n, middle);
  }
  for (int i = 0; i < r; ++i) {
    std::copy_n(middle + blur.column_of[i] * ch, ch, padded + i * ch);
    std::copy_n(middle + blur.column_of[r + i] * ch, ch, middle + (width + i) * ch);
  }
  if (r == 3) {
    Taps3(middle, middle - ch, middle + ch, middle - 2 * ch, middle + 2 * ch, middle - 3 * ch,
          middle + 3 * ch, blur.k.data(), n, out);
  } else {
    TapCentre(middle, blur.k[0], n, out);
    for (int j = 1; j <= r; ++j) TapPair(middle - j * ch, middle + j * ch, blur.k[j], n, out);
  }
}

// I = Jb t (no veiling term).
TURBID_WIDE_KERNEL void ComposePlain(const float* jb, const float* t, int n, float* out) {
  for (int i = 0; i < n; ++i) out[i] = jb[i] * t[i];
}

// I = Jb t + (1 - t)(E_L + B_inf). kInPlace: out holds E_L on entry; e == nullptr: E_L = 0.
template <int kChannels, bool kInPlace>
TURBID_WIDE_KERNEL void ComposeVeil(const float* jb, const float* t, const float* e,
                                    const float* bs, int width, float* out) {
  for (int x = 0; x < width; ++x)
    for (int c = 0; c < kChannels; ++c) {
      const int i = x * kChannels + c;
      const float e_value = kInPlace ? out[i] : (e ? e[i] : 0.0f);
      out[i] = jb[i] * t[i] + (1.0f - t[i]) * (e_value + bs[c]);
    }
}

// Model "revised": I = Jb t_D + (1 - t_B)(E_L + B_inf); e may alias out (E_L kept in place) or
// be nullptr (no light).
void ComposeRevised(const float* jb, const float* t_d, const float* t_b, const float* e,
                    const float* bs, int width, int channels, float* out) {
  for (int x = 0; x < width; ++x)
    for (int c = 0; c < channels; ++c) {
      const int i = x * channels + c;
      const float e_value = e ? e[i] : 0.0f;
      out[i] = jb[i] * t_d[i] + (1.0f - t_b[i]) * (e_value + bs[c]);
    }
}

// The veiling term alone, (1 - t)(E_L + B_inf), for the veil map.
void VeilRow(const float* t, const float* e, const float* bs, int width, int channels,
             float* veil) {
  for (int x = 0; x < width; ++x)
    for (int c = 0; c < channels; ++c) {
      const int i = x * channels + c;
      veil[i] = (1.0f - t[i]) * ((e ? e[i] : 0.0f) + bs[c]);
    }
}

// Veil "single_scatter": I = Jb t + (1 - t_B) B_inf + V (t_B = t for the paper model), and the
// veil map (1 - t_B) B_inf + V when asked.
void ComposeSingleScatter(const float* jb, const float* t, const float* t_b, const float* v,
                          const float* bs, int width, int channels, float* out, float* veil) {
  for (int x = 0; x < width; ++x)
    for (int c = 0; c < channels; ++c) {
      const int i = x * channels + c;
      const float added = (1.0f - t_b[i]) * bs[c] + v[i];
      if (veil) veil[i] = added;
      out[i] = jb[i] * t[i] + added;
    }
}

TURBID_ROW_KERNEL void QuantiseRow(float* p, int n, float levels, bool quantise) {
  if (!quantise) {
    for (int i = 0; i < n; ++i) p[i] = std::min(std::max(p[i], 0.0f), 1.0f);
    return;
  }
  for (int i = 0; i < n; ++i) {
    const float v = std::min(std::max(p[i], 0.0f), 1.0f);
    p[i] = static_cast<float>(static_cast<int>(v * levels + 0.5f)) / levels;
  }
}

}  // namespace

// ---- renderer -----------------------------------------------------------------------------------

struct Renderer::Cache {
  std::mutex mutex;
  double min_range = 0.0, max_range = 0.0;
  int valid_pixels = 0;
  cv::Mat normals;  // computed once when the scene has none
};

namespace {

// The optical thickness of each pixel's ray per channel, -ln t of the direct signal: beta_c r, or
// beta^D_c(r) r with Sea-thru's range-dependent coefficient. NaN where the range is NaN.
cv::Mat ThicknessMap(const Decisions& d, const cv::Mat& range_m, int channels) {
  if (!d.sea_thru) return ThicknessFromRange(range_m, d.beta);
  std::vector<float> coefficients[4];  // a, b, c, d in float, as pass B uses them
  const std::vector<double>* from[4] = {&d.sea_a, &d.sea_b, &d.sea_c, &d.sea_d};
  for (int k = 0; k < 4; ++k) coefficients[k].assign(from[k]->begin(), from[k]->end());
  cv::Mat out(range_m.size(), CV_32FC(channels));
  for (int y = 0; y < range_m.rows; ++y)
    SeaThruThicknessRow(range_m.ptr<float>(y), range_m.cols, channels, coefficients[0].data(),
                        coefficients[1].data(), coefficients[2].data(), coefficients[3].data(),
                        out.ptr<float>(y));
  return out;
}

RenderRecord::Turbidity TurbidityRecord(const TurbidityPsf& plan) {
  RenderRecord::Turbidity t;
  t.levels = plan.thickness.size();
  t.exact = plan.exact;
  t.thickness = plan.thickness;
  for (const Psf& g : plan.glow) t.radius_px.push_back(g.radius_px);
  return t;
}

}  // namespace

Renderer::Renderer(const Scene& scene) : scene_(scene), cache_(std::make_unique<Cache>()) {
  // The depth values are checked by the range pass below (a depth that is not NaN and not
  // positive and finite gives a range that is not either); Validate runs only to name the pixel.
  scene_.ValidateLayout();
  // The range map as RangeFromDepth computes it, and its statistics, in one vectorised pass.
  const CameraIntrinsics& camera = scene_.camera;
  const cv::Mat& depth = scene_.depth_m;
  range_m_ = internal::PooledMat(depth.size(), CV_32FC1);
  std::vector<double> dx2(depth.cols);
  for (int x = 0; x < depth.cols; ++x) {
    const double dx = (x - camera.cx) / camera.fx;
    dx2[x] = dx * dx;
  }
  RangeStats stats;
  for (int y = 0; y < depth.rows; ++y) {
    const double dy = (y - camera.cy) / camera.fy;
    RangeRow(depth.ptr<float>(y), dx2.data(), dy * dy, depth.cols, range_m_.ptr<float>(y));
    RangeStatsRow(range_m_.ptr<float>(y), depth.cols, &stats);
  }
  if (stats.suspect > 0 || stats.count == 0) scene_.Validate();  // throws for a bad depth
  const float lo = std::bit_cast<float>(stats.lo), hi = std::bit_cast<float>(stats.hi);
  cache_->min_range = stats.count ? lo : std::numeric_limits<double>::infinity();
  cache_->max_range = stats.count ? hi : 0.0;
  cache_->valid_pixels = static_cast<int>(stats.count);
}

Renderer::~Renderer() = default;

const Scene& Renderer::scene() const { return scene_; }
const cv::Mat& Renderer::range_m() const { return range_m_; }

RenderPlan Renderer::Plan(const RenderOptions& options) const {
  return Decide(options, scene_, cache_->min_range, cache_->max_range).plan;
}

// The record of a render: everything used, after defaults and preset resolution, and what was
// derived (the sidecar).
namespace {

// The depth statistics a Renderer keeps (range of the valid pixels and how many there are).
struct RangeSummary {
  double min_range = 0.0, max_range = 0.0;
  int valid_pixels = 0;
};

RenderRecord MakeRecord(const Scene& scene_, const RangeSummary& range,
                        const RenderOptions& options, const Decisions& d,
                        const TurbidityPsf* turbidity, const internal::SnowSplats& snow) {
  RenderRecord r;
  r.version = TURBID_VERSION;
  const int channels = scene_.channels();
  r.scene.name = scene_.name;
  r.scene.width = scene_.image.cols;
  r.scene.height = scene_.image.rows;
  r.scene.channels = channels;
  r.scene.fx = scene_.camera.fx;
  r.scene.fy = scene_.camera.fy;
  r.scene.cx = scene_.camera.cx;
  r.scene.cy = scene_.camera.cy;
  for (const auto& [path, hash] : scene_.input_hashes) r.scene.input_hashes[path] = hash;
  r.seed = options.seed;
  r.options = d.used;
  RenderRecord::Derived& out = r.derived;
  out.channel_order = channels == 3 ? "BGR" : "gray";
  out.model = ImageModelName(options.model);
  out.beta_per_m = d.beta;
  if (d.revised) out.beta_b_per_m = d.beta_b;
  if (d.backscatter_on) out.backscatter = d.backscatter;
  out.ambient = d.ambient;
  for (const LightOptions& l : options.light.lights)
    out.lambertian_order_m.push_back(LambertianOrder(l.half_power_angle_deg));
  out.range_min_m = range.min_range;
  out.range_max_m = range.max_range;
  out.valid_depth_fraction = static_cast<double>(range.valid_pixels) / scene_.image.size().area();
  out.psf.p = d.psf.p;
  out.psf.sigma_px = d.psf.sigma_px;
  out.psf.scale_a_px = d.psf.scale_a_px;
  out.psf.radius_px = d.psf.radius_px;
  out.psf.tail_mass_outside = d.psf.tail_mass_outside;
  out.psf.is_delta = d.psf.is_delta || !options.psf.enabled;
  out.psf.separable = d.psf.separable;
  if (turbidity) out.psf.turbidity = TurbidityRecord(*turbidity);
  out.snow_particles = snow.particles;
  out.snow_visible = snow.visible;
  r.plan = d.plan;
  r.encoding = CameraEncodingName(options.camera.FileEncoding());
  return r;
}

}  // namespace

namespace {

// Pass A's scratch for one band: light geometry of one row.
struct RowAScratch {
  std::vector<float> l, g, cos;
  std::vector<float> coded;  // model uwcnn, domain encoded: rho as 8-bit sRGB codes / 255
};

// One render: the state its two passes share. Two passes over the rows, each fusing what used to
// be whole-image steps (docs/model.md has the model, docs/performance-simulator.md the figures):
//   A: light geometry -> E_L -> J = (E_A + E_L) rho, written to lit;
//   B: J * h -> t -> I = Jb t + (1 - t)(E_L + B_inf) -> snow -> sensor noise -> clip/quantise.
// E_L reaches pass B through the output image's own rows (overwritten in place), or through
// the light map when that is asked for. Every row is computed from its inputs alone, so the
// bytes do not depend on the thread count.
struct RenderPass {
  const Scene& scene;
  const cv::Mat& range_m;
  const RenderOptions& options;
  const Decisions& d;
  const RangeSummary range;
  const int channels, width, per_row;
  const cv::Size size;
  bool backscatter = false, veil_term = false, keep_light = false;
  cv::Mat image, lit, light_map, t_map, veil, noise_map;
  cv::Mat scatter_veil;  // V of veil "single_scatter" (simulator/veil.h)
  bool e_in_map = false, e_in_image = false;  // where pass A leaves E_L
  // Pass A.
  cv::Mat normals;
  std::vector<internal::LightRowConstants> lights;
  internal::LightRowContext light_context;
  float ambient[3] = {0, 0, 0}, neg_beta[3] = {0, 0, 0};
  // J * h: the separable kernel row by row in pass B; other kernels on the whole image.
  std::optional<SeparableBlur> blur;
  bool whole_image_blur = false, stream = false;
  int radius = 0;
  double stripes = 1.0;
  cv::Mat blurred;                        // J * h when it is not computed row by row
  std::optional<TurbidityPsf> turbidity;  // the per-pixel kernels (psf.turbidity_dependent)
  // Pass B.
  internal::SnowSplats snow;
  bool snowing = false, sensor = false, open_water = false, quantise = false, srgb = false;
  float bs[3] = {0, 0, 0}, t_const[3] = {0, 0, 0}, open_bs[3] = {0, 0, 0};
  float sea_values[4][3] = {};
  float levels = 255.0f;

  RenderPass(const Scene& scene_in, const cv::Mat& range_in, const RenderOptions& options_in,
             const Decisions& d_in, RangeSummary range_in_summary)
      : scene(scene_in),
        range_m(range_in),
        options(options_in),
        d(d_in),
        range(range_in_summary),
        channels(scene_in.channels()),
        width(scene_in.image.cols),
        per_row(scene_in.image.cols * scene_in.channels()),
        size(scene_in.image.size()) {}

  void AllocateOutputs();
  void PrepareLight(const cv::Mat& scene_normals);
  void PlanBlur();
  void WholeImagePassA();
  void PreparePassB();
  RowAScratch MakeScratch() const;
  void RowA(int y, RowAScratch& scratch, float* e_out, float* lit_out);
  float* ETarget(int y, float* scratch);
  void BandB(const cv::Range& rows);
  void ComposeRow(int y, const float* jb, float* t_row, float* tb_row, float* out);
  void FinishRow(int y, float* scratch, float* out);
};

void RenderPass::AllocateOutputs() {
  const int type = scene.image.type();
  backscatter = d.backscatter_on && !d.zero_beta;
  veil_term = !d.zero_beta && (d.any_light || backscatter);
  keep_light = d.any_light && veil_term && !d.single_scatter;  // E_L needed again in pass B
  image = internal::PooledMat(size, type), lit = internal::PooledMat(size, type);
  if (options.maps.light || (keep_light && options.maps.veil))
    light_map = d.any_light ? cv::Mat(size, type) : cv::Mat(size, type, cv::Scalar::all(0));
  if (options.maps.transmission)
    t_map = d.zero_beta ? cv::Mat(size, CV_32FC(channels), cv::Scalar::all(1))
                        : cv::Mat(size, CV_32FC(channels));
  if (options.maps.veil) veil = cv::Mat(size, CV_32FC(channels), cv::Scalar::all(0));
  if (options.maps.noise) noise_map = cv::Mat(size, CV_32FC(channels));
  // Where pass A leaves E_L: the light map, else the image rows (in place), else nowhere.
  e_in_map = !light_map.empty() && d.any_light;
  e_in_image = keep_light && !e_in_map;
}

void RenderPass::PrepareLight(const cv::Mat& scene_normals) {
  if (d.any_light) {
    normals = scene_normals;
    lights = internal::LightConstantsFor(options.light, channels);
    light_context = internal::LightContextFor(options.light, scene.camera, width);
  }
  for (int c = 0; c < channels; ++c) {
    ambient[c] = static_cast<float>(d.ambient[c]);
    neg_beta[c] = -static_cast<float>(d.beta[c]);
  }
}

RowAScratch RenderPass::MakeScratch() const {
  RowAScratch scratch;
  if (d.any_light) scratch.l.resize(width), scratch.g.resize(width), scratch.cos.resize(5 * width);
  if (d.uwcnn_encoded) scratch.coded.resize(per_row);
  return scratch;
}

// Pass A for one row: E_L into e_out (when there is light) and J into lit_out.
void RenderPass::RowA(int y, RowAScratch& scratch, float* e_out, float* lit_out) {
  float* e = nullptr;
  if (d.any_light) {
    e = e_out;
    const float ray_y = light_context.RayY(scene.camera, y);
    for (size_t k = 0; k < lights.size(); ++k) {
      internal::LightGeometryRow(light_context, lights[k], ray_y, scene.depth_m.ptr<float>(y),
                                 normals.ptr<cv::Vec3f>(y), width, scratch.l.data(),
                                 scratch.g.data(), scratch.cos.data());
      internal::AccumulateLightRow(scratch.l.data(), scratch.g.data(), width, channels, neg_beta,
                                   lights[k].color, k == 0, e);
    }
  }
  const float* rho = scene.image.ptr<float>(y);
  if (d.uwcnn_encoded) {
    UwcnnEncodeRow(rho, per_row, scratch.coded.data());
    rho = scratch.coded.data();
  }
  if (channels == 3)
    LitRow<3>(rho, e, ambient, width, lit_out);
  else
    LitRow<1>(rho, e, ambient, width, lit_out);
}

// Where pass A leaves E_L of an image row (for pass B), or scratch when pass B does not need it.
float* RenderPass::ETarget(int y, float* scratch) {
  return e_in_map ? light_map.ptr<float>(y) : (e_in_image ? image.ptr<float>(y) : scratch);
}

void RenderPass::PlanBlur() {
  if (d.blur) {
    if (d.psf.separable && !d.psf.kernel_1d.empty() && !options.psf.depth_dependent &&
        !options.psf.turbidity_dependent && options.psf.model == PsfModel::kPaper)
      blur.emplace(d.psf, width, size.height, channels);
    else
      whole_image_blur = true;
  }
  radius = blur ? blur->radius : 0;
  // Streaming (pass A a few rows ahead of pass B in the same band, so J is still in cache when it
  // is blurred) needs the mirrored rows of a band's halo to be single reflections.
  stream = !whole_image_blur && 2 * radius < size.height;
  // Bands of rows (OpenCV's default is one row per task: each band computes its own halo and
  // scratch, so bands are a few per thread, of at least 16 rows).
  stripes =
      std::max(1.0, std::min<double>(4.0 * std::max(cv::getNumThreads(), 1), size.height / 16.0));
}

// Without streaming: pass A over the whole image, then the whole-image blur (if any).
void RenderPass::WholeImagePassA() {
  cv::parallel_for_(
      cv::Range(0, size.height),
      [&](const cv::Range& rows) {
        RowAScratch scratch = MakeScratch();
        std::vector<float> e_scratch(d.any_light ? per_row : 0);
        for (int y = rows.start; y < rows.end; ++y)
          RowA(y, scratch, ETarget(y, e_scratch.data()), lit.ptr<float>(y));
      },
      stripes);
  if (whole_image_blur && options.psf.model == PsfModel::kSmallAngle) {
    blurred = ApplySmallAnglePsf(options.psf, d.psf_water, scene.camera, range_m, lit);
  } else if (whole_image_blur && options.psf.turbidity_dependent) {
    turbidity = PlanTurbidityPsf(options.psf, ThicknessMap(d, range_m, channels));
    blurred = ApplyTurbidityPsf(*turbidity, lit);
  } else if (whole_image_blur) {
    blurred = options.psf.depth_dependent ? ApplyDepthDependentPsf(options.psf, lit, range_m)
                                          : ApplyPsf(d.psf, lit);
  }
}

// Pass B's constants: snow, sensor noise, backscatter, transmission, Sea-thru, camera.
void RenderPass::PreparePassB() {
  IrradianceOptions no_light;
  no_light.lights.clear();
  snowing = options.snow.enabled && options.snow.density_per_m3 > 0.0;
  if (snowing)
    snow = internal::DrawMarineSnow(options.snow, d.lights_used ? options.light : no_light,
                                    scene.camera, range_m, d.beta, d.ambient, options.seed);
  sensor = options.sensor.enabled &&
           (options.sensor.photons_at_white > 0.0 || options.sensor.read_noise > 0.0);
  for (int c = 0; c < channels; ++c) {
    bs[c] = backscatter ? static_cast<float>(d.backscatter[c]) : 0.0f;
    t_const[c] = static_cast<float>(std::exp(-d.beta[c] * range.min_range));
  }
  // beta = 0: what open water (NaN depth) shows, B_inf when enabled (t = 0 there).
  open_water = d.zero_beta && range.valid_pixels < size.area();
  for (int c = 0; c < channels; ++c)
    open_bs[c] = d.backscatter_on ? static_cast<float>(d.backscatter[c]) : 0.0f;
  if (d.sea_thru) {
    const std::vector<double>* coefficients[4] = {&d.sea_a, &d.sea_b, &d.sea_c, &d.sea_d};
    for (int k = 0; k < 4; ++k)
      for (int c = 0; c < channels; ++c)
        sea_values[k][c] = static_cast<float>((*coefficients[k])[c]);
  }
  if (d.single_scatter)
    scatter_veil = SingleScatterVeilMap(options.light, d.veil_water, scene.camera, range_m);
  levels = options.camera.bit_depth == 8 ? 255.0f : 65535.0f;
  quantise = options.camera.bit_depth != 32;
  srgb = quantise && options.camera.encoding == CameraEncoding::kSrgb;
}

// Pass B over one band of rows (with pass A streamed a few rows ahead when it can be).
void RenderPass::BandB(const cv::Range& rows) {
  const int y0 = rows.start, y1 = rows.end;
  RowAScratch scratch_a = MakeScratch();
  std::vector<float> e_scratch(d.any_light ? per_row : 0);
  std::vector<float> t_row(per_row), jb_row, padded, scratch(per_row);
  std::vector<float> tb_row(d.revised ? per_row : 0);
  if (blur) jb_row.resize(per_row), padded.resize(per_row + 2 * radius * channels);
  // Rows of J outside the band that its blur reads (mirrored at the image borders), computed
  // here rather than shared with the neighbouring band: at most 2R rows.
  std::vector<int> halo_rows;
  std::vector<float> halo;
  if (stream && blur) {
    for (int y = y0 - radius; y < y1 + radius; ++y) {
      const int source = blur->row_of[y + radius];
      if ((source < y0 || source >= y1) &&
          std::find(halo_rows.begin(), halo_rows.end(), source) == halo_rows.end())
        halo_rows.push_back(source);
    }
    halo.resize(halo_rows.size() * per_row);
    for (size_t i = 0; i < halo_rows.size(); ++i)
      RowA(halo_rows[i], scratch_a, e_scratch.data(), halo.data() + i * per_row);
  }
  auto j_row = [&](int source) -> const float* {
    // Without streaming pass A has computed every row of J (a kernel 2R + 1 >= the height
    // reads rows of other bands, reflected as often as it needs).
    if (!stream || (source >= y0 && source < y1)) return lit.ptr<float>(source);
    const size_t i = std::find(halo_rows.begin(), halo_rows.end(), source) - halo_rows.begin();
    return halo.data() + i * per_row;
  };
  std::vector<const float*> tap_rows(2 * radius + 1);
  int next_a = y0;  // next band row pass A has to compute (streaming)
  for (int y = y0; y < y1; ++y) {
    if (stream) {
      // Mirrored rows of a band lie within [y - R, y + R] (single reflections): compute up to
      // y + R.
      for (const int last = std::min(y + radius, y1 - 1); next_a <= last; ++next_a)
        RowA(next_a, scratch_a, ETarget(next_a, e_scratch.data()), lit.ptr<float>(next_a));
    }
    const float* jb = lit.ptr<float>(y);
    if (blur) {
      for (int dy = -radius; dy <= radius; ++dy)
        tap_rows[dy + radius] = j_row(blur->row_of[y + dy + radius]);
      BlurRow(*blur, tap_rows.data(), width, padded.data(), jb_row.data());
      jb = jb_row.data();
    } else if (!blurred.empty()) {
      jb = blurred.ptr<float>(y);
    }
    float* out = image.ptr<float>(y);
    ComposeRow(y, jb, t_row.data(), tb_row.data(), out);
    if (d.uwcnn_encoded) UwcnnDecodeRow(out, per_row);  // the recipe's coded I back to linear
    FinishRow(y, scratch.data(), out);
  }
}

// I of one row from Jb: attenuation, veil (and the t and veil maps).
void RenderPass::ComposeRow(int y, const float* jb, float* t_row, float* tb_row, float* out) {
  float* t_out = t_map.empty() ? nullptr : t_map.ptr<float>(y);
  float* v_out = veil.empty() ? nullptr : veil.ptr<float>(y);
  const float* r = range_m.ptr<float>(y);
  if (d.zero_beta) {
    std::copy(jb, jb + per_row, out);
    // Invalid depth is open water at infinite range: t = 0 there even at beta = 0 (the
    // limit beta -> 0+ taken along the ray), leaving the backscatter B_inf alone.
    if (open_water) {
      for (int x = 0; x < width; ++x) {
        if (r[x] == r[x]) continue;
        for (int c = 0; c < channels; ++c) {
          out[x * channels + c] = open_bs[c];
          if (t_out) t_out[x * channels + c] = 0.0f;
          if (v_out) v_out[x * channels + c] = open_bs[c];
        }
      }
    }
  } else if (d.revised) {
    // Direct transmission (constant or Sea-thru beta^D(r)) and backscatter transmission.
    float* t = t_row;
    if (d.sea_thru)
      SeaThruTransmissionRow(r, width, channels, sea_values[0], sea_values[1], sea_values[2],
                             sea_values[3], t);
    else if (d.iop_tables)
      TabulatedTransmissionRow(r, width, channels, d.direct_table.data(), t);
    else
      TransmissionRows(r, width, d.beta, t);
    if (d.iop_tables)
      TabulatedTransmissionRow(r, width, channels, d.backscatter_table.data(), tb_row);
    else
      TransmissionRows(r, width, d.beta_b, tb_row);
    if (t_out) std::copy(t, t + per_row, t_out);
    if (d.single_scatter) {
      ComposeSingleScatter(jb, t, tb_row, scatter_veil.ptr<float>(y), bs, width, channels, out,
                           v_out);
      return;
    }
    const float* e = e_in_map ? light_map.ptr<float>(y) : (e_in_image ? out : nullptr);
    if (v_out) VeilRow(tb_row, e, bs, width, channels, v_out);
    ComposeRevised(jb, t, tb_row, e, bs, width, channels, out);
  } else {
    float* t = t_row;
    if (d.uwcnn_gray) {
      UwcnnGrayTransmissionRow(r, width, d.uwcnn.gray_neg_beta.data(), d.uwcnn.gray_weight.data(),
                               t);
    } else if (d.uniform_range) {
      for (int x = 0; x < width; ++x)
        for (int c = 0; c < channels; ++c) t[x * channels + c] = r[x] == r[x] ? t_const[c] : 0.0f;
    } else {
      TransmissionRows(r, width, d.beta, t);  // NaN depth: open water, t = 0
    }
    if (t_out) std::copy(t, t + per_row, t_out);
    if (d.single_scatter) {
      ComposeSingleScatter(jb, t, t, scatter_veil.ptr<float>(y), bs, width, channels, out, v_out);
      return;
    }
    const float* e = e_in_map ? light_map.ptr<float>(y) : nullptr;
    if (v_out && veil_term) VeilRow(t, e, bs, width, channels, v_out);
    if (!veil_term)
      ComposePlain(jb, t, per_row, out);
    else if (e_in_image && channels == 3)
      ComposeVeil<3, true>(jb, t, nullptr, bs, width, out);
    else if (e_in_image)
      ComposeVeil<1, true>(jb, t, nullptr, bs, width, out);
    else if (channels == 3)
      ComposeVeil<3, false>(jb, t, e, bs, width, out);
    else
      ComposeVeil<1, false>(jb, t, e, bs, width, out);
  }
}

// Snow, sensor noise (and the noise map), then the camera's clipping and quantisation.
void RenderPass::FinishRow(int y, float* scratch, float* out) {
  float* noise = noise_map.empty() ? nullptr : noise_map.ptr<float>(y);
  if (noise) std::copy(out, out + per_row, noise);
  if (snowing) internal::AddSnowRow(snow, y, width, scratch, out);
  if (sensor) internal::AddSensorNoiseRow(options.sensor, options.seed, y, per_row, out, scratch);
  if (noise)
    for (int i = 0; i < per_row; ++i) noise[i] = out[i] - noise[i];
  const bool swap_rb = options.rgb_image && channels == 3;
  if (srgb && swap_rb) {
    QuantiseEncodedRowSwapRB(out, per_row, CameraEncoding::kSrgb, options.camera.bit_depth);
  } else if (srgb) {
    QuantiseEncodedRow(out, per_row, CameraEncoding::kSrgb, options.camera.bit_depth);
  } else {
    QuantiseRow(out, per_row, levels, quantise);
    if (swap_rb)
      for (int x = 0; x < width; ++x) std::swap(out[3 * x], out[3 * x + 2]);
  }
}

}  // namespace

const cv::Mat& Renderer::Normals() const {
  if (!scene_.normals.empty()) return scene_.normals;
  std::lock_guard<std::mutex> lock(cache_->mutex);
  if (cache_->normals.empty()) cache_->normals = NormalsFromDepth(scene_.camera, scene_.depth_m);
  return cache_->normals;
}

RenderResult Renderer::Render(const RenderOptions& options) const {
  const Decisions d = Decide(options, scene_, cache_->min_range, cache_->max_range);
  const RangeSummary range{cache_->min_range, cache_->max_range, cache_->valid_pixels};
  RenderPass pass(scene_, range_m_, options, d, range);
  pass.AllocateOutputs();
  pass.PrepareLight(d.any_light ? Normals() : cv::Mat());
  pass.PlanBlur();
  if (!pass.stream) pass.WholeImagePassA();
  pass.PreparePassB();
  cv::parallel_for_(
      cv::Range(0, pass.size.height), [&](const cv::Range& rows) { pass.BandB(rows); },
      pass.stripes);

  RenderResult result;
  result.image = pass.image;
  result.lit = pass.lit;
  result.transmission = pass.t_map;
  if (options.maps.light) result.light = pass.light_map;
  result.veil = pass.veil;
  result.noise = pass.noise_map;
  if (options.maps.psf)
    result.psf = d.psf.kernel.empty() ? cv::Mat::ones(1, 1, CV_32F) : d.psf.kernel;
  result.plan = d.plan;
  result.sidecar =
      MakeRecord(scene_, range, options, d, pass.turbidity ? &*pass.turbidity : nullptr, pass.snow);
  return result;
}

RenderResult Render(const RenderOptions& options, const Scene& scene) {
  return Renderer(scene).Render(options);
}

}  // namespace turbid
