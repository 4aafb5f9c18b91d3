#include "enhancer/paper_methods.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "enhancer/counted_sample.h"
#include "enhancer/guided_filter.h"
#include "enhancer/linear_upsample.h"
#include "enhancer/method.h"
#include "enhancer/plane_fit.h"
#include "enhancer/select.h"
#include "enhancer/simd_switch.h"
#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/noise.h"
#include "simulator/psf.h"
#include "simulator/render.h"
#include "simulator/water.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace turbid {
namespace {

void ClampUnit(cv::Mat& m) {
  cv::patchNaNs(m, 0.0);
  cv::min(m, 1.0, m);
  cv::max(m, 0.0, m);
}

bool Fail(std::string* why, const std::string& message) {
  *why = message;
  return false;
}

// Camera for an image: the scene's, else the sidecar's, else a 53-degree pinhole (fx = max side).
CameraIntrinsics ResolveCamera(const cv::Mat& image, const Scene* scene,
                               const RenderRecord* sidecar, std::vector<std::string>* steps) {
  if (scene != nullptr) {
    if (scene->camera.width != image.cols || scene->camera.height != image.rows) {
      throw Error("full: image is " + std::to_string(image.cols) + "x" +
                  std::to_string(image.rows) + " but the scene's camera is " +
                  std::to_string(scene->camera.width) + "x" + std::to_string(scene->camera.height));
    }
    return scene->camera;
  }
  CameraIntrinsics c;
  c.width = image.cols;
  c.height = image.rows;
  if (sidecar != nullptr) {
    const RenderRecord::SceneInfo& s = sidecar->scene;
    c.fx = s.fx, c.fy = s.fy, c.cx = s.cx, c.cy = s.cy;
    if (s.width == image.cols && s.height == image.rows && c.fx != 0 && c.fy != 0) {
      steps->push_back("camera: from the sidecar");
      return c;
    }
  }
  c.fx = c.fy = std::max(image.cols, image.rows);
  c.cx = (image.cols - 1) / 2.0;
  c.cy = (image.rows - 1) / 2.0;
  steps->push_back("camera: none given, assumed pinhole with fx = fy = max(width, height)");
  return c;
}

Plane ResolvePlane(const FullOptions& o, const Scene* scene, const CameraIntrinsics& camera,
                   std::string* source) {
  const std::string& want = o.plane;
  const bool any = want == "auto";
  if (scene != nullptr && (any || want == "dvl") && scene->dvl_points_in_camera.size() >= 3) {
    try {
      *source = "dvl";
      return FitPlaneToPoints(scene->dvl_points_in_camera);
    } catch (const Error&) {
      if (!any) throw;
    }
  }
  if (scene != nullptr && (any || want == "depth") && !scene->depth_m.empty()) {
    try {
      *source = "depth";
      return FitPlaneToDepth(PlaneFitOptions{}, camera, scene->depth_m).plane;
    } catch (const Error&) {
      if (!any) throw;
    }
  }
  if (scene != nullptr && (any || want == "scene") && scene->dominant_plane) {
    *source = "scene";
    return *scene->dominant_plane;
  }
  if (!any && want != "frontal") {
    throw Error("full: plane source '" + want + "' is not available for this input");
  }
  *source = "frontal";
  return Plane{cv::Vec3d(0, 0, -1), o.frontal_distance_m};
}

CameraIntrinsics Downscaled(const CameraIntrinsics& c, int subsample) {
  CameraIntrinsics s = c;
  s.width = std::max(1, (c.width + subsample - 1) / subsample);
  s.height = std::max(1, (c.height + subsample - 1) / subsample);
  const double kx = static_cast<double>(s.width) / c.width;
  const double ky = static_cast<double>(s.height) / c.height;
  s.fx = c.fx * kx, s.fy = c.fy * ky;
  s.cx = (c.cx + 0.5) * kx - 0.5, s.cy = (c.cy + 0.5) * ky - 0.5;
  return s;
}

cv::Mat PlaneDepth(const Plane& plane, const CameraIntrinsics& camera, double max_range_m) {
  cv::Mat z = DepthFromPlane(plane, camera);
  // Rays that miss the plane see open water: the farthest range we consider, as z-depth.
  for (int y = 0; y < z.rows; ++y) {
    float* p = z.ptr<float>(y);
    for (int x = 0; x < z.cols; ++x) {
      const cv::Vec3d ray = camera.Ray(x, y);
      const float zmax = static_cast<float>(max_range_m / cv::norm(ray));
      if (!std::isfinite(p[x]) || p[x] > zmax) p[x] = zmax;
    }
  }
  return z;
}

cv::Mat Upsample(const cv::Mat& small, cv::Size size) {
  if (small.size() == size) return small;
  cv::Mat out;
  cv::resize(small, out, size, 0, 0, cv::INTER_LINEAR);
  return out;
}

// The value at `percentile` (%) of `values` (no NaN), by rank floor(p/100 (n - 1)).
double PercentileOf(std::vector<float>& values, double percentile) {
  const size_t k = static_cast<size_t>(std::floor(percentile / 100.0 * (values.size() - 1)));
  return enhancer_internal::SelectKth<float, uint32_t>(values, k);
}

// I_g (1 - alpha) + I_f alpha as cv::addWeighted computes it for float images: in double, with
// a fused multiply-add where the CPU has one (OpenCV's dispatched kernels use FMA then; its
// baseline ones do not), rounded to float once. Whatever compiler built turbid (clang too: the
// sanitizer build), since OpenCV's choice is made at run time.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx2,fma"))) void AddWeightedRowFma(const float* i_g, const float* i_f,
                                                           double beta, double alpha, float* dst,
                                                           int n) {
  for (int i = 0; i < n; ++i) {
    dst[i] = static_cast<float>(
        std::fma(static_cast<double>(i_g[i]), beta, static_cast<double>(i_f[i]) * alpha));
  }
}
bool CpuHasFma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("fma") && __builtin_cpu_supports("avx2");
}
#else
void AddWeightedRowFma(const float*, const float*, double, double, float*, int) {}
bool CpuHasFma() { return false; }
#endif

void AddWeightedRow(const float* i_g, const float* i_f, double beta, double alpha, float* dst,
                    int n) {
  static const bool fma = CpuHasFma();
  if (fma) {
    AddWeightedRowFma(i_g, i_f, beta, alpha, dst, n);
    return;
  }
  for (int i = 0; i < n; ++i) {
    dst[i] = static_cast<float>(static_cast<double>(i_g[i]) * beta +
                                static_cast<double>(i_f[i]) * alpha);
  }
}

// `simplified`'s colour row in one pass: AddWeightedRow, then ClampUnitRow, in registers (AVX2;
// with FMA where AddWeightedRow uses it). Returns whether every boosted value (before the clamp)
// was finite. `next_dst` (or null): prefetched for writing as the row goes. `stream_dst` (32-byte
// aligned, or null): the clamped values are also written there, with non-temporal stores.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// Four boosted values, double precision, rounded to float once.
__attribute__((target("avx2,fma"))) inline __m128 BoostFma(__m128 g, __m128 f, __m256d beta,
                                                           __m256d alpha) {
  return _mm256_cvtpd_ps(
      _mm256_fmadd_pd(_mm256_cvtps_pd(g), beta, _mm256_mul_pd(_mm256_cvtps_pd(f), alpha)));
}
__attribute__((target("avx2"))) inline __m128 BoostMulAdd(__m128 g, __m128 f, __m256d beta,
                                                          __m256d alpha) {
  return _mm256_cvtpd_ps(_mm256_add_pd(_mm256_mul_pd(_mm256_cvtps_pd(g), beta),
                                       _mm256_mul_pd(_mm256_cvtps_pd(f), alpha)));
}

template <bool kFma>
__attribute__((target("avx2,fma"))) bool BoostClampRowAvx2(const float* i_g, const float* i_f,
                                                           double beta, double alpha, float* dst,
                                                           int n, float* next_dst,
                                                           float* stream_dst) {
  const __m256d vb = _mm256_set1_pd(beta), va = _mm256_set1_pd(alpha);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 max_finite = _mm256_set1_ps(std::numeric_limits<float>::max());
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  __m256 finite = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    if (next_dst != nullptr) __builtin_prefetch(next_dst + i, 1, 3);
    const __m256 g = _mm256_loadu_ps(i_g + i), f = _mm256_loadu_ps(i_f + i);
    const __m128 g0 = _mm256_castps256_ps128(g), f0 = _mm256_castps256_ps128(f);
    const __m128 g1 = _mm256_extractf128_ps(g, 1), f1 = _mm256_extractf128_ps(f, 1);
    const __m128 lo = kFma ? BoostFma(g0, f0, vb, va) : BoostMulAdd(g0, f0, vb, va);
    const __m128 hi = kFma ? BoostFma(g1, f1, vb, va) : BoostMulAdd(g1, f1, vb, va);
    const __m256 v = _mm256_insertf128_ps(_mm256_castps128_ps256(lo), hi, 1);
    finite =
        _mm256_and_ps(finite, _mm256_cmp_ps(_mm256_and_ps(v, abs_mask), max_finite, _CMP_LE_OQ));
    // NaN to 0 (the ordered compare is false for NaN), then std::min(x, 1) = 1 < x ? 1 : x and
    // std::max(m, 0) = m < 0 ? 0 : m (vminps / vmaxps return their second operand unless the
    // first compares less / greater: -0 stays -0, as in ClampUnitRow).
    const __m256 x = _mm256_and_ps(v, _mm256_cmp_ps(v, v, _CMP_ORD_Q));
    const __m256 c = _mm256_max_ps(zero, _mm256_min_ps(one, x));
    _mm256_storeu_ps(dst + i, c);
    if (stream_dst != nullptr) _mm256_stream_ps(stream_dst + i, c);
  }
  bool all_finite = _mm256_movemask_ps(finite) == 0xff;
  for (; i < n; ++i) {
    const double g = i_g[i], f = i_f[i];
    const float v = static_cast<float>(kFma ? std::fma(g, beta, f * alpha) : g * beta + f * alpha);
    all_finite = all_finite && std::isfinite(v);
    const float x = v != v ? 0.0f : v;
    dst[i] = std::max(std::min(x, 1.0f), 0.0f);
    if (stream_dst != nullptr) stream_dst[i] = dst[i];
  }
  return all_finite;
}
#define TURBID_HAVE_BOOST_AVX2 1
#endif

// ClampUnit on one row: NaN to 0 (cv::patchNaNs), then [0, 1].
TURBID_ROW_KERNEL void ClampUnitRow(float* __restrict v, int n) {
  for (int i = 0; i < n; ++i) {
    const float x = v[i] != v[i] ? 0.0f : v[i];
    v[i] = std::max(std::min(x, 1.0f), 0.0f);
  }
}

// ClampUnitRow from `src` into `dst`.
TURBID_ROW_KERNEL void ClampUnitCopyRow(const float* __restrict src, float* __restrict dst, int n) {
  for (int i = 0; i < n; ++i) {
    const float x = src[i] != src[i] ? 0.0f : src[i];
    dst[i] = std::max(std::min(x, 1.0f), 0.0f);
  }
}

// `full`'s exposure and detail steps on one row: j = j * inv_level (convertTo's float product),
// then j + k (I - I_de) as cv::scaleAdd computes it for float images: a fused multiply-add where
// the CPU has one (as above), else a product and a sum.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx2,fma"))) void ExposureDetailRowFma(const float* image,
                                                              const float* denoised,
                                                              float inv_level, float k, float* j,
                                                              int n) {
  for (int i = 0; i < n; ++i) j[i] = std::fma(image[i] - denoised[i], k, j[i] * inv_level);
}
#else
void ExposureDetailRowFma(const float*, const float*, float, float, float*, int) {}
#endif

void ExposureDetailRow(const float* image, const float* denoised, float inv_level, float k,
                       float* j, int n) {
  static const bool fma = CpuHasFma();
  if (fma) {
    ExposureDetailRowFma(image, denoised, inv_level, k, j, n);
    return;
  }
  for (int i = 0; i < n; ++i) j[i] = (image[i] - denoised[i]) * k + j[i] * inv_level;
}

// %g-style number for the step log (0.7, not 0.700000).
std::string FormatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

bool FullOptions::Check(std::string* why) const {
  if (denoise_radius < 1 || denoise_radius > 1000)
    return Fail(why, "denoise_radius must be in [1, 1000]");
  if (!std::isfinite(denoise_eps) || denoise_eps <= 0) return Fail(why, "denoise_eps must be > 0");
  if (light_scaling != "blind" && light_scaling != "range" && light_scaling != "physical") {
    return Fail(
        why, "light_scaling must be 'blind', 'range' or 'physical', got '" + light_scaling + "'");
  }
  if (!std::isfinite(denoise_noise_factor) || denoise_noise_factor < 0 ||
      denoise_noise_factor > 100) {
    return Fail(why, "denoise_noise_factor must be in [0, 100]");
  }
  if (!std::isfinite(light_scale_percentile) || light_scale_percentile <= 0 ||
      light_scale_percentile > 50) {
    return Fail(why, "light_scale_percentile must be in (0, 50]");
  }
  if (!std::isfinite(light_scale_support) || light_scale_support <= 0 || light_scale_support >= 1) {
    return Fail(why, "light_scale_support must be in (0, 1)");
  }
  if (!std::isfinite(keep_detail) || keep_detail < 0 || keep_detail > 10) {
    return Fail(why, "keep_detail must be in [0, 10]");
  }
  if (!std::isfinite(exposure_percentile) || exposure_percentile < 0 || exposure_percentile > 100) {
    return Fail(why, "exposure_percentile must be in [0, 100]");
  }
  if (light_subsample < 1 || light_subsample > 64)
    return Fail(why, "light_subsample must be in [1, 64]");
  if (!std::isfinite(clahe_min_mean) || clahe_min_mean < 0 || clahe_min_mean > 0.6) {
    return Fail(why, "clahe_min_mean must be in [0, 0.6]");
  }
  if (!std::isfinite(beta_per_m) || beta_per_m < 0 || beta_per_m > 10) {
    return Fail(why, "beta_per_m must be in [0, 10]");
  }
  if (beta_source != "auto" && beta_source != "fixed") {
    return Fail(why, "beta_source must be 'auto' or 'fixed', got '" + beta_source + "'");
  }
  if (!std::isfinite(t_min) || t_min <= 0 || t_min > 1) return Fail(why, "t_min must be in (0, 1]");
  if (plane != "auto" && plane != "dvl" && plane != "depth" && plane != "scene" &&
      plane != "frontal") {
    return Fail(why, "plane must be auto, dvl, depth, scene or frontal, got '" + plane + "'");
  }
  if (!std::isfinite(frontal_distance_m) || frontal_distance_m <= 0 || frontal_distance_m > 1000) {
    return Fail(why, "frontal_distance_m must be in (0, 1000]");
  }
  if (!std::isfinite(max_range_m) || max_range_m <= 0 || max_range_m > 1e4) {
    return Fail(why, "max_range_m must be in (0, 1e4]");
  }
  PsfOptions psf;
  psf.optical_thickness = psf_optical_thickness;
  psf.forward_scatter = psf_forward_scatter;
  std::string sub;
  if (!psf.Check(&sub)) return Fail(why, "psf: " + sub);
  if (!deconvolution.Check(&sub)) return Fail(why, "deconvolution: " + sub);
  if (!clahe.Check(&sub)) return Fail(why, "clahe: " + sub);
  return true;
}

namespace {

// The light model's E_L on the plane at 1/subsample, upsampled to `size`: one channel per beta.
// With `rows` and one channel, the map is not upsampled whole: *rows gives its rows (the result
// is then empty).
cv::Mat LightModelMap(const IrradianceOptions& lights, const Plane& plane,
                      const CameraIntrinsics& camera, const std::vector<double>& beta_per_m,
                      cv::Size size, int channels, int subsample, double max_range_m,
                      enhancer_internal::LinearUpsampler* rows = nullptr) {
  if (beta_per_m.size() != 1 && static_cast<int>(beta_per_m.size()) != channels) {
    throw Error("full: " + std::to_string(beta_per_m.size()) + " attenuation values for a " +
                std::to_string(channels) + "-channel image");
  }
  const CameraIntrinsics small = Downscaled(camera, subsample);
  const cv::Mat depth = PlaneDepth(plane, small, max_range_m);
  const cv::Vec3f n(static_cast<float>(plane.normal[0]), static_cast<float>(plane.normal[1]),
                    static_cast<float>(plane.normal[2]));
  const cv::Mat normals(depth.size(), CV_32FC3, cv::Scalar(n[0], n[1], n[2]));
  const cv::Mat map = IrradianceMap(lights, small, depth, normals, beta_per_m);
  if (rows != nullptr && map.channels() == 1) {
    *rows = enhancer_internal::LinearUpsampler(map, size);
    return {};
  }
  return Upsample(map, size);
}

}  // namespace

cv::Mat EstimateArtificialLight(const IrradianceOptions& lights, const Plane& plane,
                                const CameraIntrinsics& camera,
                                const std::vector<double>& beta_per_m, const cv::Mat& reference,
                                bool range_scaling, int subsample, double max_range_m) {
  const int channels = reference.channels();
  std::vector<cv::Mat> e_planes;
  cv::split(LightModelMap(lights, plane, camera, beta_per_m, reference.size(), channels, subsample,
                          max_range_m),
            e_planes);
  // One beta: the same E_L for every channel.
  if (e_planes.size() == 1) e_planes.assign(channels, e_planes[0]);
  if (!range_scaling) {
    cv::Mat merged;
    cv::merge(e_planes, merged);
    return merged;
  }
  std::vector<cv::Mat> ref;
  cv::split(reference, ref);
  std::vector<cv::Mat> out(channels);
  for (int c = 0; c < channels; ++c) {
    double e_lo, e_hi, lo, hi;
    cv::minMaxLoc(e_planes[c], &e_lo, &e_hi);
    cv::minMaxLoc(ref[c], &lo, &hi);
    if (e_hi - e_lo < 1e-12) {
      out[c] = cv::Mat(e_planes[c].size(), CV_32F, cv::Scalar(lo));
    } else {
      e_planes[c].convertTo(out[c], CV_32F, (hi - lo) / (e_hi - e_lo),
                            lo - e_lo * (hi - lo) / (e_hi - e_lo));
    }
  }
  cv::Mat merged;
  cv::merge(out, merged);
  return merged;
}

namespace {

// Least squares of I = c0 t + c1 (1 - t) L + c2 t L over the samples (normal equations in
// double), twice: the second pass drops the 20% largest absolute residuals of the first. Returns
// false when the system is singular or the samples are too few. The normal equations are summed
// sample by sample in order (A^T A is symmetric: its six distinct sums are mirrored).
// One fit sample: t, L and I_de at a grid pixel (the regressors t, (1 - t) L, t L and the
// target are formed from them in double, as VeilRow does).
struct VeilSample {
  float t, l, v;
};
inline cv::Vec4d VeilRow(const VeilSample& s) {
  const double ti = s.t, li = s.l;
  return cv::Vec4d(ti, (1.0 - ti) * li, ti * li, s.v);
}

// The fit's normal equations A^T A c = A^T b solved; false when singular or ill-conditioned
// (near-collinear regressors: constant light or transmission).
bool SolveVeilNormalEquations(const cv::Matx33d& ata, const cv::Vec3d& atb, cv::Vec3d* solution) {
  if (!cv::solve(ata, atb, *solution, cv::DECOMP_CHOLESKY)) return false;
  cv::Vec3d eig;
  cv::eigen(ata, eig);
  return eig[2] > 1e-9 * eig[0];
}

bool FitVeilModel(const std::vector<VeilSample>& samples, cv::Vec3d* c) {
  if (samples.size() < 16) return false;
  std::vector<char> use(samples.size(), 1);
  std::vector<double> residuals(samples.size());
  for (int pass = 0; pass < 2; ++pass) {
    double s00 = 0, s01 = 0, s02 = 0, s11 = 0, s12 = 0, s22 = 0, b0 = 0, b1 = 0, b2 = 0;
    for (size_t i = 0; i < samples.size(); ++i) {
      if (!use[i]) continue;
      const cv::Vec4d x = VeilRow(samples[i]);
      s00 += x[0] * x[0], s01 += x[0] * x[1], s02 += x[0] * x[2];
      s11 += x[1] * x[1], s12 += x[1] * x[2], s22 += x[2] * x[2];
      b0 += x[0] * x[3], b1 += x[1] * x[3], b2 += x[2] * x[3];
    }
    const cv::Matx33d ata(s00, s01, s02, s01, s11, s12, s02, s12, s22);
    const cv::Vec3d atb(b0, b1, b2);
    cv::Vec3d solution;
    if (!SolveVeilNormalEquations(ata, atb, &solution)) return false;
    *c = solution;
    if (pass == 1) break;
    for (size_t i = 0; i < samples.size(); ++i) {
      const cv::Vec4d x = VeilRow(samples[i]);
      residuals[i] = std::abs(solution[0] * x[0] + solution[1] * x[1] + solution[2] * x[2] - x[3]);
    }
    std::vector<double> keys = residuals;
    const double cut = enhancer_internal::SelectKth<double, uint64_t>(keys, keys.size() * 8 / 10);
    for (size_t i = 0; i < samples.size(); ++i) use[i] = residuals[i] <= cut;
  }
  return std::isfinite((*c)[0]) && std::isfinite((*c)[1]) && std::isfinite((*c)[2]);
}

// ---- The three-channel fit with one t and one L map (the default `full` on colour): every grid
// pixel gives each channel the same regressors (t, (1 - t) L, t L), so when every channel keeps
// every pixel the three fits run side by side, one channel per vector lane (GCC/Clang vector
// extensions; lane arithmetic is the scalar arithmetic above, so the bits are the same). Pass 0's
// six regressor sums are the same for all three channels and summed once; pass 1 adds a
// residual-rejected sample as +0.0, which leaves a sum started at +0.0 unchanged (such a sum is
// never -0.0 in round-to-nearest), so the masked sums equal the skipping ones.
typedef double VeilD4 __attribute__((vector_size(32)));
typedef long long VeilL4 __attribute__((vector_size(32)));

// The normal equations' sums s00, s01, s02, s11, s12, s22, b0, b1, b2; lane c: channel c (lane 3
// unused).
struct VeilSums3 {
  VeilD4 s[9];
};

// Pass 0: v holds four floats per sample (three channels and a pad).
TURBID_ROW_KERNEL void VeilSumsAll3(const float* __restrict t, const float* __restrict l,
                                    const float* __restrict v, size_t n, VeilSums3* out) {
  double s00 = 0, s01 = 0, s02 = 0, s11 = 0, s12 = 0, s22 = 0;
  VeilD4 b0 = {0, 0, 0, 0}, b1 = b0, b2 = b0;
  for (size_t i = 0; i < n; ++i) {
    const double x0 = t[i], li = l[i];
    const double x1 = (1.0 - x0) * li, x2 = x0 * li;
    s00 += x0 * x0, s01 += x0 * x1, s02 += x0 * x2;
    s11 += x1 * x1, s12 += x1 * x2, s22 += x2 * x2;
    const VeilD4 x3 = {v[4 * i], v[4 * i + 1], v[4 * i + 2], 0.0};
    b0 += x0 * x3, b1 += x1 * x3, b2 += x2 * x3;
  }
  const double shared[6] = {s00, s01, s02, s11, s12, s22};
  for (int j = 0; j < 6; ++j) out->s[j] = VeilD4{shared[j], shared[j], shared[j], shared[j]};
  out->s[6] = b0, out->s[7] = b1, out->s[8] = b2;
}

// |c0 x0 + c1 x1 + c2 x2 - x3| of every sample, channel c's into r[c][i]; coef: c0, c1, c2.
TURBID_ROW_KERNEL void VeilResiduals3(const float* __restrict t, const float* __restrict l,
                                      const float* __restrict v, size_t n, const VeilD4* coef,
                                      double* __restrict r0, double* __restrict r1,
                                      double* __restrict r2) {
  const VeilD4 c0 = coef[0], c1 = coef[1], c2 = coef[2];
  for (size_t i = 0; i < n; ++i) {
    const double x0 = t[i], li = l[i];
    const double x1 = (1.0 - x0) * li, x2 = x0 * li;
    const VeilD4 x3 = {v[4 * i], v[4 * i + 1], v[4 * i + 2], 0.0};
    const VeilD4 d = c0 * x0 + c1 * x1 + c2 * x2 - x3;
    r0[i] = std::abs(d[0]), r1[i] = std::abs(d[1]), r2[i] = std::abs(d[2]);
  }
}

// Pass 1: channel c sums the samples whose residual (recomputed as above) is <= cut[c]; coef:
// c0, c1, c2, cut.
TURBID_ROW_KERNEL void VeilSumsKept3(const float* __restrict t, const float* __restrict l,
                                     const float* __restrict v, size_t n, const VeilD4* coef,
                                     VeilSums3* out) {
  const VeilD4 c0 = coef[0], c1 = coef[1], c2 = coef[2], cut = coef[3];
  const VeilL4 abs_bits = {0x7fffffffffffffffLL, 0x7fffffffffffffffLL, 0x7fffffffffffffffLL,
                           0x7fffffffffffffffLL};
  VeilD4 acc[9] = {};
  for (size_t i = 0; i < n; ++i) {
    const double x0 = t[i], li = l[i];
    const double x1 = (1.0 - x0) * li, x2 = x0 * li;
    const VeilD4 x3 = {v[4 * i], v[4 * i + 1], v[4 * i + 2], 0.0};
    const VeilD4 d = c0 * x0 + c1 * x1 + c2 * x2 - x3;
    const VeilL4 keep = reinterpret_cast<VeilD4>(reinterpret_cast<VeilL4>(d) & abs_bits) <= cut;
    const double q[6] = {x0 * x0, x0 * x1, x0 * x2, x1 * x1, x1 * x2, x2 * x2};
    VeilD4 p[9] = {};
    for (int j = 0; j < 6; ++j) p[j] = VeilD4{q[j], q[j], q[j], q[j]};
    p[6] = x0 * x3, p[7] = x1 * x3, p[8] = x2 * x3;
    for (int j = 0; j < 9; ++j) {
      acc[j] += reinterpret_cast<VeilD4>(reinterpret_cast<VeilL4>(p[j]) & keep);
    }
  }
  for (int j = 0; j < 9; ++j) out->s[j] = acc[j];
}

// Channel c's normal equations solved as FitVeilModel does: false when singular or ill-conditioned.
bool SolveVeil(const VeilSums3& s, int c, cv::Vec3d* solution) {
  const double s00 = s.s[0][c], s01 = s.s[1][c], s02 = s.s[2][c], s11 = s.s[3][c];
  const double s12 = s.s[4][c], s22 = s.s[5][c];
  const cv::Matx33d ata(s00, s01, s02, s01, s11, s12, s02, s12, s22);
  return SolveVeilNormalEquations(ata, cv::Vec3d(s.s[6][c], s.s[7][c], s.s[8][c]), solution);
}

// FitVeilModel for three channels whose samples share t and L (`v`: four floats per sample).
void FitVeilModel3(const std::vector<float>& t, const std::vector<float>& l,
                   const std::vector<float>& v, bool ok[3], cv::Vec3d fit[3]) {
  const size_t n = t.size();
  for (int c = 0; c < 3; ++c) ok[c] = n >= 16;
  if (n < 16) return;
  VeilSums3 sums;
  VeilSumsAll3(t.data(), l.data(), v.data(), n, &sums);
  for (int c = 0; c < 3; ++c) ok[c] = SolveVeil(sums, c, &fit[c]);
  if (!ok[0] && !ok[1] && !ok[2]) return;
  // The three channels' solutions (lanes) and, once selected, their residual cuts.
  VeilD4 coef[4] = {{fit[0][0], fit[1][0], fit[2][0], 0.0},
                    {fit[0][1], fit[1][1], fit[2][1], 0.0},
                    {fit[0][2], fit[1][2], fit[2][2], 0.0},
                    {0.0, 0.0, 0.0, 0.0}};
  std::vector<double> r[3] = {std::vector<double>(n), std::vector<double>(n),
                              std::vector<double>(n)};
  VeilResiduals3(t.data(), l.data(), v.data(), n, coef, r[0].data(), r[1].data(), r[2].data());
  for (int c = 0; c < 3; ++c) {
    if (ok[c]) coef[3][c] = enhancer_internal::SelectKth<double, uint64_t>(r[c], n * 8 / 10);
  }
  VeilSumsKept3(t.data(), l.data(), v.data(), n, coef, &sums);
  for (int c = 0; c < 3; ++c) {
    if (!ok[c]) continue;
    ok[c] = SolveVeil(sums, c, &fit[c]) && std::isfinite(fit[c][0]) && std::isfinite(fit[c][1]) &&
            std::isfinite(fit[c][2]);
  }
}

// The estimate from the ratios' percentile (`bound`) and the fit: the fit is usable when it is
// physical, a > 0 and 0 <= mean reflectance (c2 / c1) <= 1.
void SetLightScale(double bound, bool fit_ok, const cv::Vec3d& fit, LightScaleEstimate* e) {
  e->bound = bound;
  if (fit_ok && fit[1] > 0 && fit[2] >= 0 && fit[2] <= fit[1]) {
    e->fit = fit[1];
    e->scale = std::min(e->fit, e->bound);
    e->source = e->fit <= e->bound ? "fit" : "bound";
  } else {
    e->scale = e->bound;
    e->source = "bound (no usable fit)";
  }
}

// A t or L map as EstimateLightScale reads it: image row y is row y / every of `m` (every > 1: a
// map of the grid rows only, the streamed colour path's).
struct GridRows {
  const cv::Mat& m;
  int every;
  const float* operator()(int y) const { return m.ptr<float>(y / every); }
  int channels() const { return m.channels(); }
};

// EstimateLightScale for a three-channel image with one-channel t and L maps, when every channel
// keeps every grid pixel (the sample sets are then the same; false, nothing written, when a
// channel's value is not finite where L is). The ratios and samples are those of the general
// loop, in grid order; the fits run side by side (FitVeilModel3).
bool LightScaleShared3(const cv::Mat& denoised, GridRows light, GridRows transmission, int stride,
                       float w_min, double percentile, std::vector<LightScaleEstimate>* out) {
  const size_t expected = static_cast<size_t>((denoised.rows + stride - 1) / stride) *
                          static_cast<size_t>((denoised.cols + stride - 1) / stride);
  std::vector<float> ts(expected), ls(expected), vs(4 * expected);
  std::vector<float> ratios[3] = {std::vector<float>(expected), std::vector<float>(expected),
                                  std::vector<float>(expected)};
  size_t n = 0, m = 0;  // samples, ratios
  for (int y = 0; y < denoised.rows; y += stride) {
    const float* in = denoised.ptr<float>(y);
    const float* t = transmission(y);
    const float* l = light(y);
    for (int x = 0; x < denoised.cols; x += stride) {
      const double ti = t[x], li = l[x];
      if (!std::isfinite(li)) continue;
      const float* v = in + 3 * x;
      if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) return false;
      const float w = static_cast<float>((1.0 - ti) * li);
      if (w >= w_min) {
        for (int c = 0; c < 3; ++c) {
          ratios[c][m] = static_cast<float>(std::max(static_cast<double>(v[c]), 0.0) / w);
        }
        ++m;
      }
      ts[n] = t[x], ls[n] = l[x];
      vs[4 * n] = v[0], vs[4 * n + 1] = v[1], vs[4 * n + 2] = v[2], vs[4 * n + 3] = 0.0f;
      ++n;
    }
  }
  if (m == 0) return true;  // no pixel carries the veil: no estimate, as in the general loop
  ts.resize(n), ls.resize(n), vs.resize(4 * n);
  bool fit_ok[3];
  cv::Vec3d fit[3];
  FitVeilModel3(ts, ls, vs, fit_ok, fit);
  for (int c = 0; c < 3; ++c) {
    ratios[c].resize(m);
    SetLightScale(std::max(0.0, PercentileOf(ratios[c], percentile)), fit_ok[c], fit[c],
                  &(*out)[c]);
  }
  return true;
}

// EstimateLightScale's default grid stride: about 65536 grid pixels.
int LightScaleStride(const cv::Mat& denoised) {
  return std::max(1, static_cast<int>(std::floor(std::sqrt(denoised.total() / 65536.0))));
}

// EstimateLightScale on maps given as GridRows (the checks done, `stride` > 0).
std::vector<LightScaleEstimate> EstimateLightScaleGrid(const cv::Mat& denoised, GridRows light,
                                                       GridRows transmission, double percentile,
                                                       double support, int stride) {
  const int ch = denoised.channels(), lc = light.channels(), tc = transmission.channels();
  CV_Assert(ch <= 4 && (lc == 1 || lc == ch) && (tc == 1 || tc == ch));
  std::vector<LightScaleEstimate> out(ch);
  // Per channel: the largest veil weight w = (1 - t) L on the grid (one pass for every channel
  // when t and L have one channel each).
  std::vector<float> w_max(ch, 0.0f);
  for (int c = 0; c < ch; ++c) {
    if (c > 0 && lc == 1 && tc == 1) {
      w_max[c] = w_max[0];
      continue;
    }
    const int l_at = lc == 1 ? 0 : c, t_at = tc == 1 ? 0 : c;
    for (int y = 0; y < denoised.rows; y += stride) {
      const float* t = transmission(y);
      const float* l = light(y);
      for (int x = 0; x < denoised.cols; x += stride) {
        w_max[c] = std::max(w_max[c], (1.0f - t[x * tc + t_at]) * l[x * lc + l_at]);
      }
    }
  }
  std::vector<bool> active(ch);
  std::vector<float> w_min(ch);
  for (int c = 0; c < ch; ++c) {
    active[c] = w_max[c] > 0.0f && std::isfinite(w_max[c]);
    w_min[c] = static_cast<float>(support) * w_max[c];
  }
  if (ch == 3 && lc == 1 && tc == 1 && active[0] &&
      LightScaleShared3(denoised, light, transmission, stride, w_min[0], percentile, &out)) {
    return out;
  }
  // One pass over the grid collects every channel's ratios and fit samples, each in grid order.
  std::vector<std::vector<float>> ratios(ch);
  std::vector<std::vector<VeilSample>> samples(ch);
  const size_t expected = static_cast<size_t>((denoised.rows + stride - 1) / stride) *
                          static_cast<size_t>((denoised.cols + stride - 1) / stride);
  for (int c = 0; c < ch; ++c) {
    if (!active[c]) continue;
    samples[c].reserve(expected);
    ratios[c].reserve(expected);
  }
  for (int y = 0; y < denoised.rows; y += stride) {
    const float* in = denoised.ptr<float>(y);
    const float* t = transmission(y);
    const float* l = light(y);
    for (int x = 0; x < denoised.cols; x += stride) {
      for (int c = 0; c < ch; ++c) {
        if (!active[c]) continue;
        const VeilSample sample{t[x * tc + (tc == 1 ? 0 : c)], l[x * lc + (lc == 1 ? 0 : c)],
                                in[x * ch + c]};
        const double ti = sample.t, li = sample.l, v = sample.v;
        const float w = static_cast<float>((1.0 - ti) * li);
        if (!std::isfinite(v) || !std::isfinite(li)) continue;
        if (w >= w_min[c]) ratios[c].push_back(static_cast<float>(std::max(v, 0.0) / w));
        samples[c].push_back(sample);
      }
    }
  }
  for (int c = 0; c < ch; ++c) {
    if (ratios[c].empty()) continue;
    const double bound = std::max(0.0, PercentileOf(ratios[c], percentile));
    cv::Vec3d fit;
    const bool fit_ok = FitVeilModel(samples[c], &fit);
    SetLightScale(bound, fit_ok, fit, &out[c]);
  }
  return out;
}

}  // namespace

std::vector<LightScaleEstimate> EstimateLightScale(const cv::Mat& denoised, const cv::Mat& light,
                                                   const cv::Mat& transmission, double percentile,
                                                   double support, int stride) {
  CV_Assert(denoised.depth() == CV_32F && light.depth() == CV_32F &&
            transmission.depth() == CV_32F && stride >= 0);
  if (stride == 0) stride = LightScaleStride(denoised);
  CV_Assert(denoised.size() == light.size() && denoised.size() == transmission.size());
  return EstimateLightScaleGrid(denoised, GridRows{light, 1}, GridRows{transmission, 1}, percentile,
                                support, stride);
}

namespace {

// Noise standard deviation of a float image (all channels), J. Immerkaer, "Fast noise variance
// estimation", CVIU 64(2) 1996, eq. 2: sqrt(pi/2) / (6 (W-2)(H-2)) sum |I * N| with the 3x3
// Laplacian-difference mask N = [1 -2 1; -2 4 -2; 1 -2 1], over interior pixels.
// |I * N| at value i of row b (a above, c below), ch values between horizontal neighbours.
inline float LaplacianAbsAt(const float* a, const float* b, const float* c, int i, int ch) {
  const float v = (a[i - ch] + a[i + ch] + c[i - ch] + c[i + ch]) -
                  2.0f * (a[i] + c[i] + b[i - ch] + b[i + ch]) + 4.0f * b[i];
  return std::abs(v);
}

// |I * N| along one row (the mask's 3x3 sum), for the n values from i = ch on.
TURBID_ROW_KERNEL void LaplacianAbsRow(const float* __restrict a, const float* __restrict b,
                                       const float* __restrict c, int ch, float* __restrict out,
                                       int n) {
  for (int j = 0; j < n; ++j) out[j] = LaplacianAbsAt(a, b, c, j + ch, ch);
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// Eight rows' sums of |I * N| at once (rows y0 .. y0 + 7, values i = ch .. ch + n - 1): per eight
// values the rows' |I * N| vectors (LaplacianAbsRow's arithmetic, lane by lane) are transposed so
// that lane k holds row k, and added to lane k's sum in value order: each lane is the scalar
// float chain of its row, bit for bit, without the rows' values going through memory. Values past
// the last whole eight are added one by one. row[k] receives row y0 + k's sum.
__attribute__((target("avx2"))) inline __m256 LaplacianAbs8(const float* a, const float* b,
                                                            const float* c, int i, int ch) {
  const __m256 two = _mm256_set1_ps(2.0f), four = _mm256_set1_ps(4.0f);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  __m256 s = _mm256_add_ps(_mm256_loadu_ps(a + i - ch), _mm256_loadu_ps(a + i + ch));
  s = _mm256_add_ps(s, _mm256_loadu_ps(c + i - ch));
  s = _mm256_add_ps(s, _mm256_loadu_ps(c + i + ch));
  __m256 m = _mm256_add_ps(_mm256_loadu_ps(a + i), _mm256_loadu_ps(c + i));
  m = _mm256_add_ps(m, _mm256_loadu_ps(b + i - ch));
  m = _mm256_add_ps(m, _mm256_loadu_ps(b + i + ch));
  const __m256 v = _mm256_add_ps(_mm256_sub_ps(s, _mm256_mul_ps(two, m)),
                                 _mm256_mul_ps(four, _mm256_loadu_ps(b + i)));
  return _mm256_and_ps(v, abs_mask);
}

__attribute__((target("avx2"))) void LaplacianAbsSums8(const float* const* rows, int ch, int n,
                                                       float* row) {
  __m256 acc = _mm256_setzero_ps();
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    const int i = j + ch;
    __m256 v[8];
    for (int k = 0; k < 8; ++k) v[k] = LaplacianAbs8(rows[k], rows[k + 1], rows[k + 2], i, ch);
    // 8 x 8 transpose: t[q] lane k = v[k] lane q.
    const __m256 u0 = _mm256_unpacklo_ps(v[0], v[1]), u1 = _mm256_unpackhi_ps(v[0], v[1]);
    const __m256 u2 = _mm256_unpacklo_ps(v[2], v[3]), u3 = _mm256_unpackhi_ps(v[2], v[3]);
    const __m256 u4 = _mm256_unpacklo_ps(v[4], v[5]), u5 = _mm256_unpackhi_ps(v[4], v[5]);
    const __m256 u6 = _mm256_unpacklo_ps(v[6], v[7]), u7 = _mm256_unpackhi_ps(v[6], v[7]);
    const __m256 w0 = _mm256_shuffle_ps(u0, u2, 0x44), w1 = _mm256_shuffle_ps(u0, u2, 0xee);
    const __m256 w2 = _mm256_shuffle_ps(u1, u3, 0x44), w3 = _mm256_shuffle_ps(u1, u3, 0xee);
    const __m256 w4 = _mm256_shuffle_ps(u4, u6, 0x44), w5 = _mm256_shuffle_ps(u4, u6, 0xee);
    const __m256 w6 = _mm256_shuffle_ps(u5, u7, 0x44), w7 = _mm256_shuffle_ps(u5, u7, 0xee);
    acc = _mm256_add_ps(acc, _mm256_permute2f128_ps(w0, w4, 0x20));
    acc = _mm256_add_ps(acc, _mm256_permute2f128_ps(w1, w5, 0x20));
    acc = _mm256_add_ps(acc, _mm256_permute2f128_ps(w2, w6, 0x20));
    acc = _mm256_add_ps(acc, _mm256_permute2f128_ps(w3, w7, 0x20));
    acc = _mm256_add_ps(acc, _mm256_permute2f128_ps(w0, w4, 0x31));
    acc = _mm256_add_ps(acc, _mm256_permute2f128_ps(w1, w5, 0x31));
    acc = _mm256_add_ps(acc, _mm256_permute2f128_ps(w2, w6, 0x31));
    acc = _mm256_add_ps(acc, _mm256_permute2f128_ps(w3, w7, 0x31));
  }
  _mm256_storeu_ps(row, acc);
  for (int k = 0; k < 8; ++k) {
    for (int jj = j; jj < n; ++jj)
      row[k] += LaplacianAbsAt(rows[k], rows[k + 1], rows[k + 2], jj + ch, ch);
  }
}
#define TURBID_HAVE_NOISE_AVX2 1
#endif

double EstimateNoiseSigma(const cv::Mat& image) {
  if (image.rows < 3 || image.cols < 3) return 0.0;
  CV_Assert(image.depth() == CV_32F);
  const int ch = image.channels(), n = (image.cols - 2) * ch;
  // Each row's sum is one float accumulation in order (accumulated in double over the rows, in
  // order); kRows rows are summed side by side so their dependent additions overlap.
  constexpr int kRows = 8;
#ifdef TURBID_HAVE_NOISE_AVX2
  const bool avx2 = enhancer_internal::UseHandWrittenAvx2();
#else
  const bool avx2 = false;
#endif
  std::vector<float> v(avx2 ? 0 : static_cast<size_t>(kRows) * n);
  double total = 0.0;
  for (int y0 = 1; y0 + 1 < image.rows; y0 += kRows) {
    const int m = std::min(kRows, image.rows - 1 - y0);
    float row[kRows] = {};
#ifdef TURBID_HAVE_NOISE_AVX2
    if (avx2 && m == kRows) {
      const float* rows[kRows + 2];
      for (int k = 0; k < kRows + 2; ++k) rows[k] = image.ptr<float>(y0 - 1 + k);
      LaplacianAbsSums8(rows, ch, n, row);
      for (int k = 0; k < m; ++k) total += row[k];
      continue;
    }
#endif
    if (avx2) v.resize(static_cast<size_t>(kRows) * n);
    for (int k = 0; k < m; ++k) {
      const int y = y0 + k;
      LaplacianAbsRow(image.ptr<float>(y - 1), image.ptr<float>(y), image.ptr<float>(y + 1), ch,
                      v.data() + static_cast<size_t>(k) * n, n);
    }
    if (m == kRows) {
      const float* p = v.data();
      for (int i = 0; i < n; ++i) {
        for (int k = 0; k < kRows; ++k) row[k] += p[static_cast<size_t>(k) * n + i];
      }
    } else {
      for (int k = 0; k < m; ++k) {
        for (int i = 0; i < n; ++i) row[k] += v[static_cast<size_t>(k) * n + i];
      }
    }
    for (int k = 0; k < m; ++k) total += row[k];
  }
  const double count = 6.0 * (image.cols - 2) * (image.rows - 2) * ch;
  return std::sqrt(CV_PI / 2.0) * total / count;
}

// Step 1 (eq. 4): self-guided filter per channel; with denoise_adaptive the epsilon follows the
// haze (t_med) and the noise.
// `noise_sigma`: the image's EstimateNoiseSigma when already known (else null: computed here).
// `t_rows`: t as rows (the streamed colour path; r->transmission empty then), or null.
cv::Mat DenoiseStep(const FullOptions& o, const cv::Mat& image, FullResult* r,
                    const double* noise_sigma = nullptr,
                    const enhancer_internal::LinearUpsampler* t_rows = nullptr) {
  if (!o.denoise) {
    r->steps.push_back("denoise: skipped (off)");
    return image;
  }
  GuidedFilterOptions g;
  g.radius = o.denoise_radius;
  g.eps = o.denoise_eps;
  std::string how;
  if (o.denoise_adaptive) {
    double t_med = 1.0;
    const bool t_as_rows = t_rows != nullptr && !t_rows->empty();
    if (!r->transmission.empty() || t_as_rows) {
      // Every fourth value of every fourth row of t.
      const cv::Mat& t = r->transmission;
      const int n = t_as_rows ? image.cols : t.cols * t.channels();
      std::vector<float> sample, row(t_as_rows ? n : 0);
      for (int y = 0; y < image.rows; y += 4) {
        const float* p = t_as_rows ? t_rows->Row(y, row.data()) : t.ptr<float>(y);
        for (int i = 0; i < n; i += 4) sample.push_back(p[i]);
      }
      if (!sample.empty()) t_med = PercentileOf(sample, 50.0);
    }
    r->noise_sigma = noise_sigma != nullptr ? *noise_sigma : EstimateNoiseSigma(image);
    const double noise_eps = std::pow(o.denoise_noise_factor * r->noise_sigma, 2);
    g.eps = std::min(o.denoise_eps, std::max(o.denoise_eps * t_med * t_med, noise_eps));
    g.eps = std::max(g.eps, 1e-8);
    how = " (adaptive: t_med " + FormatNumber(t_med) + ", noise sigma " +
          FormatNumber(r->noise_sigma) + ")";
  }
  r->denoise_eps = g.eps;
  r->steps.push_back("denoise: guided filter r " + std::to_string(o.denoise_radius) + ", eps " +
                     FormatNumber(g.eps) + how);
  return GuidedFilterSelf(g, image);
}

// The LED specification (the sidecar's lights, else the simulator's default LED) and beta: the
// fixed beta_per_m, or with beta_source=auto the sidecar's water per channel. One value when every
// channel has the same beta.
void ResolveLightsAndBeta(const FullOptions& o, const RenderRecord* sidecar, int channels,
                          IrradianceOptions* lights, std::vector<double>* beta, FullResult* r) {
  *beta = {o.beta_per_m};
  r->beta_source = "beta_per_m";
  if (sidecar != nullptr && sidecar->options) {
    const RenderOptions& rendered = *sidecar->options;
    *lights = rendered.light;
    if (o.beta_source == "auto") {
      const WaterOptions& water = rendered.water;
      *beta = ChannelValues(water.beta_rgb_per_m, water.beta_gray_per_m, channels);
      r->beta_source = "sidecar water";
    }
  }
  if (std::all_of(beta->begin(), beta->end(), [&](double b) { return b == (*beta)[0]; })) {
    beta->resize(1);
  }
  r->beta_per_m = beta->size() == 1 ? std::vector<double>(channels, (*beta)[0]) : *beta;
}

// t = exp(-beta r) on the plane, clamped to t_min, at 1/light_subsample and upsampled; one map per
// distinct beta. Fills r->transmission (and r->range_m when inspecting); with `t_rows` and one
// beta, *t_rows instead (the rows of the upsampled map, one at a time).
void TransmissionStep(const FullOptions& o, const CameraIntrinsics& camera,
                      const std::vector<double>& beta, cv::Size size, bool keep_steps,
                      FullResult* r, enhancer_internal::LinearUpsampler* t_rows = nullptr) {
  const CameraIntrinsics small = Downscaled(camera, o.light_subsample);
  const cv::Mat range = RangeFromDepth(small, PlaneDepth(*r->plane, small, o.max_range_m));
  std::vector<cv::Mat> t_planes;
  for (double b : beta) {
    cv::Mat t;
    cv::exp(range * -b, t);
    cv::max(t, o.t_min, t);
    if (t_rows != nullptr && beta.size() == 1) {
      *t_rows = enhancer_internal::LinearUpsampler(t, size);
      return;
    }
    t_planes.push_back(Upsample(t, size));
  }
  if (keep_steps) r->range_m = Upsample(range, size);
  if (t_planes.size() == 1) {
    r->transmission = t_planes[0];
  } else {
    cv::merge(t_planes, r->transmission);
  }
}

// Step 2 (eq. 5): E_L on the plane, scaled into image units blind, by the range fit, or as is.
// Returned as `map` times `scale` per channel (scale empty: the map as is); the map has one
// channel per distinct beta except with range scaling (image channels, scaled). The streamed
// colour path may get a one-channel map as `rows` instead (`map` empty).
struct LightEstimate {
  cv::Mat map;
  enhancer_internal::LinearUpsampler rows;
  std::vector<double> scale;
  bool empty() const { return map.empty() && rows.empty(); }
};

// EstimateLightScale(denoised, E_L, t) with E_L and t as maps or rows (t_rows non-null and not
// empty: t's rows; else `transmission`): only the grid rows of the row sources are made.
std::vector<LightScaleEstimate> LightScaleOf(const FullOptions& o, const cv::Mat& denoised,
                                             const LightEstimate& e, const cv::Mat& transmission,
                                             const enhancer_internal::LinearUpsampler* t_rows) {
  const bool t_as_rows = t_rows != nullptr && !t_rows->empty();
  if (!t_as_rows && e.rows.empty()) {
    return EstimateLightScale(denoised, e.map, transmission, o.light_scale_percentile,
                              o.light_scale_support);
  }
  const int stride = LightScaleStride(denoised);
  const cv::Mat t_grid = t_as_rows ? t_rows->EveryNthRow(stride) : transmission;
  const cv::Mat l_grid = e.rows.empty() ? e.map : e.rows.EveryNthRow(stride);
  return EstimateLightScaleGrid(denoised, GridRows{l_grid, e.rows.empty() ? 1 : stride},
                                GridRows{t_grid, t_as_rows ? stride : 1}, o.light_scale_percentile,
                                o.light_scale_support, stride);
}

// `t_rows`: the streamed colour path's t (r->transmission empty then); with it, E_L may be returned
// as rows too.
LightEstimate LightStepUnscaled(const FullOptions& o, const IrradianceOptions& lights,
                                const CameraIntrinsics& camera, const std::vector<double>& beta,
                                const cv::Mat& denoised, FullResult* r,
                                const enhancer_internal::LinearUpsampler* t_rows = nullptr) {
  if (!o.light) {
    r->steps.push_back("light: skipped (off)");
    return {};
  }
  if (lights.lights.empty()) {
    r->steps.push_back("light: skipped (no lights)");
    return {};
  }
  LightEstimate e;
  e.map =
      o.light_scaling == "range"
          ? EstimateArtificialLight(lights, *r->plane, camera, beta, denoised, true,
                                    o.light_subsample, o.max_range_m)
          : LightModelMap(lights, *r->plane, camera, beta, denoised.size(), denoised.channels(),
                          o.light_subsample, o.max_range_m, t_rows != nullptr ? &e.rows : nullptr);
  std::string detail = o.light_scaling + " scaling";
  if (o.light_scaling == "physical") {
    r->light_scale.assign(denoised.channels(), 1.0);
  } else if (o.light_scaling == "blind") {
    if (r->transmission.empty() && (t_rows == nullptr || t_rows->empty())) {
      // No attenuation: no veil to measure the light by, and eq. 6 leaves I unchanged.
      r->light_scale.assign(denoised.channels(), 0.0);
    } else {
      const std::vector<LightScaleEstimate> est =
          LightScaleOf(o, denoised, e, r->transmission, t_rows);
      for (const LightScaleEstimate& est_c : est) {
        r->light_scale.push_back(est_c.scale);
        detail += "; scale " + FormatNumber(est_c.scale) + " (" + est_c.source + "; fit " +
                  FormatNumber(est_c.fit) + ", bound " + FormatNumber(est_c.bound) + ")";
      }
    }
    e.scale = r->light_scale;
  }
  r->steps.push_back("light: " + std::to_string(lights.lights.size()) + " light(s), " + detail);
  return e;
}

// LightStepUnscaled's E_L as one image with the image's channels.
cv::Mat LightStep(const FullOptions& o, const IrradianceOptions& lights,
                  const CameraIntrinsics& camera, const std::vector<double>& beta,
                  const cv::Mat& denoised, FullResult* r) {
  LightEstimate e = LightStepUnscaled(o, lights, camera, beta, denoised, r);
  if (e.map.empty()) return {};
  cv::Mat e_l = e.map;
  if (e_l.channels() != denoised.channels()) {  // one beta: the same E_L for every channel
    cv::merge(std::vector<cv::Mat>(denoised.channels(), e_l), e_l);
  }
  if (!e.scale.empty()) {
    cv::Scalar a;
    for (int c = 0; c < denoised.channels(); ++c) a[c] = e.scale[c];
    cv::multiply(e_l, a, e_l);
  }
  return e_l;
}

// Step 3 (eq. 6): (I - E_L) / t + E_L, or I / t without light; a one-channel t serves every
// channel. Written into `dehazed`, which may be `current` itself.
void DehazeRows(const cv::Mat& current, const cv::Mat& e_l, const cv::Mat& tm, cv::Mat& dehazed) {
  const int channels = current.channels();
  const bool t_per_value = tm.channels() == channels;  // else one t for every channel
  const int n = current.cols * channels;
  for (int y = 0; y < current.rows; ++y) {
    const float* in = current.ptr<float>(y);
    const float* t = tm.ptr<float>(y);
    const float* e = e_l.empty() ? nullptr : e_l.ptr<float>(y);
    float* d = dehazed.ptr<float>(y);
    if (t_per_value && e == nullptr) {
      for (int i = 0; i < n; ++i) d[i] = in[i] / t[i];
    } else if (t_per_value) {
      for (int i = 0; i < n; ++i) d[i] = (in[i] - e[i]) / t[i] + e[i];
    } else {
      for (int x = 0; x < current.cols; ++x) {
        const float ti = t[x];
        for (int i = x * channels; i < (x + 1) * channels; ++i) {
          d[i] = e == nullptr ? in[i] / ti : (in[i] - e[i]) / ti + e[i];
        }
      }
    }
  }
}

// Divides J_plane by its exposure_percentile percentile when that exceeds 1 (sampled on a
// stride-2 grid, every channel).
void ExposureStep(const FullOptions& o, cv::Mat& dehazed, FullResult* r) {
  if (o.exposure_percentile <= 0) return;
  std::vector<float> sample;
  sample.reserve(static_cast<size_t>(dehazed.total() * dehazed.channels() / 4 + 16));
  const int n = dehazed.cols * dehazed.channels();
  for (int y = 0; y < dehazed.rows; y += 2) {
    const float* p = dehazed.ptr<float>(y);
    for (int i = 0; i < n; i += 2) {
      if (std::isfinite(p[i])) sample.push_back(p[i]);
    }
  }
  if (sample.empty()) return;
  const double level = PercentileOf(sample, o.exposure_percentile);
  if (level > 1.0) {
    r->exposure_scale = level;
    dehazed.convertTo(dehazed, CV_32F, 1.0 / level);
    r->steps.push_back("exposure: J_plane divided by its " + FormatNumber(o.exposure_percentile) +
                       "th percentile " + FormatNumber(level));
  }
}

// The contrast step's log line.
void ContrastStepLog(const FullOptions& o, const ClaheOptions& clahe, const ClaheStats& stats,
                     FullResult* r) {
  if (!o.contrast) {
    r->steps.push_back("contrast: skipped (off)");
    return;
  }
  r->clahe_alpha = stats.alpha;
  std::string what = "contrast: CLAHE " + ClaheDistributionName(clahe.distribution);
  if (clahe.distribution != ClaheDistribution::kUniform) {
    what += ", alpha " + FormatNumber(stats.alpha);
    if (clahe.keep_mean) {
      what += " (chosen for the mean " + FormatNumber(stats.target_mean) + "; mean in " +
              FormatNumber(stats.input_mean) + ")";
    }
  }
  r->steps.push_back(what);
}

// Steps 4 (eq. 7) and 5 (CLAHE). Without inspection, a one-channel spatial Wiener deblur streams
// its rows straight into CLAHE's bin indices: no full-size deblurred image.
cv::Mat DeblurAndContrast(const FullOptions& o, cv::Mat current, bool keep_steps, FullResult* r) {
  const int channels = current.channels();
  cv::Mat bins;
  if (o.deblur) {
    PsfOptions p;
    p.optical_thickness = o.psf_optical_thickness;
    p.forward_scatter = o.psf_forward_scatter;
    const Psf psf = PsfKernel(p);
    if (psf.is_delta) {
      r->steps.push_back("deblur: skipped (PSF is a delta at this pixel scale)");
    } else {
      bool streamed = false;
      if (!keep_steps && o.contrast && channels == 1) {
        bins = ClaheNewBins(o.clahe, current.size());
        try {
          streamed =
              DeconvolveRows(o.deconvolution, current, psf.kernel,
                             [&](int y, const float* row) { ClaheBinRow(o.clahe, row, bins, y); });
        } catch (const Error&) {
          streamed = false;  // non-finite values: the general path below
        }
      }
      if (!streamed) {
        bins.release();
        current = Deconvolve(o.deconvolution, current, psf.kernel);
      }
      r->steps.push_back("deblur: " + DeconvolutionMethodName(o.deconvolution.method) +
                         ", PSF radius " + std::to_string(psf.radius_px));
    }
  } else {
    r->steps.push_back("deblur: skipped (off)");
  }
  if (bins.empty()) r->deblurred = current;

  ClaheOptions clahe = o.clahe;
  clahe.keep_mean = o.clahe_target_mean;
  clahe.min_mean = o.clahe_min_mean;
  ClaheStats stats;
  cv::Mat out;
  if (!bins.empty()) {
    out = ClaheFromBins(clahe, bins, &stats);  // in [0, 1]
  } else if (o.contrast && channels == 1) {
    // CLAHE clamps while binning, so the clamped copy is not needed; its output is in [0, 1].
    // Non-finite values (ClampUnit turns NaN into 0) take the general path below.
    bins = ClaheNewBins(clahe, current.size());
    try {
      for (int y = 0; y < current.rows; ++y) ClaheBinRow(clahe, current.ptr<float>(y), bins, y);
      out = ClaheFromBins(clahe, bins, &stats);
    } catch (const Error&) {
      out.release();
    }
  }
  if (out.empty()) {
    out = current.clone();
    ClampUnit(out);
    if (o.contrast) out = Clahe(clahe, out, &stats);
    ClampUnit(out);
  }
  ContrastStepLog(o, clahe, stats, r);
  return out;
}

// ---- `full` on colour images, streamed (FullEnhance only; FullEnhanceDetailed keeps every
// intermediate). The whole-image steps become row producers with the same arithmetic: J_plane
// (eq. 6), its exposure scale and the detail layer are computed per row as the deblur asks for
// them, the deblurred rows are clamped and binned for CLAHE as they come, and the output reuses
// the denoised image's buffer. Full-size buffers: the denoised image (then the output), the
// upsampled t and E_L maps (one channel each when one beta), CLAHE's bins.

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// What DehazeSpreadAvx2 does after eq. 6: nothing; the exposure scale (j * inv_level, the
// product of ColorRowSource::ScaleRow); or the exposure scale and the detail layer (fma(I - I_de,
// k, j * inv_level), ExposureDetailRowFma's arithmetic).
enum class AfterDehaze { kNone, kScale, kScaleDetail };

// Eq. 6 on an interleaved BGR row from one-channel t and E_L rows (w pixels): per 8 pixels (24
// values, three vectors) t and E_L are spread to the values' pixels by one permute each, E_L is
// scaled per channel in double (the lanes' channels repeat with period 3) and rounded to float,
// then (I - E) / t + E, or I / t without light (e null); then the `kAfter` step in registers
// (image: the input row, for the detail layer). The scalar arithmetic of ColorRowSource's
// portable path, lane by lane: the same bits. Compiled with FMA (the detail step's fused
// multiply-add, as ExposureDetailRowFma); nothing else has a product feeding a sum, so nothing
// else can be contracted. Callers check CpuHasFma().
// The kAfter step on eight values j of eq. 6 at value index i of the row (image, denoised: the
// input's and the denoised image's rows; image is read for the detail layer only).
template <AfterDehaze kAfter>
__attribute__((target("avx2,fma"))) inline __m256 AfterDehazeStep(__m256 j, const float* image,
                                                                  const float* denoised, int i,
                                                                  __m256 inv, __m256 kd) {
  if (kAfter == AfterDehaze::kNone) return j;
  const __m256 scaled = _mm256_mul_ps(j, inv);
  if (kAfter == AfterDehaze::kScale) return scaled;
  return _mm256_fmadd_ps(_mm256_sub_ps(_mm256_loadu_ps(image + i), _mm256_loadu_ps(denoised + i)),
                         kd, scaled);
}

template <AfterDehaze kAfter>
__attribute__((target("avx2,fma"))) void DehazeSpreadAvx2(const float* in, const float* e,
                                                          const double* scale, const float* t,
                                                          const float* image, float inv_level,
                                                          float k_detail, float* d, int w) {
  // Pixel (within the 8) and channel of each lane of the three vectors.
  static const int kPixel[3][8] = {
      {0, 0, 0, 1, 1, 1, 2, 2}, {2, 3, 3, 3, 4, 4, 4, 5}, {5, 5, 6, 6, 6, 7, 7, 7}};
  static const int kChannel[3][8] = {
      {0, 1, 2, 0, 1, 2, 0, 1}, {2, 0, 1, 2, 0, 1, 2, 0}, {1, 2, 0, 1, 2, 0, 1, 2}};
  __m256i spread[3];
  __m256d s_lo[3], s_hi[3];
  for (int k = 0; k < 3; ++k) {
    spread[k] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(kPixel[k]));
    const int* c = kChannel[k];
    s_lo[k] = _mm256_setr_pd(scale[c[0]], scale[c[1]], scale[c[2]], scale[c[3]]);
    s_hi[k] = _mm256_setr_pd(scale[c[4]], scale[c[5]], scale[c[6]], scale[c[7]]);
  }
  const __m256 inv = _mm256_set1_ps(inv_level), kd = _mm256_set1_ps(k_detail);
  int x = 0;
  for (; x + 8 <= w; x += 8) {
    const __m256 t8 = _mm256_loadu_ps(t + x);
    const __m256 e8 = e != nullptr ? _mm256_loadu_ps(e + x) : _mm256_setzero_ps();
    for (int k = 0; k < 3; ++k) {
      const int i = 3 * x + 8 * k;
      const __m256 tv = _mm256_permutevar8x32_ps(t8, spread[k]);
      const __m256 v = _mm256_loadu_ps(in + i);
      if (e == nullptr) {
        _mm256_storeu_ps(d + i,
                         AfterDehazeStep<kAfter>(_mm256_div_ps(v, tv), image, in, i, inv, kd));
        continue;
      }
      const __m256 ev = _mm256_permutevar8x32_ps(e8, spread[k]);
      const __m128 lo =
          _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(ev)), s_lo[k]));
      const __m128 hi =
          _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(ev, 1)), s_hi[k]));
      const __m256 ee = _mm256_insertf128_ps(_mm256_castps128_ps256(lo), hi, 1);
      const __m256 j = _mm256_add_ps(_mm256_div_ps(_mm256_sub_ps(v, ee), tv), ee);
      _mm256_storeu_ps(d + i, AfterDehazeStep<kAfter>(j, image, in, i, inv, kd));
    }
  }
  for (; x < w; ++x) {
    for (int c = 0; c < 3; ++c) {
      const int i = 3 * x + c;
      float j;
      if (e == nullptr) {
        j = in[i] / t[x];
      } else {
        const float ee = static_cast<float>(static_cast<double>(e[x]) * scale[c]);
        j = (in[i] - ee) / t[x] + ee;
      }
      if (kAfter == AfterDehaze::kScale) j *= inv_level;
      if (kAfter == AfterDehaze::kScaleDetail)
        j = std::fma(image[i] - in[i], k_detail, j * inv_level);
      d[i] = j;
    }
  }
}
#define TURBID_HAVE_DEHAZE_AVX2 1
#endif

// Row y of the image entering the deblur (J_plane, exposure-scaled, plus the detail layer), from
// the input, the denoised image, E_L (map or rows, x scale) and t (`transmission`, or `t_rows`
// when that is not empty).
class ColorRowSource {
 public:
  ColorRowSource(const FullOptions& o, const cv::Mat& image, const cv::Mat& denoised,
                 LightEstimate light, const cv::Mat& transmission,
                 const enhancer_internal::LinearUpsampler& t_rows, bool dehaze)
      : image_(image),
        denoised_(denoised),
        light_(std::move(light)),
        t_(transmission),
        t_rows_(t_rows),
        dehaze_(dehaze),
        detail_(o.keep_detail > 0 && o.denoise),
        keep_(static_cast<float>(o.keep_detail)),
        n_(image.cols * 3),
        e_row_(light_.empty() ? 0 : n_),
        t_row_(n_),
        e_upsampled_(light_.rows.empty() ? 0 : image.cols),
        t_upsampled_(t_rows_.empty() ? 0 : image.cols) {
    // E_L's per-channel scale (1 without one), for DehazeSpreadAvx2.
    const bool scaled = !light_.empty() && !light_.scale.empty();
    for (int c = 0; c < 3; ++c) scale_[c] = scaled ? light_.scale[c] : 1.0;
  }

  // J_plane of row y (eq. 6), or the denoised row without dehazing; `dst` holds n floats.
  void Dehazed(int y, float* dst) {
    const float* in = denoised_.ptr<float>(y);
    if (!dehaze_) {
      std::copy_n(in, n_, dst);
      return;
    }
#ifdef TURBID_HAVE_DEHAZE_AVX2
    if (Spread()) {
      DehazeSpreadAvx2<AfterDehaze::kNone>(in, LightRow(y), scale_, TRow(y), nullptr, 1.0f, 0.0f,
                                           dst, image_.cols);
      return;
    }
#endif
    const float* t = Expand(TRow(y), TChannels(), nullptr, t_row_.data());
    if (light_.empty()) {
      DehazeRowNoLight(in, t, dst, n_);
    } else {
      const float* e = Expand(LightRow(y), LightChannels(), &light_.scale, e_row_.data());
      DehazeRowLight(in, e, t, dst, n_);
    }
  }

  // The deblur's input row: J_plane / exposure, plus keep_detail (I - I_de).
  void Row(int y, float* dst) {
#ifdef TURBID_HAVE_DEHAZE_AVX2
    // Eq. 6, the exposure scale and the detail layer in one pass over the row.
    if (dehaze_ && Spread() && (detail_ || exposure_ != 1.0f)) {
      const float* in = denoised_.ptr<float>(y);
      if (detail_) {
        DehazeSpreadAvx2<AfterDehaze::kScaleDetail>(in, LightRow(y), scale_, TRow(y),
                                                    image_.ptr<float>(y), exposure_, keep_, dst,
                                                    image_.cols);
      } else {
        DehazeSpreadAvx2<AfterDehaze::kScale>(in, LightRow(y), scale_, TRow(y), nullptr, exposure_,
                                              0.0f, dst, image_.cols);
      }
      return;
    }
#endif
    Dehazed(y, dst);
    if (detail_) {
      ExposureDetailRow(image_.ptr<float>(y), denoised_.ptr<float>(y), exposure_, keep_, dst, n_);
    } else if (exposure_ != 1.0f) {
      ScaleRow(dst, exposure_, n_);
    }
  }

  int values() const { return n_; }
  // J_plane is divided by `level` (cv::Mat::convertTo's float product by 1 / level).
  void SetExposure(double level) { exposure_ = static_cast<float>(1.0 / level); }

 private:
#ifdef TURBID_HAVE_DEHAZE_AVX2
  // Whether DehazeSpreadAvx2 serves: one t and one E_L map for every channel (one beta), spread
  // and scaled in registers, on a CPU with AVX2 and FMA.
  bool Spread() const {
    static const bool fma = CpuHasFma();
    return fma && TChannels() == 1 && (light_.empty() || LightChannels() == 1) &&
           enhancer_internal::UseHandWrittenAvx2();
  }
#endif
  // Row y of t and of E_L (null without light), from the maps or computed from their rows.
  const float* TRow(int y) {
    return t_rows_.empty() ? t_.ptr<float>(y) : t_rows_.Row(y, t_upsampled_.data());
  }
  const float* LightRow(int y) {
    if (!light_.rows.empty()) return light_.rows.Row(y, e_upsampled_.data());
    return light_.map.empty() ? nullptr : light_.map.ptr<float>(y);
  }
  int TChannels() const { return t_rows_.empty() ? t_.channels() : 1; }
  int LightChannels() const { return light_.rows.empty() ? light_.map.channels() : 1; }

  // A row `p` of a one- or three-channel map as three values per pixel, times scale[c] in double
  // (cv::multiply by a Scalar) when a scale is given.
  const float* Expand(const float* p, int channels, const std::vector<double>* scale, float* buf) {
    const int w = image_.cols;
    if (scale == nullptr || scale->empty()) {
      if (channels == 3) return p;
      SpreadRow(p, buf, w);
    } else if (channels == 1) {
      SpreadScaledRow(p, (*scale)[0], (*scale)[1], (*scale)[2], buf, w);
    } else {
      ScaledRow3(p, (*scale)[0], (*scale)[1], (*scale)[2], buf, w);
    }
    return buf;
  }

  static TURBID_ROW_KERNEL void SpreadRow(const float* __restrict p, float* __restrict b, int w) {
    for (int x = 0; x < w; ++x) b[3 * x] = b[3 * x + 1] = b[3 * x + 2] = p[x];
  }
  static TURBID_ROW_KERNEL void SpreadScaledRow(const float* __restrict p, double s0, double s1,
                                                double s2, float* __restrict b, int w) {
    for (int x = 0; x < w; ++x) {
      const double v = p[x];
      b[3 * x] = static_cast<float>(v * s0);
      b[3 * x + 1] = static_cast<float>(v * s1);
      b[3 * x + 2] = static_cast<float>(v * s2);
    }
  }
  static TURBID_ROW_KERNEL void ScaledRow3(const float* __restrict p, double s0, double s1,
                                           double s2, float* __restrict b, int w) {
    for (int x = 0; x < w; ++x) {
      b[3 * x] = static_cast<float>(static_cast<double>(p[3 * x]) * s0);
      b[3 * x + 1] = static_cast<float>(static_cast<double>(p[3 * x + 1]) * s1);
      b[3 * x + 2] = static_cast<float>(static_cast<double>(p[3 * x + 2]) * s2);
    }
  }

  static TURBID_ROW_KERNEL void DehazeRowLight(const float* __restrict in,
                                               const float* __restrict e, const float* __restrict t,
                                               float* __restrict d, int n) {
    for (int i = 0; i < n; ++i) d[i] = (in[i] - e[i]) / t[i] + e[i];
  }
  static TURBID_ROW_KERNEL void DehazeRowNoLight(const float* __restrict in,
                                                 const float* __restrict t, float* __restrict d,
                                                 int n) {
    for (int i = 0; i < n; ++i) d[i] = in[i] / t[i];
  }
  static TURBID_ROW_KERNEL void ScaleRow(float* __restrict v, float k, int n) {
    for (int i = 0; i < n; ++i) v[i] *= k;
  }

  const cv::Mat& image_;
  const cv::Mat& denoised_;
  const LightEstimate light_;
  const cv::Mat& t_;
  const enhancer_internal::LinearUpsampler& t_rows_;
  const bool dehaze_, detail_;
  const float keep_;
  const int n_;
  float exposure_ = 1.0f;
  double scale_[3];
  std::vector<float> e_row_, t_row_;
  std::vector<float> e_upsampled_, t_upsampled_;  // one-channel rows computed from *_rows
};

// ExposureStep on the rows of J_plane (the same sample: every second value of every second row).
void ExposureStepRows(const FullOptions& o, ColorRowSource& src, int rows, FullResult* r) {
  if (o.exposure_percentile <= 0) return;
  const int n = src.values();
  std::vector<float> row(n);
  enhancer_internal::CountedSample sample(static_cast<size_t>((rows + 1) / 2) *
                                          static_cast<size_t>((n + 1) / 2));
  for (int y = 0; y < rows; y += 2) {
    src.Dehazed(y, row.data());
    sample.AddEverySecondFinite(row.data(), n);
  }
  if (sample.empty()) return;
  const double level = sample.Percentile(o.exposure_percentile);
  if (level > 1.0) {
    r->exposure_scale = level;
    src.SetExposure(level);
    r->steps.push_back("exposure: J_plane divided by its " + FormatNumber(o.exposure_percentile) +
                       "th percentile " + FormatNumber(level));
  }
}

// Steps 4 and 5 over the row source when the deblur is the spatial Wiener filter: rows produced
// into a ring of 2k + 1 (k the inverse filter's radius), deblurred, clamped (ClampUnit) and
// binned into `out`. Returns false (nothing done) when another deblur path applies.
bool DeblurAndContrastRows(const FullOptions& o, ColorRowSource& src, cv::Mat& out, FullResult* r) {
  if (!o.deblur) return false;
  PsfOptions p;
  p.optical_thickness = o.psf_optical_thickness;
  p.forward_scatter = o.psf_forward_scatter;
  const Psf psf = PsfKernel(p);
  if (psf.is_delta || o.deconvolution.method != DeconvolutionMethod::kWiener ||
      o.deconvolution.spatial_max_radius <= 0) {
    return false;
  }
  const int k = WienerInverseKernel(psf.kernel, o.deconvolution.nsr).rows / 2;
  if (k > o.deconvolution.spatial_max_radius) return false;
  ClaheOptions clahe = o.clahe;
  clahe.keep_mean = o.clahe_target_mean;
  clahe.min_mean = o.clahe_min_mean;
  const int n = src.values(), ring = std::min(2 * k + 1, out.rows);
  cv::Mat rows(ring, n, CV_32F), bins;
  if (o.contrast) bins = ClaheNewBins(clahe, out.size());
  std::vector<float> lum(out.cols);
  int next = 0;  // rows [next - ring, next) are in the ring
  const bool streamed = DeconvolveRowsFrom(
      o.deconvolution, out.size(), 3,
      [&](int y) {
        for (; next <= y; ++next) src.Row(next, rows.ptr<float>(next % ring));
        return rows.ptr<float>(y % ring);
      },
      psf.kernel,
      [&](int y, const float* row) {
        float* dst = out.ptr<float>(y);  // its denoised values were read for ring row y
        ClampUnitCopyRow(row, dst, n);
        if (o.contrast) ClaheBinColorRow(clahe, dst, lum.data(), bins, y);
      });
  if (!streamed) return false;  // another deblur path after all: nothing was read or written
  r->steps.push_back("deblur: " + DeconvolutionMethodName(o.deconvolution.method) +
                     ", PSF radius " + std::to_string(psf.radius_px));
  ClaheStats stats;
  if (o.contrast) ClaheColorFromBins(clahe, bins, out, &stats);  // in [0, 1]
  ContrastStepLog(o, clahe, stats, r);
  return true;
}

// Steps 1-5 of `full` for a three-channel image after the geometry (FullEnhanceImpl's).
cv::Mat FullColorStreamed(const FullOptions& o, const cv::Mat& image,
                          const IrradianceOptions& lights, const CameraIntrinsics& camera,
                          const std::vector<double>& beta, bool any_beta, const double* noise_sigma,
                          const enhancer_internal::LinearUpsampler& t_rows, FullResult* r) {
  const cv::Mat denoised = DenoiseStep(o, image, r, noise_sigma, &t_rows);
  LightEstimate light = LightStepUnscaled(o, lights, camera, beta, denoised, r, &t_rows);
  const bool dehaze = o.dehaze && any_beta;
  ColorRowSource src(o, image, denoised, std::move(light), r->transmission, t_rows, dehaze);
  if (dehaze) {
    std::string values;
    for (double b : r->beta_per_m) values += (values.empty() ? "" : "/") + FormatNumber(b);
    r->steps.push_back("dehaze: beta " + values + " 1/m (" + r->beta_source +
                       "), t >= " + FormatNumber(o.t_min));
    ExposureStepRows(o, src, image.rows, r);
  } else {
    r->steps.push_back(o.dehaze ? "dehaze: skipped (beta 0)" : "dehaze: skipped (off)");
  }
  if (o.keep_detail > 0 && o.denoise) {
    r->steps.push_back("detail: the denoising residual added back x" + FormatNumber(o.keep_detail));
  }
  // The output overwrites the denoised image row by row when that is our own buffer.
  cv::Mat out = o.denoise ? denoised : cv::Mat(image.size(), CV_32FC3);
  if (DeblurAndContrastRows(o, src, out, r)) return out;
  // Other deblur paths: the whole deblur input, then the general steps 4-5.
  cv::Mat current(image.size(), CV_32FC3);
  for (int y = 0; y < image.rows; ++y) src.Row(y, current.ptr<float>(y));
  return DeblurAndContrast(o, current, false, r);
}

// The full pipeline. `keep_steps`: fill every inspection-only field of FullResult (range_m);
// FullEnhance passes false and saves the full-size work they cost.
FullResult FullEnhanceImpl(const FullOptions& o, const cv::Mat& image, const Scene* scene,
                           const RenderRecord* sidecar, bool keep_steps) {
  ThrowIfInvalid(o, "full");
  FullResult r;
  const int channels = image.channels();
  // The streamed colour path with adaptive denoising reads the input once for the finiteness
  // check and the noise estimate: every value has a nonzero weight in some |I * N| term of the
  // estimate (3 x 3 and larger), so a non-finite value makes the sum non-finite; only then (or
  // when finite values overflow it) is the input scanned, to name the row as before.
  const bool streamed = !keep_steps && image.channels() == 3;
  double noise_sigma = 0.0;
  const bool sigma_known =
      streamed && o.denoise && o.denoise_adaptive && image.rows >= 3 && image.cols >= 3;
  if (sigma_known) {
    ValidateEnhanceImageLayout(image, "full");
    noise_sigma = EstimateNoiseSigma(image);
    if (!std::isfinite(noise_sigma)) ValidateEnhanceImage(image, "full");
  } else {
    ValidateEnhanceImage(image, "full");
  }

  IrradianceOptions lights;
  std::vector<double> beta;
  enhancer_internal::LinearUpsampler t_rows;  // the streamed path's t, when one beta
  ResolveLightsAndBeta(o, sidecar, channels, &lights, &beta, &r);
  const bool any_beta = std::any_of(beta.begin(), beta.end(), [](double b) { return b > 0; });
  const bool need_light = o.light && !lights.lights.empty();
  const bool need_geometry = need_light || (o.dehaze && any_beta);
  CameraIntrinsics camera;
  if (need_geometry) {
    camera = ResolveCamera(image, scene, sidecar, &r.steps);
    std::string source;
    r.plane = ResolvePlane(o, scene, camera, &source);
    r.plane_source = source;
    r.steps.push_back("plane: from " + source);
    // The streamed path reads t one row at a time (with one beta): no full-size map.
    if (any_beta) {
      TransmissionStep(o, camera, beta, image.size(), keep_steps, &r, streamed ? &t_rows : nullptr);
    }
  }
  if (streamed) {
    r.image = FullColorStreamed(o, image, lights, camera, beta, any_beta,
                                sigma_known ? &noise_sigma : nullptr, t_rows, &r);
    return r;
  }
  cv::Mat current = DenoiseStep(o, image, &r);
  r.denoised = current;
  // The layer the denoising removes (noise and texture finer than its epsilon), taken before the
  // dehazing may reuse the denoised buffer.
  cv::Mat detail;
  if (o.keep_detail > 0 && o.denoise) cv::subtract(image, current, detail);
  const cv::Mat e_l = LightStep(o, lights, camera, beta, current, &r);
  r.light = e_l;

  if (o.dehaze && any_beta) {
    // In place over the denoised image when nobody inspects it (it is our own buffer then).
    cv::Mat dehazed = !keep_steps && o.denoise ? current : cv::Mat(current.size(), current.type());
    DehazeRows(current, e_l, r.transmission, dehazed);
    current = dehazed;
    std::string values;
    for (double b : r.beta_per_m) values += (values.empty() ? "" : "/") + FormatNumber(b);
    r.steps.push_back("dehaze: beta " + values + " 1/m (" + r.beta_source +
                      "), t >= " + FormatNumber(o.t_min));
    ExposureStep(o, current, &r);
  } else {
    r.steps.push_back(o.dehaze ? "dehaze: skipped (beta 0)" : "dehaze: skipped (off)");
  }
  r.dehazed = current;
  if (!detail.empty()) {
    // Added back at its input amplitude, not divided by t: noise is not amplified, and texture
    // visible in the input stays visible (a structure-texture split: only the structure layer is
    // dehazed). In place unless r.dehazed is inspected; `detail` is ours either way.
    if (keep_steps || current.data == image.data) {
      cv::scaleAdd(detail, o.keep_detail, current, detail);
      current = detail;
    } else {
      cv::scaleAdd(detail, o.keep_detail, current, current);
    }
    r.steps.push_back("detail: the denoising residual added back x" + FormatNumber(o.keep_detail));
  }
  r.image = DeblurAndContrast(o, current, keep_steps, &r);
  return r;
}

}  // namespace

FullResult FullEnhanceDetailed(const FullOptions& o, const cv::Mat& image, const Scene* scene,
                               const RenderRecord* sidecar) {
  return FullEnhanceImpl(o, image, scene, sidecar, true);
}

cv::Mat FullEnhance(const FullOptions& o, const cv::Mat& image, const Scene* scene,
                    const RenderRecord* sidecar) {
  return FullEnhanceImpl(o, image, scene, sidecar, false).image;
}

// ---------------------------------------------------------------------------------------------

bool SimplifiedOptions::Check(std::string* why) const {
  if (fine_radius < 1 || fine_radius > 1000 || coarse_radius < 1 || coarse_radius > 1000) {
    return Fail(why, "fine_radius and coarse_radius must be in [1, 1000]");
  }
  if (!std::isfinite(fine_eps) || fine_eps <= 0 || !std::isfinite(coarse_eps) || coarse_eps <= 0) {
    return Fail(why, "fine_eps and coarse_eps must be > 0");
  }
  if (coarse_subsample < 1 || coarse_subsample > 8)
    return Fail(why, "coarse_subsample must be in [1, 8]");
  if (!std::isfinite(alpha) || alpha < 0 || alpha > 100)
    return Fail(why, "alpha must be in [0, 100]");
  std::string sub;
  if (!clahe.Check(&sub)) return Fail(why, "clahe: " + sub);
  return true;
}

namespace {

// I_g + alpha (I_f - I_g), as addWeighted(I_g, 1 - alpha, I_f, alpha).
TURBID_ROW_KERNEL void DetailBoostRow(const float* __restrict i_f, const float* __restrict i_g,
                                      float alpha, float one_minus_alpha, float* __restrict dst,
                                      int w) {
  for (int x = 0; x < w; ++x) dst[x] = i_g[x] * one_minus_alpha + i_f[x] * alpha;
}

// Clamped to [0, 1] (a loop of its own: GCC vectorises it alone, not after the arithmetic).
TURBID_ROW_KERNEL void ClampRow(float* __restrict v, int w) {
  for (int x = 0; x < w; ++x) v[x] = std::min(std::max(v[x], 0.0f), 1.0f);
}

// One-channel `simplified`, streamed: both guided filters by rows, the detail boost per row, then
// straight into CLAHE's bin indices; no full-size float intermediates (each costs ~1 ms of page
// faults). The input's finiteness is not scanned up front: a non-finite input value makes the
// boosted rows around it non-finite, which the binning (or, without CLAHE, RowIsFinite) detects.
cv::Mat SimplifiedGray(const SimplifiedOptions& o, const GuidedFilterOptions& fine,
                       const GuidedFilterOptions& coarse, const cv::Mat& image) {
  const int w = image.cols;
  const float a = static_cast<float>(o.alpha), one_minus_a = static_cast<float>(1.0 - o.alpha);
  cv::Mat out, bins;
  std::vector<float> boosted;
  if (o.contrast) {
    bins = ClaheNewBins(o.clahe, image.size());
    boosted.resize(w);
  } else {
    out.create(image.size(), CV_32F);
  }
  GuidedFilterSelfRows({fine, coarse}, image, [&](int y, const std::vector<const float*>& q) {
    float* dst = o.contrast ? boosted.data() : out.ptr<float>(y);
    DetailBoostRow(q[0], q[1], a, one_minus_a, dst, w);
    if (o.contrast) {
      ClaheBinRow(o.clahe, dst, bins, y);  // clamps to [0, 1] as it bins; throws if not finite
    } else {
      if (!RowIsFinite(dst, static_cast<size_t>(w))) {
        throw Error("simplified: the detail layers have non-finite values");
      }
      ClampRow(dst, w);
    }
  });
  // CLAHE's output is in [0, 1] already.
  return o.contrast ? ClaheFromBins(o.clahe, bins) : out;
}

// Output images above this size are written with non-temporal stores by SimplifiedColor.
constexpr size_t kStreamBytes = size_t{8} << 20;

// Three-channel `simplified`, streamed as the gray path is: both guided filters interleaved by
// rows, the boost, the clamp and CLAHE's luminance binning per row into the output buffer, then
// the colour CLAHE in place. The input is scanned for non-finite values only when a boosted row
// is not finite (the up-front check's error then; a finite input that overflows is clamped).
cv::Mat SimplifiedColor(const SimplifiedOptions& o, const GuidedFilterOptions& fine,
                        const GuidedFilterOptions& coarse, const cv::Mat& image) {
  const int n = image.cols * 3;
  cv::Mat out(image.size(), CV_32FC3), bins;
  // Images too large to stay in the last-level cache until CLAHE's pass reads them back are
  // written with non-temporal stores (smaller ones: the pass finds them in cache).
  const bool stream = o.contrast && out.total() * out.elemSize() > kStreamBytes;
  std::vector<float> lum(image.cols), row(stream ? n : 0);
  if (o.contrast) bins = ClaheNewBins(o.clahe, image.size());
  bool validated = false;
  [[maybe_unused]] const bool avx2 = enhancer_internal::UseHandWrittenAvx2(), fma = CpuHasFma();
  GuidedFilterSelfRows({fine, coarse}, image, [&](int y, const std::vector<const float*>& q) {
    float* dst = out.ptr<float>(y);
    bool finite;
#ifdef TURBID_HAVE_BOOST_AVX2
    if (avx2) {
      float* next_dst = nullptr;
      float* stream_dst = nullptr;
      if (stream && reinterpret_cast<uintptr_t>(dst) % 32 == 0) {
        // CLAHE's binning reads the row from `row` (still in L1); the image row is written with
        // non-temporal stores (no read of its old contents).
        stream_dst = dst;
        dst = row.data();
      } else if (y + 1 < image.rows) {
        next_dst = out.ptr<float>(y + 1);  // fetched for writing while this row is boosted
      }
      finite = fma ? BoostClampRowAvx2<true>(q[1], q[0], 1.0 - o.alpha, o.alpha, dst, n, next_dst,
                                             stream_dst)
                   : BoostClampRowAvx2<false>(q[1], q[0], 1.0 - o.alpha, o.alpha, dst, n, next_dst,
                                              stream_dst);
    } else
#endif
    {
      AddWeightedRow(q[1], q[0], 1.0 - o.alpha, o.alpha, dst, n);
      finite = RowIsFinite(dst, static_cast<size_t>(n));
      ClampUnitRow(dst, n);
    }
    if (!validated && !finite) {
      ValidateEnhanceImage(image, "simplified");
      validated = true;
    }
    if (o.contrast) ClaheBinColorRow(o.clahe, dst, lum.data(), bins, y);
  });
#if defined(__x86_64__)
  _mm_sfence();  // the non-temporal stores ordered before CLAHE's reads
#endif
  if (o.contrast) ClaheColorFromBins(o.clahe, bins, out);  // in [0, 1]
  return out;
}

}  // namespace

cv::Mat SimplifiedEnhance(const SimplifiedOptions& o, const cv::Mat& image) {
  ThrowIfInvalid(o, "simplified");
  ValidateEnhanceImageLayout(image, "simplified");
  GuidedFilterOptions fine, coarse;
  fine.radius = o.fine_radius;
  fine.eps = o.fine_eps;
  coarse.radius = o.coarse_radius;
  coarse.eps = o.coarse_eps;
  coarse.subsample = o.coarse_subsample;
  if (image.channels() == 1) {
    try {
      return SimplifiedGray(o, fine, coarse, image);
    } catch (const Error&) {
      ValidateEnhanceImage(image, "simplified");  // a non-finite input: say where
      throw;
    }
  }
  if (image.channels() == 3) return SimplifiedColor(o, fine, coarse, image);
  ValidateEnhanceImage(image, "simplified");
  const cv::Mat i_f = GuidedFilterSelf(fine, image);
  const cv::Mat i_g = GuidedFilterSelf(coarse, image);
  cv::Mat out;
  cv::addWeighted(i_g, 1.0 - o.alpha, i_f, o.alpha, 0.0, out);  // I_g + alpha (I_f - I_g)
  ClampUnit(out);
  if (o.contrast) out = Clahe(o.clahe, out);
  ClampUnit(out);
  return out;
}

// ---------------------------------------------------------------------------------------------

namespace {

void BindClahe(ParamBinder& b, const std::string& prefix, ClaheOptions* c, std::string* dist) {
  b.Bind(prefix + "tiles_x", &c->tiles_x);
  b.Bind(prefix + "tiles_y", &c->tiles_y);
  b.Bind(prefix + "clip_limit", &c->clip_limit);
  b.Bind(prefix + "bins", &c->bins);
  b.Bind(prefix + "distribution", dist);
  b.Bind(prefix + "alpha", &c->alpha);
}

std::vector<MethodParam> ClahePar(const std::string& prefix, const ClaheOptions& c) {
  return {
      Param(prefix + "tiles_x", c.tiles_x, "CLAHE tiles along x, >= 2 (adapthisteq: 8)",
            SizeBound::kPerAxis),
      Param(prefix + "tiles_y", c.tiles_y, "CLAHE tiles along y, >= 2 (adapthisteq: 8)",
            SizeBound::kPerAxis),
      Param(prefix + "clip_limit", c.clip_limit, "CLAHE clip limit as a fraction, [0,1] (0.01)"),
      Param(prefix + "bins", c.bins, "CLAHE histogram bins, [2, 65536] (256)"),
      Param(prefix + "distribution", ClaheDistributionName(c.distribution),
            "CLAHE target: uniform | rayleigh | exponential (paper: rayleigh)"),
      Param(prefix + "alpha", c.alpha, "Rayleigh/exponential parameter, > 0 (paper: 0.4)"),
  };
}

}  // namespace

FullOptions FullVariantDefaults(const std::string& variant) {
  FullOptions o;
  if (variant == "full") return o;
  // The variants keep the paper's reading of the clamp (t >= 0.1): `full_literal` is the paper as
  // written, `full_matched` / `full_physical` know the true beta (no over-correction to guard);
  // and the paper's CLAHE target, Rayleigh alpha 0.4.
  o.t_min = 0.1;
  o.clahe.alpha = ClaheOptions().alpha;
  if (variant == "full_literal") {
    o.light_scaling = "range";
    o.denoise_adaptive = false;
    o.keep_detail = 0;
    o.exposure_percentile = 0;
  } else if (variant == "full_matched") {
    o.beta_source = "auto";
  } else if (variant == "full_physical") {
    o.light_scaling = "physical";
    o.beta_source = "auto";
    o.exposure_percentile = 0;
  } else {
    throw Error("unknown variant of full '" + variant + "'");
  }
  return o;
}

bool FullOptionsArePrivileged(const FullOptions& o) {
  return o.beta_source == "auto" || o.light_scaling == "physical";
}

FullOptions FullOptionsFromJson(const nlohmann::json& params, const std::string& variant) {
  FullOptions o = FullVariantDefaults(variant);
  ParamBinder b(variant, params);
  b.Bind("denoise", &o.denoise);
  b.Bind("denoise_radius", &o.denoise_radius);
  b.Bind("denoise_eps", &o.denoise_eps);
  b.Bind("denoise_adaptive", &o.denoise_adaptive);
  b.Bind("denoise_noise_factor", &o.denoise_noise_factor);
  b.Bind("light", &o.light);
  b.Bind("light_scaling", &o.light_scaling);
  b.Bind("light_scale_percentile", &o.light_scale_percentile);
  b.Bind("light_scale_support", &o.light_scale_support);
  b.Bind("light_subsample", &o.light_subsample);
  b.Bind("dehaze", &o.dehaze);
  b.Bind("beta_per_m", &o.beta_per_m);
  // A beta the user names is the beta they want: it wins over a sidecar's water unless
  // beta_source says otherwise.
  if (params.is_object() && params.contains("beta_per_m")) o.beta_source = "fixed";
  b.Bind("beta_source", &o.beta_source);
  b.Bind("t_min", &o.t_min);
  b.Bind("exposure_percentile", &o.exposure_percentile);
  b.Bind("keep_detail", &o.keep_detail);
  b.Bind("plane", &o.plane);
  b.Bind("frontal_distance_m", &o.frontal_distance_m);
  b.Bind("max_range_m", &o.max_range_m);
  b.Bind("deblur", &o.deblur);
  b.Bind("psf_optical_thickness", &o.psf_optical_thickness);
  b.Bind("psf_forward_scatter", &o.psf_forward_scatter);
  std::string deconv = DeconvolutionMethodName(o.deconvolution.method);
  b.Bind("deconvolution", &deconv);
  b.Bind("nsr", &o.deconvolution.nsr);
  b.Bind("iterations", &o.deconvolution.iterations);
  b.Bind("contrast", &o.contrast);
  // An alpha the user names is the alpha they want, unless clahe_target_mean says otherwise.
  if (params.is_object() && params.contains("clahe_alpha")) o.clahe_target_mean = false;
  b.Bind("clahe_target_mean", &o.clahe_target_mean);
  b.Bind("clahe_min_mean", &o.clahe_min_mean);
  std::string dist = ClaheDistributionName(o.clahe.distribution);
  BindClahe(b, "clahe_", &o.clahe, &dist);
  b.FinishKeys();
  try {
    o.deconvolution.method = DeconvolutionMethodFromName(deconv);
    o.clahe.distribution = ClaheDistributionFromName(dist);
  } catch (const Error& e) {
    throw Error(variant + ": " + e.what());
  }
  b.Finish(o);
  return o;
}

namespace {

SimplifiedOptions BindSimplified(const nlohmann::json& params) {
  SimplifiedOptions o;
  ParamBinder b("simplified", params);
  b.Bind("fine_radius", &o.fine_radius);
  b.Bind("fine_eps", &o.fine_eps);
  b.Bind("coarse_radius", &o.coarse_radius);
  b.Bind("coarse_eps", &o.coarse_eps);
  b.Bind("coarse_subsample", &o.coarse_subsample);
  b.Bind("alpha", &o.alpha);
  b.Bind("contrast", &o.contrast);
  std::string dist = ClaheDistributionName(o.clahe.distribution);
  BindClahe(b, "clahe_", &o.clahe, &dist);
  b.FinishKeys();
  try {
    o.clahe.distribution = ClaheDistributionFromName(dist);
  } catch (const Error& e) {
    throw Error(std::string("simplified: ") + e.what());
  }
  b.Finish(o);
  return o;
}

// What each variant of `full` reads besides the image (docs/methods.md).
std::string FullInputs(const FullOptions& d) {
  std::string inputs =
      "plane (DVL points, else a plane fitted to the scene depth); camera; LED geometry from the "
      "vehicle's specification (the sidecar's options.light)";
  inputs += d.light_scaling == "physical" ? ", with the LED power in image units (true)"
                                          : ", not its power";
  inputs += d.beta_source == "auto" ? "; beta: the sidecar's water (true)" : "; beta: fixed 0.7 /m";
  return inputs;
}

MethodEntry FullEntry(const std::string& variant) {
  const FullOptions d = FullVariantDefaults(variant);
  MethodEntry e;
  e.info.name = variant;
  const std::string steps =
      "denoise, light estimate, plane-induced dehazing, PSF deconvolution, CLAHE";
  if (variant == "full") {
    e.info.summary = "paper full model (" + steps + "), light scale estimated blind";
  } else if (variant == "full_literal") {
    e.info.summary = "paper full model as written: E_L fitted into [min I, max I] (§III-A.2)";
  } else if (variant == "full_matched") {
    e.info.summary = "full with the true water (beta per channel from the sidecar): privileged";
  } else {
    e.info.summary =
        "full with the true water and the light's true power in image units: privileged";
  }
  e.info.source =
      "the reproduced paper (Visibility Enhancement for Underwater Visual SLAM), §III-A, eqs. 4-7";
  e.info.needs_geometry = true;
  e.info.privileged = FullOptionsArePrivileged(d);
  e.info.inputs = FullInputs(d);
  e.info.params = {
      Param("denoise", d.denoise, "step 1: guided-filter denoise (eq. 4)"),
      Param("denoise_radius", d.denoise_radius, "guided filter k, pixels (paper: 4)",
            SizeBound::kRadius),
      Param("denoise_eps", d.denoise_eps, "guided filter epsilon on [0,1] data (paper: 0.1^2)"),
      Param("denoise_adaptive", d.denoise_adaptive,
            "epsilon scaled by t_med^2, floored at (factor * noise sigma)^2 (false: as given)"),
      Param("denoise_noise_factor", d.denoise_noise_factor,
            "adaptive denoise: multiple of the Immerkaer noise estimate, [0, 100]"),
      Param("light", d.light, "step 2: artificial-light estimate (eq. 5; lights from the sidecar)"),
      Param("light_scaling", d.light_scaling,
            "blind: scale estimated from the veil | range: E_L mapped onto [min I, max I] (paper "
            "as written) | physical: E_L as modelled (privileged)"),
      Param("light_scale_percentile", d.light_scale_percentile,
            "blind: percentile of I_de / ((1 - t) L), %, (0, 50]"),
      Param("light_scale_support", d.light_scale_support,
            "blind: share of max (1 - t) L a pixel needs to count, (0, 1)"),
      Param("light_subsample", d.light_subsample, "E_L and t computed at 1/this size, [1, 64]"),
      Param("dehaze", d.dehaze, "step 3: plane-induced dehazing (eq. 6)"),
      Param("beta_per_m", d.beta_per_m,
            "attenuation in t = exp(-beta r), 1/m (paper: 0.7); setting it implies beta_source "
            "fixed"),
      Param("beta_source", d.beta_source,
            "fixed: beta_per_m | auto: the sidecar's water (per channel) when given (privileged)"),
      Param("t_min", d.t_min, "lower clamp on t in eq. 6, (0, 1]"),
      Param("exposure_percentile", d.exposure_percentile,
            "J_plane divided by this percentile when above 1 (0: clip), [0, 100]"),
      Param("keep_detail", d.keep_detail,
            "weight of the denoising residual added back after dehazing (0: discarded), [0, 10]"),
      Param("plane", d.plane, "plane source: auto | dvl | depth | scene | frontal"),
      Param("frontal_distance_m", d.frontal_distance_m,
            "distance of the fallback frontal plane, m"),
      Param("max_range_m", d.max_range_m, "range where a ray misses the plane, m"),
      Param("deblur", d.deblur, "step 4: PSF deconvolution (eq. 7)"),
      Param("psf_optical_thickness", d.psf_optical_thickness, "PSF T (paper: 4)"),
      Param("psf_forward_scatter", d.psf_forward_scatter, "PSF q (paper: 0.9)"),
      Param("deconvolution", DeconvolutionMethodName(d.deconvolution.method),
            "wiener | richardson_lucy"),
      Param("nsr", d.deconvolution.nsr, "Wiener noise-to-signal ratio, [1e-8, 10]"),
      Param("iterations", d.deconvolution.iterations, "Richardson-Lucy iterations, [1, 1000]"),
      Param("contrast", d.contrast, "step 5: CLAHE"),
      Param("clahe_target_mean", d.clahe_target_mean,
            "CLAHE alpha chosen per image so the output keeps the restored image's mean (at "
            "least clahe_min_mean) instead of clahe_alpha; naming clahe_alpha implies false"),
      Param("clahe_min_mean", d.clahe_min_mean,
            "floor of the kept mean (an underexposed image is brought up to it), [0, 0.6]"),
  };
  for (MethodParam& p : ClahePar("clahe_", d.clahe)) e.info.params.push_back(p);
  e.run = [variant](const nlohmann::json& params, const EnhanceInput& in) {
    return FullEnhance(FullOptionsFromJson(params, variant), in.image, in.scene, in.sidecar);
  };
  e.privileged_with = [variant](const nlohmann::json& params) {
    return FullOptionsArePrivileged(FullOptionsFromJson(params, variant));
  };
  return e;
}

MethodEntry SimplifiedEntry() {
  const SimplifiedOptions d;
  MethodEntry e;
  e.info.name = "simplified";
  e.info.summary = "paper simplified model: dual guided-filter detail boost, then CLAHE";
  e.info.source = "the reproduced paper §III-B, eqs. 8-9 (after He et al. TPAMI 2013 §4.2)";
  e.info.inputs = "";  // the image alone
  e.info.params = {
      Param("fine_radius", d.fine_radius, "k_f, pixels (paper: 2)", SizeBound::kRadius),
      Param("fine_eps", d.fine_eps, "sigma_f on [0,1] data (paper: 0.1^2)"),
      Param("coarse_radius", d.coarse_radius, "k_g, pixels (paper: 8)", SizeBound::kRadius),
      Param("coarse_eps", d.coarse_eps, "sigma_g on [0,1] data (paper: 0.4^2)"),
      Param("coarse_subsample", d.coarse_subsample, "fast guided filter ratio for I_g, 1 = exact"),
      Param("alpha", d.alpha, "detail amplification (paper: 5)"),
      Param("contrast", d.contrast, "CLAHE after the detail boost"),
  };
  for (MethodParam& p : ClahePar("clahe_", d.clahe)) e.info.params.push_back(p);
  e.run = [](const nlohmann::json& params, const EnhanceInput& in) {
    SimplifiedOptions o = BindSimplified(params);
    o.clahe.rgb = in.rgb;  // the guided filters and the detail boost are per channel
    return SimplifiedEnhance(o, in.image);
  };
  e.rgb_native = true;
  return e;
}

}  // namespace

std::vector<MethodEntry> PaperMethodEntries() {
  return {FullEntry("full"), FullEntry("full_literal"), FullEntry("full_matched"),
          FullEntry("full_physical"), SimplifiedEntry()};
}

}  // namespace turbid
