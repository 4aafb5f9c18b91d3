// `full`'s step 2 (§III-A.2): the light model's E_L on the plane, its scale into image units
// (range, physical, or blind: the veil fit of docs/methods.md, "Blind light scale").
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/row_kernel.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/full_internal.h"
#include "enhancer/select.h"

namespace turbid {
namespace paper_internal {
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
}  // namespace paper_internal

using paper_internal::LightModelMap;

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

namespace paper_internal {
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
// pixel gives each channel the same regressors (t, (1 - t) L, t L). The samples are kept as five
// float columns (t, L and the three channels) and the kernels below run four samples per vector
// (GCC/Clang vector extensions, no FMA: every clone rounds alike). A value a kernel writes per
// sample (ratio, residual) is the scalar expression's, bit for bit; the normal equations' sums are
// four partial sums per term, one per lane, added at the end as (lane 0 + lane 1) + (lane 2 +
// lane 3). That order differs from FitVeilModel's sample order, so a fit may move by a few double
// roundings (issue 29 item 6 allows 1e-5 relative). Pass 1 adds a residual-rejected sample as
// +0.0, as do the pad lanes past the last sample (t = L = v = 0: every product is +0.0).
typedef double VeilD4 __attribute__((vector_size(32)));
typedef long long VeilL4 __attribute__((vector_size(32)));
typedef float VeilF4 __attribute__((vector_size(16)));
typedef int VeilI4 __attribute__((vector_size(16)));

// The samples' columns: sample i is t[i], l[i], v[c][i]. Each column holds n rounded up to a
// multiple of 4 values, the pad ones +0.0.
struct VeilColumns {
  const float* t;
  const float* l;
  const float* v[3];
  size_t n;
};

inline size_t RoundUp4(size_t n) { return (n + 3) & ~size_t{3}; }

inline VeilF4 LoadF4(const float* p) {
  VeilF4 f;
  std::memcpy(&f, p, sizeof(f));
  return f;
}
// The lanes' magnitudes (the sign bit cleared).
constexpr VeilL4 kVeilAbs = {0x7fffffffffffffffLL, 0x7fffffffffffffffLL, 0x7fffffffffffffffLL,
                             0x7fffffffffffffffLL};
inline double SumLanes(const VeilD4& a) { return (a[0] + a[1]) + (a[2] + a[3]); }

// Pass 0's sums: s00, s01, s02, s11, s12, s22 (every channel's), then b0, b1, b2 of channel 0, 1
// and 2 (out[6 + 3 c + j]).
TURBID_ROW_KERNEL void VeilSumsAll3(VeilColumns s, double out[15]) {
  VeilD4 acc[15] = {};
  for (size_t i = 0; i < s.n; i += 4) {
    const VeilD4 x0 = __builtin_convertvector(LoadF4(s.t + i), VeilD4),
                 l = __builtin_convertvector(LoadF4(s.l + i), VeilD4);
    const VeilD4 x1 = (1.0 - x0) * l, x2 = x0 * l;
    acc[0] += x0 * x0, acc[1] += x0 * x1, acc[2] += x0 * x2;
    acc[3] += x1 * x1, acc[4] += x1 * x2, acc[5] += x2 * x2;
    for (int c = 0; c < 3; ++c) {
      const VeilD4 v = __builtin_convertvector(LoadF4(s.v[c] + i), VeilD4);
      acc[6 + 3 * c] += x0 * v, acc[7 + 3 * c] += x1 * v, acc[8 + 3 * c] += x2 * v;
    }
  }
  for (int j = 0; j < 15; ++j) out[j] = SumLanes(acc[j]);
}

// |c0 x0 + c1 x1 + c2 x2 - v| of every sample (pad lanes too), channel c's into r[c][i];
// coef[j][c]: channel c's c_j.
TURBID_ROW_KERNEL void VeilResiduals3(VeilColumns s, const double (*coef)[3], double* __restrict r0,
                                      double* __restrict r1, double* __restrict r2) {
  double* const r[3] = {r0, r1, r2};
  for (size_t i = 0; i < s.n; i += 4) {
    const VeilD4 x0 = __builtin_convertvector(LoadF4(s.t + i), VeilD4),
                 l = __builtin_convertvector(LoadF4(s.l + i), VeilD4);
    const VeilD4 x1 = (1.0 - x0) * l, x2 = x0 * l;
    for (int c = 0; c < 3; ++c) {
      const VeilD4 d = coef[0][c] * x0 + coef[1][c] * x1 + coef[2][c] * x2 -
                       __builtin_convertvector(LoadF4(s.v[c] + i), VeilD4);
      const VeilL4 abs_d = reinterpret_cast<VeilL4>(d) & kVeilAbs;
      std::memcpy(r[c] + i, &abs_d, sizeof(abs_d));
    }
  }
}

// Pass 1's sums for channel c (s00 .. s22, b0, b1, b2), over the samples whose residual
// (recomputed as above) is <= cut; coef: c0, c1, c2.
TURBID_ROW_KERNEL void VeilSumsKept(VeilColumns s, int c, const double coef[3], double cut,
                                    double out[9]) {
  VeilD4 acc[9] = {};
  for (size_t i = 0; i < s.n; i += 4) {
    const VeilD4 x0 = __builtin_convertvector(LoadF4(s.t + i), VeilD4),
                 l = __builtin_convertvector(LoadF4(s.l + i), VeilD4),
                 v = __builtin_convertvector(LoadF4(s.v[c] + i), VeilD4);
    const VeilD4 x1 = (1.0 - x0) * l, x2 = x0 * l;
    const VeilD4 d = coef[0] * x0 + coef[1] * x1 + coef[2] * x2 - v;
    const VeilL4 keep = reinterpret_cast<VeilD4>(reinterpret_cast<VeilL4>(d) & kVeilAbs) <= cut;
    const VeilD4 p[9] = {x0 * x0, x0 * x1, x0 * x2, x1 * x1, x1 * x2,
                         x2 * x2, x0 * v,  x1 * v,  x2 * v};
    for (int j = 0; j < 9; ++j) {
      acc[j] += reinterpret_cast<VeilD4>(reinterpret_cast<VeilL4>(p[j]) & keep);
    }
  }
  for (int j = 0; j < 9; ++j) out[j] = SumLanes(acc[j]);
}

// Channel c's veil ratios max(v, 0) / w, w = (1 - t) L (in double) rounded to float, of the
// samples with w >= w_min, in sample order into r[c][0 ..) (each r[c] holds n rounded up to 4: a
// rejected sample is written past the kept ones, then overwritten). The ratio is a float division:
// the correctly rounded quotient, which is also the double quotient rounded to float (double
// rounding is innocuous for a quotient of floats, 53 >= 2 * 24 + 2 bits), as the general loop's.
// Returns how many samples were kept.
TURBID_ROW_KERNEL size_t VeilRatios3(VeilColumns s, float w_min, float* __restrict r0,
                                     float* __restrict r1, float* __restrict r2) {
  const VeilI4 lane = {0, 1, 2, 3};
  size_t m = 0;
  for (size_t i = 0; i < s.n; i += 4) {
    const int valid = s.n - i < 4 ? static_cast<int>(s.n - i) : 4;
    const VeilD4 t = __builtin_convertvector(LoadF4(s.t + i), VeilD4),
                 l = __builtin_convertvector(LoadF4(s.l + i), VeilD4);
    const VeilF4 w = __builtin_convertvector((1.0 - t) * l, VeilF4);
    const VeilI4 keep = (w >= w_min) & (lane < valid);
    VeilF4 ratio[3];
    for (int c = 0; c < 3; ++c) {
      const VeilF4 v = LoadF4(s.v[c] + i);
      const VeilF4 positive =  // std::max(v, 0): +0 where v < 0, else v (-0 stays)
          reinterpret_cast<VeilF4>(reinterpret_cast<VeilI4>(v) & ~(v < 0.0f));
      ratio[c] = positive / w;
    }
    for (int k = 0; k < 4; ++k) {  // branch-free compaction
      r0[m] = ratio[0][k], r1[m] = ratio[1][k], r2[m] = ratio[2][k];
      m += static_cast<size_t>(keep[k] & 1);
    }
  }
  return m;
}

// The largest veil weight (1 - t) L (in float) of samples 0 .. n, at least +0: four running
// maxima per lane; a NaN weight never replaces one, so the value is LargestVeilWeight's (the pad
// samples' weight is +0).
TURBID_ROW_KERNEL float LargestVeilWeightOf(const float* __restrict t, const float* __restrict l,
                                            size_t n) {
  VeilF4 m = {0.0f, 0.0f, 0.0f, 0.0f};
  for (size_t i = 0; i < n; i += 4) {
    const VeilF4 w = (1.0f - LoadF4(t + i)) * LoadF4(l + i);
    const VeilI4 larger = w > m;
    m = reinterpret_cast<VeilF4>((reinterpret_cast<VeilI4>(w) & larger) |
                                 (reinterpret_cast<VeilI4>(m) & ~larger));
  }
  return std::max(std::max(m[0], m[1]), std::max(m[2], m[3]));
}

// True when none of p[0 .. n) is infinite or NaN.
TURBID_ROW_KERNEL bool AllFinite(const float* p, size_t n) {
  uint32_t largest = 0;  // the largest magnitude's bits
  for (size_t i = 0; i < n; ++i) {
    uint32_t u;
    std::memcpy(&u, p + i, sizeof(u));
    largest = std::max(largest, u & 0x7fffffffu);
  }
  return largest < 0x7f800000u;
}

// The normal equations (the shared sums s00 .. s22 and one channel's b0, b1, b2) solved as
// FitVeilModel does: false when singular or ill-conditioned.
bool SolveVeil(const double* s, const double* b, cv::Vec3d* solution) {
  const cv::Matx33d ata(s[0], s[1], s[2], s[1], s[3], s[4], s[2], s[4], s[5]);
  return SolveVeilNormalEquations(ata, cv::Vec3d(b[0], b[1], b[2]), solution);
}

// FitVeilModel for three channels whose samples share t and L.
void FitVeilModel3(const VeilColumns& s, bool ok[3], cv::Vec3d fit[3]) {
  const size_t n = s.n;
  for (int c = 0; c < 3; ++c) ok[c] = n >= 16;
  if (n < 16) return;
  double sums[15];
  VeilSumsAll3(s, sums);
  for (int c = 0; c < 3; ++c) ok[c] = SolveVeil(sums, sums + 6 + 3 * c, &fit[c]);
  if (!ok[0] && !ok[1] && !ok[2]) return;
  double coef[3][3];  // coef[j][c]: channel c's c_j
  for (int j = 0; j < 3; ++j) {
    for (int c = 0; c < 3; ++c) coef[j][c] = ok[c] ? fit[c][j] : 0.0;
  }
  ScratchVector<double> r[3] = {ScratchVector<double>(RoundUp4(n)),
                                ScratchVector<double>(RoundUp4(n)),
                                ScratchVector<double>(RoundUp4(n))};
  VeilResiduals3(s, coef, r[0].data(), r[1].data(), r[2].data());
  for (int c = 0; c < 3; ++c) {
    if (!ok[c]) continue;
    r[c].resize(n);
    const double cut = enhancer_internal::SelectKth<double, uint64_t>(r[c], n * 8 / 10);
    const double channel_coef[3] = {coef[0][c], coef[1][c], coef[2][c]};
    double kept[9];
    VeilSumsKept(s, c, channel_coef, cut, kept);
    ok[c] = SolveVeil(kept, kept + 6, &fit[c]) && std::isfinite(fit[c][0]) &&
            std::isfinite(fit[c][1]) && std::isfinite(fit[c][2]);
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

// dst[j] = src[j * stride * step] for j < count (kStride > 0: stride is kStride).
template <int kStride>
void GatherColumn(const float* __restrict src, int step, int count, int stride,
                  float* __restrict dst) {
  const ptrdiff_t at = static_cast<ptrdiff_t>(kStride > 0 ? kStride : stride) * step;
  for (int j = 0; j < count; ++j) dst[j] = src[j * at];
}

// Drops the samples (columns t, l, v0, v1, v2 of n) whose L is not finite, keeping the order;
// false when a kept sample's value is not finite (EstimateLightScale's general loop then decides).
bool DropUnlitSamples(ScratchVector<float> (&cols)[5], size_t* n) {
  float* t = cols[0].data();
  float* l = cols[1].data();
  float* v[3] = {cols[2].data(), cols[3].data(), cols[4].data()};
  size_t kept = 0;
  for (size_t i = 0; i < *n; ++i) {
    if (!std::isfinite(l[i])) continue;
    if (!std::isfinite(v[0][i]) || !std::isfinite(v[1][i]) || !std::isfinite(v[2][i])) {
      return false;
    }
    t[kept] = t[i], l[kept] = l[i];
    for (int c = 0; c < 3; ++c) v[c][kept] = v[c][i];
    ++kept;
  }
  *n = kept;
  return true;
}

// EstimateLightScale for a three-channel image with one-channel t and L maps, when every channel
// keeps every grid pixel (the sample sets are then the same; false, nothing written, when a
// channel's value is not finite where L is). w_max is taken from the grid columns (nothing
// written when it is not positive and finite: no channel is active). The ratios and samples are
// those of the general loop, in grid order; the fits run side by side (FitVeilModel3).
bool LightScaleShared3(const cv::Mat& denoised, GridRows light, GridRows transmission, int stride,
                       double support, double percentile, std::vector<LightScaleEstimate>* out) {
  const size_t expected = static_cast<size_t>((denoised.rows + stride - 1) / stride) *
                          static_cast<size_t>((denoised.cols + stride - 1) / stride);
  // Columns t, L, v0, v1, v2 of every grid pixel, in grid order (written before read, so not
  // zero-filled: ScratchVector).
  ScratchVector<float> cols[5];
  for (ScratchVector<float>& col : cols) col.resize(RoundUp4(expected));
  size_t n = 0;
  for (int y = 0; y < denoised.rows; y += stride) {
    const int count = (denoised.cols + stride - 1) / stride;
    const float* in = denoised.ptr<float>(y);
    if (stride == 2) {  // the usual stride (640 x 480 to 1023 x 767 pixels): a constant step
      GatherColumn<2>(transmission(y), 1, count, 2, cols[0].data() + n);
      GatherColumn<2>(light(y), 1, count, 2, cols[1].data() + n);
      for (int c = 0; c < 3; ++c) GatherColumn<2>(in + c, 3, count, 2, cols[2 + c].data() + n);
    } else {
      GatherColumn<0>(transmission(y), 1, count, stride, cols[0].data() + n);
      GatherColumn<0>(light(y), 1, count, stride, cols[1].data() + n);
      for (int c = 0; c < 3; ++c) {
        GatherColumn<0>(in + c, 3, count, stride, cols[2 + c].data() + n);
      }
    }
    n += static_cast<size_t>(count);
  }
  for (ScratchVector<float>& col : cols) std::fill(col.begin() + n, col.begin() + RoundUp4(n), 0.f);
  const float w_max = LargestVeilWeightOf(cols[0].data(), cols[1].data(), n);
  if (!(w_max > 0.0f) || !std::isfinite(w_max)) return true;  // no channel is active
  const float w_min = static_cast<float>(support) * w_max;
  bool finite = true;
  for (const ScratchVector<float>& col : cols) finite = finite && AllFinite(col.data(), n);
  if (!finite) {  // some L is not finite (unlit): drop those samples, pad the columns again
    if (!DropUnlitSamples(cols, &n)) return false;
    for (ScratchVector<float>& col : cols) {
      std::fill(col.begin() + n, col.begin() + RoundUp4(n), 0.f);
    }
  }
  const VeilColumns s{
      cols[0].data(), cols[1].data(), {cols[2].data(), cols[3].data(), cols[4].data()}, n};
  ScratchVector<float> ratios[3] = {ScratchVector<float>(RoundUp4(n)),
                                    ScratchVector<float>(RoundUp4(n)),
                                    ScratchVector<float>(RoundUp4(n))};
  const size_t m = VeilRatios3(s, w_min, ratios[0].data(), ratios[1].data(), ratios[2].data());
  if (m == 0) return true;  // no pixel carries the veil: no estimate, as in the general loop
  bool fit_ok[3];
  cv::Vec3d fit[3];
  FitVeilModel3(s, fit_ok, fit);
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

// Channel c's largest veil weight (1 - t) L on the grid, at least +0. Four running maxima (one
// chain waited on each maxss); the same value as one: a NaN product never replaces a maximum.
float LargestVeilWeight(const cv::Mat& denoised, GridRows light, GridRows transmission, int stride,
                        int c) {
  const int lc = light.channels(), tc = transmission.channels();
  const int l_at = lc == 1 ? 0 : c, t_at = tc == 1 ? 0 : c;
  float m[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  for (int y = 0; y < denoised.rows; y += stride) {
    const float* t = transmission(y);
    const float* l = light(y);
    int x = 0, k = 0;
    for (; x + 3 * stride < denoised.cols; x += 4 * stride) {
      for (int j = 0; j < 4; ++j) {
        const int xj = x + j * stride;
        m[j] = std::max(m[j], (1.0f - t[xj * tc + t_at]) * l[xj * lc + l_at]);
      }
    }
    for (; x < denoised.cols; x += stride, k = (k + 1) & 3) {
      m[k] = std::max(m[k], (1.0f - t[x * tc + t_at]) * l[x * lc + l_at]);
    }
  }
  return std::max(std::max(m[0], m[1]), std::max(m[2], m[3]));
}

// EstimateLightScale on maps given as GridRows (the checks done, `stride` > 0).
std::vector<LightScaleEstimate> EstimateLightScaleGrid(const cv::Mat& denoised, GridRows light,
                                                       GridRows transmission, double percentile,
                                                       double support, int stride) {
  const int ch = denoised.channels(), lc = light.channels(), tc = transmission.channels();
  CV_Assert(ch <= 4 && (lc == 1 || lc == ch) && (tc == 1 || tc == ch));
  std::vector<LightScaleEstimate> out(ch);
  if (ch == 3 && lc == 1 && tc == 1 &&
      LightScaleShared3(denoised, light, transmission, stride, support, percentile, &out)) {
    return out;
  }
  // Per channel: the largest veil weight w = (1 - t) L on the grid (one pass for every channel
  // when t and L have one channel each).
  std::vector<float> w_max(ch, 0.0f);
  for (int c = 0; c < ch; ++c) {
    if (c > 0 && lc == 1 && tc == 1) {
      w_max[c] = w_max[0];
      continue;
    }
    w_max[c] = LargestVeilWeight(denoised, light, transmission, stride, c);
  }
  std::vector<bool> active(ch);
  std::vector<float> w_min(ch);
  for (int c = 0; c < ch; ++c) {
    active[c] = w_max[c] > 0.0f && std::isfinite(w_max[c]);
    w_min[c] = static_cast<float>(support) * w_max[c];
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
}  // namespace paper_internal

using paper_internal::EstimateLightScaleGrid;
using paper_internal::GridRows;
using paper_internal::LightScaleStride;

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

namespace paper_internal {

namespace {

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

}  // namespace

// `t_rows`: the streamed colour path's t (r->transmission empty then); with it, E_L may be returned
// as rows too.
LightEstimate LightStepUnscaled(const FullOptions& o, const IrradianceOptions& lights,
                                const CameraIntrinsics& camera, const std::vector<double>& beta,
                                const cv::Mat& denoised, FullResult* r,
                                const enhancer_internal::LinearUpsampler* t_rows) {
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

}  // namespace paper_internal
}  // namespace turbid
