// `full`'s step 2 (§III-A.2): the light model's E_L on the plane, its scale into image units
// (range, physical, or blind: the veil fit of docs/methods.md, "Blind light scale").
#include <algorithm>
#include <cmath>
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
void FitVeilModel3(const ScratchVector<float>& t, const ScratchVector<float>& l,
                   const ScratchVector<float>& v, bool ok[3], cv::Vec3d fit[3]) {
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
  ScratchVector<double> r[3] = {ScratchVector<double>(n), ScratchVector<double>(n),
                                ScratchVector<double>(n)};
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
  // Written before read, so not zero-filled (ScratchVector).
  ScratchVector<float> ts(expected), ls(expected), vs(4 * expected);
  ScratchVector<float> ratios[3] = {ScratchVector<float>(expected), ScratchVector<float>(expected),
                                    ScratchVector<float>(expected)};
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
        // One division per pixel (issue 29 item 6: a ratio may move by a double rounding).
        const double inv_w = 1.0 / w;
        for (int c = 0; c < 3; ++c) {
          ratios[c][m] = static_cast<float>(std::max(static_cast<double>(v[c]), 0.0) * inv_w);
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
