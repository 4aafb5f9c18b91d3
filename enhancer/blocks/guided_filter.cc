#include "enhancer/blocks/guided_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "enhancer/blocks/box_filter.h"
#include "enhancer/simd_switch.h"
#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/image_pool.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace turbid {
namespace {

TURBID_ROW_KERNEL void MultiplyRows(const float* __restrict u, const float* __restrict v,
                                    float* __restrict out, int w) {
  for (int x = 0; x < w; ++x) out[x] = u[x] * v[x];
}

void CheckInputs(const GuidedFilterOptions& options, const cv::Mat& guide, const cv::Mat& src) {
  ThrowIfInvalid(options, "guided filter");
  if (guide.empty() || src.empty()) throw Error("guided filter: empty image");
  if (guide.depth() != CV_32F || src.depth() != CV_32F) {
    throw Error("guided filter: images must be float32");
  }
  if (guide.channels() != 1 && guide.channels() != 3) {
    throw Error("guided filter: guide must have 1 or 3 channels, got " +
                std::to_string(guide.channels()));
  }
  if (guide.size() != src.size()) {
    throw Error("guided filter: guide and source sizes differ");
  }
}

// Row kernels of the one-channel filter (TURBID_ROW_KERNEL). Each processes a whole row of
// contiguous floats, so the loops vectorise.

// Vertical running sums are float and re-anchored by direct summation every kAnchorRows rows, so
// rounding drift spans at most that many steps (the variance mean(I^2) - mean(I)^2 cancels, so a
// drift over a thousand rows would show in a = var / (var + eps)).
constexpr int kAnchorRows = 64;

TURBID_ROW_KERNEL void AddRows(float* __restrict dst, const float* __restrict a,
                               const float* __restrict b, int n) {
  for (int i = 0; i < n; ++i) dst[i] = a[i] + b[i];
}

TURBID_ROW_KERNEL void AccumulateRow(float* __restrict dst, const float* __restrict a, int n) {
  for (int i = 0; i < n; ++i) dst[i] += a[i];
}

// Sums of `window` (odd) consecutive values: out[x] = ext[x] + ... + ext[x + window - 1], x < w,
// where ext has w + window - 1 values (the row with zeros on both sides: the clipped window).
// Small windows: direct sums; larger: binary doubling (partial sums over 1, 2, 4, ... values, each
// pass a vectorised add) instead of a running sum: O(log window) passes without a serial dependency
// chain, and no drift.
template <int W>
TURBID_ROW_KERNEL void DirectWindowSums(const float* __restrict ext, float* __restrict out, int w) {
  for (int x = 0; x < w; ++x) {
    float s = ext[x];
    for (int k = 1; k < W; ++k) s += ext[x + k];
    out[x] = s;
  }
}

// Windows of 9+ values: sums of 4 first (one pass into tmp), then W/4 of those plus the rest.
template <int W>
TURBID_ROW_KERNEL void BlockedWindowSums(const float* __restrict ext, float* __restrict tmp,
                                         float* __restrict out, int w) {
  constexpr int kQuads = W / 4;
  const int n = w + 4 * (kQuads - 1);
  for (int x = 0; x < n; ++x) tmp[x] = ext[x] + ext[x + 1] + ext[x + 2] + ext[x + 3];
  for (int x = 0; x < w; ++x) {
    float s = tmp[x];
    for (int q = 1; q < kQuads; ++q) s += tmp[x + 4 * q];
    for (int k = 4 * kQuads; k < W; ++k) s += ext[x + k];
    out[x] = s;
  }
}

template <int R>
bool DirectWindowSumsUpTo(int r, const float* ext, float* tmp, float* out, int w) {
  if (r == R) {
    if constexpr (R >= 4) {
      BlockedWindowSums<2 * R + 1>(ext, tmp, out, w);
    } else {
      DirectWindowSums<2 * R + 1>(ext, out, w);
    }
    return true;
  }
  if constexpr (R > 1) return DirectWindowSumsUpTo<R - 1>(r, ext, tmp, out, w);
  return false;
}

void WindowSums(const float* ext, int w, int window, float* out, float* t0, float* t1) {
  // Radii up to 12 (the paper uses 2, 4 and 8): one pass with the window unrolled.
  if (DirectWindowSumsUpTo<12>(window / 2, ext, t0, out, w)) return;
  const int n = w + window - 1;
  const float* p = ext;  // p[i] = sum of `len` values from ext[i], valid for i <= n - len
  int len = 1, offset = 0, rest = window;
  bool first = true;
  float* bufs[2] = {t0, t1};
  int which = 0;
  for (;;) {
    if (rest & 1) {
      if (first) {
        std::copy(p + offset, p + offset + w, out);
      } else {
        AccumulateRow(out, p + offset, w);
      }
      first = false;
      offset += len;
    }
    rest >>= 1;
    if (rest == 0) break;
    float* q = bufs[which];
    which ^= 1;
    AddRows(q, p, p + len, n - 2 * len + 1);
    p = q;
    len *= 2;
  }
}

// The per-pixel formulas (He 2013 Alg. 1), from window sums and 1/N = inv_cx[x] * inv_cy; every
// kernel below uses these, so all paths round alike. Self-guided: a = var / (var + eps),
// b = m (1 - a). Guided: a = cov(I, p) / (var(I) + eps), b = mean p - a mean I. Output:
// q = (sum a * I + sum b) / N.
inline void SelfCoefficient(float s_i, float s_ii, float inv, float eps, float* a, float* b) {
  const float m = s_i * inv;
  const float var = s_ii * inv - m * m;
  const float av = var / (var + eps);
  *a = av;
  *b = m - av * m;
}

inline void GuidedCoefficient(float s_i, float s_p, float s_ii, float s_ip, float inv, float eps,
                              float* a, float* b) {
  const float mi = s_i * inv, mp = s_p * inv;
  const float var = s_ii * inv - mi * mi;
  const float cov = s_ip * inv - mi * mp;
  const float av = cov / (var + eps);
  *a = av;
  *b = mp - av * mi;
}

inline float ApplyCoefficient(float s_a, float s_b, float guide, float inv) {
  return (s_a * guide + s_b) * inv;
}

TURBID_ROW_KERNEL void SelfCoefficients(const float* __restrict s_i, const float* __restrict s_ii,
                                        const float* __restrict inv_cx, float inv_cy, float eps,
                                        float* __restrict a, float* __restrict b, int w) {
  for (int x = 0; x < w; ++x)
    SelfCoefficient(s_i[x], s_ii[x], inv_cx[x] * inv_cy, eps, a + x, b + x);
}

TURBID_ROW_KERNEL void GuidedCoefficients(const float* __restrict s_i, const float* __restrict s_p,
                                          const float* __restrict s_ii,
                                          const float* __restrict s_ip,
                                          const float* __restrict inv_cx, float inv_cy, float eps,
                                          float* __restrict a, float* __restrict b, int w) {
  for (int x = 0; x < w; ++x) {
    GuidedCoefficient(s_i[x], s_p[x], s_ii[x], s_ip[x], inv_cx[x] * inv_cy, eps, a + x, b + x);
  }
}

TURBID_ROW_KERNEL void ApplyCoefficients(const float* __restrict s_a, const float* __restrict s_b,
                                         const float* __restrict guide,
                                         const float* __restrict inv_cx, float inv_cy,
                                         float* __restrict q, int w) {
  for (int x = 0; x < w; ++x) q[x] = ApplyCoefficient(s_a[x], s_b[x], guide[x], inv_cx[x] * inv_cy);
}

// Fused row kernels for radii 1..12 (window W = 2r+1), so the window sums of a row are never
// stored: the coefficients (stage A) and the output (stage B) are computed straight from the
// padded column sums. Each window sum adds the same values in the same order as
// DirectWindowSums / BlockedWindowSums, so the results are bit-identical to the unfused passes.

// S is the distance between horizontally neighbouring values of one channel: 1 for one-channel
// rows, the channel count for interleaved rows (each channel is summed alone, in the same order).

// Sum of W consecutive values (S apart) from ext[x]; for W >= 9 from the sums of 4 in `quads`.
template <int W, int S = 1>
inline float WindowSumAt(const float* __restrict ext, const float* __restrict quads, int x) {
  if constexpr (W >= 9) {
    constexpr int kQuads = W / 4;
    float s = quads[x];
    for (int q = 1; q < kQuads; ++q) s += quads[x + 4 * S * q];
    for (int k = 4 * kQuads; k < W; ++k) s += ext[x + S * k];
    return s;
  } else {
    float s = ext[x];
    for (int k = 1; k < W; ++k) s += ext[x + S * k];
    return s;
  }
}

// Sums of 4 consecutive values of two padded rows (the first pass of BlockedWindowSums).
template <int W, int S = 1>
TURBID_ROW_KERNEL void QuadSumsPair(const float* __restrict e0, const float* __restrict e1,
                                    float* __restrict q0, float* __restrict q1, int w) {
  const int n = w + 4 * S * (W / 4 - 1);
  for (int x = 0; x < n; ++x) {
    q0[x] = e0[x] + e0[x + S] + e0[x + 2 * S] + e0[x + 3 * S];
    q1[x] = e1[x] + e1[x + S] + e1[x + 2 * S] + e1[x + 3 * S];
  }
}

// The same sums of 4 (one plane pair) for `count` positions from the given pointers: the
// chunked interleaved stream (GrayStream::Chunked) forms them piece by piece.
template <int S>
TURBID_ROW_KERNEL void QuadSumsRange(const float* __restrict e0, const float* __restrict e1,
                                     float* __restrict q0, float* __restrict q1, int count) {
  for (int x = 0; x < count; ++x) {
    q0[x] = e0[x] + e0[x + S] + e0[x + 2 * S] + e0[x + 3 * S];
    q1[x] = e1[x] + e1[x + S] + e1[x + 2 * S] + e1[x + 3 * S];
  }
}

// kUniform: every inv_cx[x] of the call equals inv_cx[0] (columns at least r from the border),
// which is read once: the same product per value, one load less.
template <int W, int S = 1, bool kUniform = false>
TURBID_ROW_KERNEL void SelfCoefficientsFused(
    const float* __restrict e_i, const float* __restrict e_ii, const float* __restrict q_i,
    const float* __restrict q_ii, const float* __restrict inv_cx, float inv_cy, float eps,
    float* __restrict a, float* __restrict b, int w) {
  const float cx = inv_cx[0];
  for (int x = 0; x < w; ++x) {
    SelfCoefficient(WindowSumAt<W, S>(e_i, q_i, x), WindowSumAt<W, S>(e_ii, q_ii, x),
                    (kUniform ? cx : inv_cx[x]) * inv_cy, eps, a + x, b + x);
  }
}

template <int W>
TURBID_ROW_KERNEL void GuidedCoefficientsFused(const float* const* __restrict e,
                                               const float* const* __restrict q,
                                               const float* __restrict inv_cx, float inv_cy,
                                               float eps, float* __restrict a, float* __restrict b,
                                               int w) {
  // Planes: 0 I, 1 I^2, 2 p, 3 I p (as GrayStream stores them).
  const float* __restrict e0 = e[0];
  const float* __restrict e1 = e[1];
  const float* __restrict e2 = e[2];
  const float* __restrict e3 = e[3];
  const float* __restrict q0 = q[0];
  const float* __restrict q1 = q[1];
  const float* __restrict q2 = q[2];
  const float* __restrict q3 = q[3];
  for (int x = 0; x < w; ++x) {
    GuidedCoefficient(WindowSumAt<W>(e0, q0, x), WindowSumAt<W>(e2, q2, x),
                      WindowSumAt<W>(e1, q1, x), WindowSumAt<W>(e3, q3, x), inv_cx[x] * inv_cy, eps,
                      a + x, b + x);
  }
}

template <int W, int S = 1, bool kUniform = false>
TURBID_ROW_KERNEL void ApplyCoefficientsFused(
    const float* __restrict e_a, const float* __restrict e_b, const float* __restrict q_a,
    const float* __restrict q_b, const float* __restrict guide, const float* __restrict inv_cx,
    float inv_cy, float* __restrict q, int w) {
  const float cx = inv_cx[0];
  for (int x = 0; x < w; ++x) {
    q[x] = ApplyCoefficient(WindowSumAt<W, S>(e_a, q_a, x), WindowSumAt<W, S>(e_b, q_b, x),
                            guide[x], (kUniform ? cx : inv_cx[x]) * inv_cy);
  }
}

// Window sums of W > 25 values as running sums on a stride of 8 (GuidedFilterGrayRunning): with
// the sums of 8 G(i) = ((e_i + e_i+1) + (e_i+2 + e_i+3)) + ((e_i+4 + e_i+5) + (e_i+6 + e_i+7)),
// out(x) = out(x - 8) + (G(x - 8 + W) - G(x - 8)), so 8 neighbouring outputs advance together as
// one vector; at x = 0, 128, 256, ... (8 outputs each) the direct sum G(x) + G(x + 8) + ... +
// G(x + 8 (W / 8 - 1)) + e_{x + 8 (W / 8)} + ... + e_{x + W - 1} restarts them, so rounding drifts
// over at most 15 steps. About half the additions of the doubling tree; not its rounding.
constexpr int kRunningAnchorCols = 128;

TURBID_ROW_KERNEL void EightSums(const float* __restrict e, int count, float* __restrict g) {
  for (int i = 0; i < count; ++i) {
    g[i] = ((e[i] + e[i + 1]) + (e[i + 2] + e[i + 3])) +
           ((e[i + 4] + e[i + 5]) + (e[i + 6] + e[i + 7]));
  }
}

inline float AnchoredWindowSum(const float* e, const float* g, int x, int window) {
  const int k = window / 8;
  float s = g[x];
  for (int j = 1; j < k; ++j) s += g[x + 8 * j];
  for (int j = 8 * k; j < window; ++j) s += e[x + j];
  return s;
}

// Outputs from x on (the recurrence above, one value at a time).
inline void RunningWindowSumsFrom(const float* e, const float* g, int x, int w, int window,
                                  float* out) {
  for (; x < w; ++x) {
    out[x] = x % kRunningAnchorCols < 8 ? AnchoredWindowSum(e, g, x, window)
                                        : out[x - 8] + (g[x - 8 + window] - g[x - 8]);
  }
}

// `g`: w + window - 8 floats of scratch.
void RunningWindowSumsPortable(const float* e, int w, int window, float* out, float* g) {
  EightSums(e, w + window - 8, g);
  RunningWindowSumsFrom(e, g, 0, w, window, out);
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// AVX2 kernels for W >= 9 without the separate pass of 4-sums: each 8-pixel step at x needs the
// 4-sums starting at x, x+4, ..., x+4(K-1) (K = W/4); all but the last two were already formed by
// the step at x-8, so each step forms two and carries the rest in registers. Same additions in the
// same order as WindowSumAt (and no FMA), so bit-identical to the portable kernels.
#define TURBID_AVX2 __attribute__((target("avx2")))

TURBID_AVX2 inline __m256 QuadAt(const float* p) {
  return _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_loadu_ps(p), _mm256_loadu_ps(p + 1)),
                                     _mm256_loadu_ps(p + 2)),
                       _mm256_loadu_ps(p + 3));
}

template <int W>
struct RollingQuads {
  static constexpr int kQuads = W / 4;
  static_assert(kQuads >= 2, "rolling 4-sums need W >= 8");
  __m256 q[kQuads];
};

template <int W>
TURBID_AVX2 inline void RollStart(RollingQuads<W>& r, const float* e) {
  for (int k = 0; k < RollingQuads<W>::kQuads; ++k) r.q[k] = QuadAt(e + 4 * k);
}

// Advance from x - 8 to x.
template <int W>
TURBID_AVX2 inline void RollNext(RollingQuads<W>& r, const float* e, int x) {
  constexpr int kQuads = RollingQuads<W>::kQuads;
  for (int k = 0; k + 2 < kQuads; ++k) r.q[k] = r.q[k + 2];
  r.q[kQuads - 2] = QuadAt(e + x + 4 * (kQuads - 2));
  r.q[kQuads - 1] = QuadAt(e + x + 4 * (kQuads - 1));
}

template <int W>
TURBID_AVX2 inline __m256 RollSum(const RollingQuads<W>& r, const float* e, int x) {
  constexpr int kQuads = RollingQuads<W>::kQuads;
  __m256 s = r.q[0];
  for (int k = 1; k < kQuads; ++k) s = _mm256_add_ps(s, r.q[k]);
  for (int k = 4 * kQuads; k < W; ++k) s = _mm256_add_ps(s, _mm256_loadu_ps(e + x + k));
  return s;
}

// Scalar window sum with the 4-sums formed on the fly (for the last < 8 pixels of a row).
template <int W>
inline float WindowSumQuadsInline(const float* e, int x) {
  constexpr int kQuads = W / 4;
  auto quad = [e](int o) { return e[o] + e[o + 1] + e[o + 2] + e[o + 3]; };
  float s = quad(x);
  for (int q = 1; q < kQuads; ++q) s += quad(x + 4 * q);
  for (int k = 4 * kQuads; k < W; ++k) s += e[x + k];
  return s;
}

template <int W>
TURBID_AVX2 void SelfCoefficientsRolling(const float* e_i, const float* e_ii, const float*,
                                         const float*, const float* inv_cx, float inv_cy, float eps,
                                         float* a, float* b, int w) {
  int x = 0;
  if (w >= 8) {
    RollingQuads<W> ri, rii;
    RollStart(ri, e_i);
    RollStart(rii, e_ii);
    const __m256 vcy = _mm256_set1_ps(inv_cy), veps = _mm256_set1_ps(eps);
    for (; x + 8 <= w; x += 8) {
      if (x > 0) {
        RollNext(ri, e_i, x);
        RollNext(rii, e_ii, x);
      }
      const __m256 inv = _mm256_mul_ps(_mm256_loadu_ps(inv_cx + x), vcy);
      const __m256 m = _mm256_mul_ps(RollSum(ri, e_i, x), inv);
      const __m256 var =
          _mm256_sub_ps(_mm256_mul_ps(RollSum(rii, e_ii, x), inv), _mm256_mul_ps(m, m));
      const __m256 av = _mm256_div_ps(var, _mm256_add_ps(var, veps));
      _mm256_storeu_ps(a + x, av);
      _mm256_storeu_ps(b + x, _mm256_sub_ps(m, _mm256_mul_ps(av, m)));
    }
  }
  for (; x < w; ++x) {
    SelfCoefficient(WindowSumQuadsInline<W>(e_i, x), WindowSumQuadsInline<W>(e_ii, x),
                    inv_cx[x] * inv_cy, eps, a + x, b + x);
  }
}

template <int W>
TURBID_AVX2 void GuidedCoefficientsRolling(const float* const* e, const float* const*,
                                           const float* inv_cx, float inv_cy, float eps, float* a,
                                           float* b, int w) {
  int x = 0;
  if (w >= 8) {
    RollingQuads<W> r[4];
    for (int k = 0; k < 4; ++k) RollStart(r[k], e[k]);
    const __m256 vcy = _mm256_set1_ps(inv_cy), veps = _mm256_set1_ps(eps);
    for (; x + 8 <= w; x += 8) {
      if (x > 0) {
        for (int k = 0; k < 4; ++k) RollNext(r[k], e[k], x);
      }
      const __m256 inv = _mm256_mul_ps(_mm256_loadu_ps(inv_cx + x), vcy);
      const __m256 mi = _mm256_mul_ps(RollSum(r[0], e[0], x), inv);
      const __m256 mp = _mm256_mul_ps(RollSum(r[2], e[2], x), inv);
      const __m256 var =
          _mm256_sub_ps(_mm256_mul_ps(RollSum(r[1], e[1], x), inv), _mm256_mul_ps(mi, mi));
      const __m256 cov =
          _mm256_sub_ps(_mm256_mul_ps(RollSum(r[3], e[3], x), inv), _mm256_mul_ps(mi, mp));
      const __m256 av = _mm256_div_ps(cov, _mm256_add_ps(var, veps));
      _mm256_storeu_ps(a + x, av);
      _mm256_storeu_ps(b + x, _mm256_sub_ps(mp, _mm256_mul_ps(av, mi)));
    }
  }
  for (; x < w; ++x) {
    GuidedCoefficient(WindowSumQuadsInline<W>(e[0], x), WindowSumQuadsInline<W>(e[2], x),
                      WindowSumQuadsInline<W>(e[1], x), WindowSumQuadsInline<W>(e[3], x),
                      inv_cx[x] * inv_cy, eps, a + x, b + x);
  }
}

template <int W>
TURBID_AVX2 void ApplyCoefficientsRolling(const float* e_a, const float* e_b, const float*,
                                          const float*, const float* guide, const float* inv_cx,
                                          float inv_cy, float* q, int w) {
  int x = 0;
  if (w >= 8) {
    RollingQuads<W> ra, rb;
    RollStart(ra, e_a);
    RollStart(rb, e_b);
    const __m256 vcy = _mm256_set1_ps(inv_cy);
    for (; x + 8 <= w; x += 8) {
      if (x > 0) {
        RollNext(ra, e_a, x);
        RollNext(rb, e_b, x);
      }
      const __m256 v = _mm256_add_ps(_mm256_mul_ps(RollSum(ra, e_a, x), _mm256_loadu_ps(guide + x)),
                                     RollSum(rb, e_b, x));
      _mm256_storeu_ps(q + x, _mm256_mul_ps(v, _mm256_mul_ps(_mm256_loadu_ps(inv_cx + x), vcy)));
    }
  }
  for (; x < w; ++x) {
    q[x] = ApplyCoefficient(WindowSumQuadsInline<W>(e_a, x), WindowSumQuadsInline<W>(e_b, x),
                            guide[x], inv_cx[x] * inv_cy);
  }
}

// Window sums of W > 25 values (the binary-doubling tree of WindowSums) in fewer passes: with
// D_1 = ext and D_2L(i) = D_L(i) + D_L(i + L), WindowSums returns the sum, in increasing L, of
// D_L(x + o_L) over the set bits L of W (o_L: the sum of the lower set bits). One pass forms D_8
// (and the terms of bits 1, 2 and 4) straight from ext; each further level is one pass over
// aligned vectors on the grid of positions = W mod 8 (mod 8), where every level >= 8 is read; the
// last pass adds the terms. The same additions in the same order as WindowSums, so the sums are
// bit-identical. `scratch`: DoublingScratchFloats(w, W) floats.
int DoublingLevels(int window) {
  int top = 0;
  while ((2 << top) <= window) ++top;
  return top;  // 2^top <= window < 2^(top+1)
}
size_t DoublingScratchFloats(int w, int window) {
  return static_cast<size_t>(DoublingLevels(window) - 2) * (w + window + 16) + 8;
}

// Scalar D_len(i), the tree of the doubling passes (tails of rows).
inline float TreeSum(const float* e, int i, int len) {
  if (len == 1) return e[i];
  return TreeSum(e, i, len / 2) + TreeSum(e, i + len / 2, len / 2);
}
inline float WindowTreeSum(const float* e, int x, int window) {
  float s = 0.0f;
  bool first = true;
  int offset = 0;
  for (int len = 1; len <= window; len *= 2) {
    if ((window & len) == 0) continue;
    const float t = TreeSum(e, x + offset, len);
    s = first ? t : s + t;
    first = false;
    offset += len;
  }
  return s;
}

TURBID_AVX2 inline __m256 Pair(const float* e) {
  return _mm256_add_ps(_mm256_loadu_ps(e), _mm256_loadu_ps(e + 1));
}
TURBID_AVX2 inline __m256 Quad(const float* e) { return _mm256_add_ps(Pair(e), Pair(e + 2)); }
// Lanes 4..11 / 2..9 of the 16 values a, b (a in lanes 0..7).
TURBID_AVX2 inline __m256 Shift4(__m256 a, __m256 b) { return _mm256_permute2f128_ps(a, b, 0x21); }
TURBID_AVX2 inline __m256 Shift2(__m256 a, __m256 b) {
  const __m256i t = _mm256_castps_si256(_mm256_permute2f128_ps(a, b, 0x21));
  return _mm256_castsi256_ps(_mm256_alignr_epi8(t, _mm256_castps_si256(a), 8));
}

TURBID_AVX2 void DoublingWindowSumsAvx2(const float* ext, int w, int window, float* out,
                                        float* scratch) {
  const int n = w + window - 1;
  const int top = DoublingLevels(window);
  const int c = window & 7;
  const int o1 = window & 1, o2 = window & 3, o3 = window & 7;  // offsets of bits 2, 4, 8
  const int blocks = w / 8;
  const size_t stride = static_cast<size_t>(w + window + 16) & ~static_cast<size_t>(7);
  float* base = scratch + ((8 - (reinterpret_cast<uintptr_t>(scratch) / 4) % 8) % 8);
  // Level j (2^j values, j >= 3) at grid index m: positions c + 8m .. c + 8m + 7.
  auto level = [&](int j) { return base + static_cast<size_t>(j - 3) * stride; };
  auto count = [&](int j) {
    const int room = n - (1 << j) - 7 - c;
    return room < 0 ? 0 : room / 8 + 1;
  };
  {
    // D_8 = D_4(i) + D_4(i + 4), D_4 = D_2(i) + D_2(i + 2), D_2 = ext(i) + ext(i + 1): the shifted
    // operands come from the next vectors by lane shuffles (exact), so each vector costs three
    // adds; the last vectors (whose look-ahead would leave ext) load their operands directly.
    float* g = level(3);
    const int m_end = count(3);
    int m = 0;
    const int m_shuffled = std::max(0, (n - 25 - c) / 8 + 1);  // ext(i0 + 24) must exist
    if (std::min(m_end, m_shuffled) >= 1 && n - 25 - c >= 0) {
      const float* e = ext + c;
      __m256 p0 = Pair(e), p1 = Pair(e + 8), p2 = Pair(e + 16);
      __m256 d0 = _mm256_add_ps(p0, Shift2(p0, p1));
      __m256 d1 = _mm256_add_ps(p1, Shift2(p1, p2));
      for (; m < std::min(m_end, m_shuffled); ++m) {
        _mm256_store_ps(g + 8 * m, _mm256_add_ps(d0, Shift4(d0, d1)));
        if (m + 1 >= std::min(m_end, m_shuffled)) break;
        p1 = p2;
        p2 = Pair(e + 8 * (m + 3));
        d0 = d1;
        d1 = _mm256_add_ps(p1, Shift2(p1, p2));
      }
      ++m;
    }
    for (; m < m_end; ++m) {
      const float* e = ext + c + 8 * m;
      _mm256_store_ps(g + 8 * m, _mm256_add_ps(Quad(e), Quad(e + 4)));
    }
  }
  for (int j = 4; j <= top; ++j) {
    const float* lo = level(j - 1);
    float* g = level(j);
    const int gap = 8 << (j - 4);  // 2^(j-1) floats
    const int m_end = count(j);
    for (int m = 0; m < m_end; ++m) {
      _mm256_store_ps(g + 8 * m,
                      _mm256_add_ps(_mm256_load_ps(lo + 8 * m), _mm256_load_ps(lo + 8 * m + gap)));
    }
  }
  // The terms of the levels >= 8, in increasing order: level j read at x + offset - c.
  const float* terms[32];
  int term_count = 0;
  for (int j = 3, offset = o3; j <= top; ++j) {
    if ((window >> j) & 1) {
      terms[term_count++] = level(j) + (offset - c);
      offset += 1 << j;
    }
  }
  const bool bit2 = (window & 2) != 0, bit4 = (window & 4) != 0;
  for (int b = 0; b < blocks; ++b) {
    const int x = 8 * b;
    __m256 s = _mm256_loadu_ps(ext + x);  // bit 1 (W is odd)
    if (bit2) s = _mm256_add_ps(s, Pair(ext + x + o1));
    if (bit4) s = _mm256_add_ps(s, Quad(ext + x + o2));
    for (int t = 0; t < term_count; ++t) s = _mm256_add_ps(s, _mm256_load_ps(terms[t] + x));
    _mm256_storeu_ps(out + x, s);
  }
  for (int x = 8 * blocks; x < w; ++x) out[x] = WindowTreeSum(ext, x, window);
}
// RunningWindowSumsPortable with vectors: the sums of 8 from lane shuffles of pair sums (as in
// DoublingWindowSumsAvx2), 8 outputs per step. The same additions in the same order.
TURBID_AVX2 void RunningWindowSumsAvx2(const float* e, int w, int window, float* out, float* g) {
  const int count = w + window - 8;  // e holds count + 7 values
  int i = 0;
  if (count - 18 >= 0) {
    __m256 p1 = Pair(e + 8);
    __m256 d0 = _mm256_add_ps(Pair(e), Shift2(Pair(e), p1));
    for (; i + 8 <= count && i <= count - 18; i += 8) {
      const __m256 p2 = Pair(e + i + 16);
      const __m256 d1 = _mm256_add_ps(p1, Shift2(p1, p2));
      _mm256_storeu_ps(g + i, _mm256_add_ps(d0, Shift4(d0, d1)));
      p1 = p2;
      d0 = d1;
    }
  }
  for (; i < count; ++i) {
    g[i] = ((e[i] + e[i + 1]) + (e[i + 2] + e[i + 3])) +
           ((e[i + 4] + e[i + 5]) + (e[i + 6] + e[i + 7]));
  }
  const int k = window / 8;
  int x = 0;
  __m256 prev = _mm256_setzero_ps();
  for (; x + 8 <= w; x += 8) {
    if (x % kRunningAnchorCols == 0) {
      prev = _mm256_loadu_ps(g + x);
      for (int j = 1; j < k; ++j) prev = _mm256_add_ps(prev, _mm256_loadu_ps(g + x + 8 * j));
      for (int j = 8 * k; j < window; ++j) prev = _mm256_add_ps(prev, _mm256_loadu_ps(e + x + j));
    } else {
      prev = _mm256_add_ps(
          prev, _mm256_sub_ps(_mm256_loadu_ps(g + x - 8 + window), _mm256_loadu_ps(g + x - 8)));
    }
    _mm256_storeu_ps(out + x, prev);
  }
  RunningWindowSumsFrom(e, g, x, w, window, out);
}

// The interleaved (three-channel) stream's column-sum step of two planes fused with their sums of
// 4 (QuadSumsRange<3>), so the updated column sums are not read back: for x in [0, n) the update
// c[x] = c[x] + (add[x] - sub[x]) (kSquare: the second plane's terms are add[x]^2 and sub[x]^2,
// as ColumnStepSelf; else its own rows, as ColumnStepPair; kAdd / kSub: which rows there are, the
// expressions of those kernels' other branches), and the sums of 4 at positions x - 16 for
// x in [0, n8), n8 = n rounded down to 8: q[j] = ((c[j] + c[j + 3]) + c[j + 6]) + c[j + 9]. Each
// vector of sums is formed in registers from the three last vectors of column sums (shifted by
// lane permutations) once the one holding c[j + 9] is updated. c[-16 .. -1] must be final
// (earlier chunks or the zero padding). Same operations in the same order as the two separate
// passes, so bit-identical. Returns n8.
// Sums of 4 at j .. j + 7 from the column sums v0 = c[j ..], v1 = c[j + 8 ..], v2 = c[j + 16 ..]:
// the operands c[j + 3 ..], c[j + 6 ..], c[j + 9 ..] by lane shifts of the pairs (v0, v1), (v1, v2).
TURBID_AVX2 inline __m256 Quad3(__m256 v0, __m256 v1, __m256 v2) {
  const __m256i a = _mm256_castps_si256(v0), b = _mm256_castps_si256(v1);
  const __m256i t = _mm256_permute2f128_si256(a, b, 0x21);  // v0's high half, v1's low half
  const __m256i u = _mm256_permute2f128_si256(b, _mm256_castps_si256(v2), 0x21);
  const __m256 s3 = _mm256_castsi256_ps(_mm256_alignr_epi8(t, a, 12));
  const __m256 s6 = _mm256_castsi256_ps(_mm256_alignr_epi8(b, t, 8));
  const __m256 s9 = _mm256_castsi256_ps(_mm256_alignr_epi8(u, b, 4));
  return _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(v0, s3), s6), s9);
}

// One vector of a column-sum update (the rows' squares when kSquare); returns the new sums.
template <bool kSquare, bool kAdd, bool kSub>
TURBID_AVX2 inline __m256 ColumnStep8(float* c, const float* add, const float* sub) {
  const __m256 cv = _mm256_loadu_ps(c);
  __m256 a = _mm256_setzero_ps(), s = _mm256_setzero_ps();
  if (kAdd) a = _mm256_loadu_ps(add);
  if (kSub) s = _mm256_loadu_ps(sub);
  if (kSquare) {
    a = _mm256_mul_ps(a, a);
    s = _mm256_mul_ps(s, s);
  }
  const __m256 v = kAdd && kSub ? _mm256_add_ps(cv, _mm256_sub_ps(a, s))
                   : kAdd       ? _mm256_add_ps(cv, a)
                                : _mm256_sub_ps(cv, s);
  _mm256_storeu_ps(c, v);
  return v;
}

template <bool kSquare, bool kAdd, bool kSub>
TURBID_AVX2 int ColumnStepQuads3(float* c0, float* c1, const float* add0, const float* sub0,
                                 const float* add1, const float* sub1, float* q0, float* q1,
                                 int n) {
  if (!kAdd) add0 = add1 = c0;  // unused: any valid pointer (no arithmetic on null)
  if (!kSub) sub0 = sub1 = c0;
  __m256 a0 = _mm256_loadu_ps(c0 - 16), a1 = _mm256_loadu_ps(c0 - 8);
  __m256 b0 = _mm256_loadu_ps(c1 - 16), b1 = _mm256_loadu_ps(c1 - 8);
  int x = 0;
  for (; x + 8 <= n; x += 8) {
    const __m256 a2 = ColumnStep8<false, kAdd, kSub>(c0 + x, add0 + x, sub0 + x);
    const __m256 b2 = kSquare ? ColumnStep8<true, kAdd, kSub>(c1 + x, add0 + x, sub0 + x)
                              : ColumnStep8<false, kAdd, kSub>(c1 + x, add1 + x, sub1 + x);
    _mm256_storeu_ps(q0 + x - 16, Quad3(a0, a1, a2));
    _mm256_storeu_ps(q1 + x - 16, Quad3(b0, b1, b2));
    a0 = a1, a1 = a2, b0 = b1, b1 = b2;
  }
  const int n8 = x;
  for (; x < n; ++x) {  // the last < 8 values: the update only
    const float a = kAdd ? add0[x] : 0.0f, s = kSub ? sub0[x] : 0.0f;
    const float a2 = kSquare ? a * a : (kAdd ? add1[x] : 0.0f);
    const float s2 = kSquare ? s * s : (kSub ? sub1[x] : 0.0f);
    c0[x] = kAdd && kSub ? c0[x] + (a - s) : kAdd ? c0[x] + a : c0[x] - s;
    c1[x] = kAdd && kSub ? c1[x] + (a2 - s2) : kAdd ? c1[x] + a2 : c1[x] - s2;
  }
  return n8;
}

// ColumnStepQuads3 for the rows present (add / sub null: none), as ColumnStepSelf (kSquare) or
// ColumnStepPair; returns 0 without doing anything when neither row is there (the column sums do
// not change, and the sums of 4 are left to QuadSumsRange).
template <bool kSquare>
TURBID_AVX2 int ColumnStepQuads3Rows(float* c0, float* c1, const float* add0, const float* sub0,
                                     const float* add1, const float* sub1, float* q0, float* q1,
                                     int n) {
  if (add0 != nullptr && sub0 != nullptr) {
    return ColumnStepQuads3<kSquare, true, true>(c0, c1, add0, sub0, add1, sub1, q0, q1, n);
  }
  if (add0 != nullptr) {
    return ColumnStepQuads3<kSquare, true, false>(c0, c1, add0, sub0, add1, sub1, q0, q1, n);
  }
  if (sub0 != nullptr) {
    return ColumnStepQuads3<kSquare, false, true>(c0, c1, add0, sub0, add1, sub1, q0, q1, n);
  }
  return 0;
}
#define TURBID_HAVE_COLUMN_QUADS3 1
#undef TURBID_AVX2
#define TURBID_HAVE_ROLLING_QUADS 1
#endif

// The fused kernels of one radius; quads is null where W < 9 (direct sums) and where the AVX2
// kernels form the 4-sums themselves.
struct FusedKernels {
  void (*quads)(const float*, const float*, float*, float*, int) = nullptr;
  void (*self_coefficients)(const float*, const float*, const float*, const float*, const float*,
                            float, float, float*, float*, int) = nullptr;
  void (*guided_coefficients)(const float* const*, const float* const*, const float*, float, float,
                              float*, float*, int) = nullptr;
  void (*apply)(const float*, const float*, const float*, const float*, const float*, const float*,
                float, float*, int) = nullptr;
  // Interleaved streams: the same kernels for columns whose window counts are all 2r + 1.
  decltype(self_coefficients) self_coefficients_uniform = nullptr;
  decltype(apply) apply_uniform = nullptr;
};

constexpr int kMaxFusedRadius = 12;
// Values per chunk of the interleaved stream's running steps (GrayStream::Chunked): the chunk's
// rows of column sums, sums of 4 and coefficients stay within L1.
constexpr int kChunkValues = 384;

// S > 1 (interleaved channels, each self-guided): no guided kernel and no rolling AVX2 kernels
// (their 4-sums advance by 8 values, which is not a whole number of pixels).
template <int R, int S = 1>
FusedKernels MakeFusedKernels([[maybe_unused]] bool avx2) {
  constexpr int W = 2 * R + 1;
  FusedKernels k;
  k.self_coefficients = &SelfCoefficientsFused<W, S>;
  if constexpr (S == 1) k.guided_coefficients = &GuidedCoefficientsFused<W>;
  k.apply = &ApplyCoefficientsFused<W, S>;
  if constexpr (S > 1) {
    k.self_coefficients_uniform = &SelfCoefficientsFused<W, S, true>;
    k.apply_uniform = &ApplyCoefficientsFused<W, S, true>;
  }
  if constexpr (W >= 9) {
    k.quads = &QuadSumsPair<W, S>;
#ifdef TURBID_HAVE_ROLLING_QUADS
    if (avx2 && S == 1) {
      k.quads = nullptr;
      k.self_coefficients = &SelfCoefficientsRolling<W>;
      k.guided_coefficients = &GuidedCoefficientsRolling<W>;
      k.apply = &ApplyCoefficientsRolling<W>;
    }
#endif
  }
  return k;
}

// Kernels for radius r and `channels` interleaved channels (1 or 3).
template <int... R>
FusedKernels FusedKernelsFor(int r, int channels, std::integer_sequence<int, R...>) {
  static const FusedKernels portable[] = {MakeFusedKernels<R + 1>(false)...};
  static const FusedKernels avx2[] = {MakeFusedKernels<R + 1>(true)...};
  static const FusedKernels interleaved3[] = {MakeFusedKernels<R + 1, 3>(false)...};
  if (channels == 3) return interleaved3[r - 1];
  return enhancer_internal::UseHandWrittenAvx2() ? avx2[r - 1] : portable[r - 1];
}

// Stage A / B column-sum updates of two planes at once (one pass; the same arithmetic per plane
// as ColumnStep / ColumnProductStep): self-guided stage A keeps I and I^2 (both from rows of I),
// stage B keeps a and b.
TURBID_ROW_KERNEL void ColumnStepSelf(float* __restrict c_i, float* __restrict c_ii,
                                      const float* __restrict add, const float* __restrict sub,
                                      int w) {
  if (add != nullptr && sub != nullptr) {
    for (int x = 0; x < w; ++x) {
      c_i[x] += add[x] - sub[x];
      c_ii[x] += add[x] * add[x] - sub[x] * sub[x];
    }
  } else if (add != nullptr) {
    for (int x = 0; x < w; ++x) {
      c_i[x] += add[x];
      c_ii[x] += add[x] * add[x];
    }
  } else if (sub != nullptr) {
    for (int x = 0; x < w; ++x) {
      c_i[x] -= sub[x];
      c_ii[x] -= sub[x] * sub[x];
    }
  }
}

TURBID_ROW_KERNEL void ColumnStepPair(float* __restrict c0, float* __restrict c1,
                                      const float* __restrict add0, const float* __restrict sub0,
                                      const float* __restrict add1, const float* __restrict sub1,
                                      int w) {
  if (add0 != nullptr && sub0 != nullptr) {
    for (int x = 0; x < w; ++x) {
      c0[x] += add0[x] - sub0[x];
      c1[x] += add1[x] - sub1[x];
    }
  } else if (add0 != nullptr) {
    for (int x = 0; x < w; ++x) {
      c0[x] += add0[x];
      c1[x] += add1[x];
    }
  } else if (sub0 != nullptr) {
    for (int x = 0; x < w; ++x) {
      c0[x] -= sub0[x];
      c1[x] -= sub1[x];
    }
  }
}

// Non-self stage A: the column sums of I, I^2, p and I p in one pass (the arithmetic of
// ColumnStep / ColumnProductStep per plane).
TURBID_ROW_KERNEL void ColumnStepGuided(float* __restrict c_i, float* __restrict c_ii,
                                        float* __restrict c_p, float* __restrict c_ip,
                                        const float* __restrict add_i,
                                        const float* __restrict sub_i,
                                        const float* __restrict add_p,
                                        const float* __restrict sub_p, int w) {
  if (add_i != nullptr && sub_i != nullptr) {
    for (int x = 0; x < w; ++x) {
      c_i[x] += add_i[x] - sub_i[x];
      c_ii[x] += add_i[x] * add_i[x] - sub_i[x] * sub_i[x];
      c_p[x] += add_p[x] - sub_p[x];
      c_ip[x] += add_i[x] * add_p[x] - sub_i[x] * sub_p[x];
    }
  } else if (add_i != nullptr) {
    for (int x = 0; x < w; ++x) {
      c_i[x] += add_i[x];
      c_ii[x] += add_i[x] * add_i[x];
      c_p[x] += add_p[x];
      c_ip[x] += add_i[x] * add_p[x];
    }
  } else if (sub_i != nullptr) {
    for (int x = 0; x < w; ++x) {
      c_i[x] -= sub_i[x];
      c_ii[x] -= sub_i[x] * sub_i[x];
      c_p[x] -= sub_p[x];
      c_ip[x] -= sub_i[x] * sub_p[x];
    }
  }
}

// Re-anchoring (every kAnchorRows rows): the column sums over the window's rows from zero, the
// rows added in order as the running steps add them (so the same roundings), but 16 columns at a
// time in registers instead of one pass over the whole row per window row. Sums of u (into
// c_u), and as selected of u^2 (c_uu), of v (c_v) and of u v (c_uv).
constexpr int kAnchorBlock = 16;

template <bool kSquare, bool kSecond, bool kProduct>
TURBID_ROW_KERNEL void AnchorSums(const float* const* u, const float* const* v, int count, int w,
                                  float* __restrict c_u, float* __restrict c_uu,
                                  float* __restrict c_v, float* __restrict c_uv) {
  int x0 = 0;
  for (; x0 + kAnchorBlock <= w; x0 += kAnchorBlock) {
    float su[kAnchorBlock] = {}, suu[kAnchorBlock] = {}, sv[kAnchorBlock] = {},
          suv[kAnchorBlock] = {};
    for (int k = 0; k < count; ++k) {
      const float* __restrict a = u[k] + x0;
      const float* __restrict b = kSecond ? v[k] + x0 : a;
      for (int i = 0; i < kAnchorBlock; ++i) {
        su[i] += a[i];
        if (kSquare) suu[i] += a[i] * a[i];
        if (kSecond) sv[i] += b[i];
        if (kProduct) suv[i] += a[i] * b[i];
      }
    }
    for (int i = 0; i < kAnchorBlock; ++i) {
      c_u[x0 + i] = su[i];
      if (kSquare) c_uu[x0 + i] = suu[i];
      if (kSecond) c_v[x0 + i] = sv[i];
      if (kProduct) c_uv[x0 + i] = suv[i];
    }
  }
  for (; x0 < w; ++x0) {  // the last < 16 columns: the same additions one column at a time
    float su = 0.0f, suu = 0.0f, sv = 0.0f, suv = 0.0f;
    for (int k = 0; k < count; ++k) {
      const float a = u[k][x0];
      const float b = kSecond ? v[k][x0] : a;
      su += a;
      if (kSquare) suu += a * a;
      if (kSecond) sv += b;
      if (kProduct) suv += a * b;
    }
    c_u[x0] = su;
    if (kSquare) c_uu[x0] = suu;
    if (kSecond) c_v[x0] = sv;
    if (kProduct) c_uv[x0] = suv;
  }
}

// Vertical window bookkeeping for output row t of a clipped (2r+1)-row window over h rows: the
// rows entering and leaving (-1: none). Row t's window is [max(t-r, 0), min(t+r, h-1)]; the
// first row primes the sums with the whole window.
int InvCount(int t, int r, int n) { return std::min(t + r, n - 1) - std::max(t - r, 0) + 1; }

// One-channel guide, one-channel source (He 2013 Alg. 1), streamed by rows: the first stage
// computes a, b for row y from the box sums of I, I^2 (and p, I p unless self-guided); the second
// stage, r rows behind, box-sums a and b and writes q. a and b live in a ring of 2r+2 rows, so
// there are no full-size temporaries besides the output. Rows are pulled in order 0..h-1.
// `channels` 3: a self-guided interleaved image, each channel its own guide, every step the
// one-channel filter's arithmetic on each channel (the values of a row are processed together,
// the horizontal sums taking every third value); radius 1..kMaxFusedRadius only.
class GrayStream {
 public:
  GrayStream(const cv::Mat& guide, const cv::Mat& src, int r, float eps, bool self,
             int channels = 1, bool running = false)
      : guide_(guide),
        src_(src),
        r_(r),
        eps_(eps),
        self_(self),
        h_(guide.rows),
        w_(guide.cols * channels),
        pad_(r * channels),
        window_(2 * r + 1),
        ext_len_(w_ + 2 * pad_),
        planes_a_(self ? 2 : 4),  // I, I^2 [, p, I p]
        ring_(std::min(window_ + 1, h_)),
        ext_(static_cast<size_t>(planes_a_ + 2) * ext_len_, 0.0f),
        inv_cx_(w_),
        a_ring_(ring_, w_, CV_32F),
        b_ring_(ring_, w_, CV_32F) {
    CV_Assert(channels == 1 || (channels == 3 && self && r >= 1 && r <= kMaxFusedRadius));
    for (int x = 0; x < w_; ++x) {
      inv_cx_[x] = 1.0f / static_cast<float>(InvCount(x / channels, r_, guide.cols));
    }
    if (r_ >= 1 && r_ <= kMaxFusedRadius) {
      fused_ = FusedKernelsFor(r_, channels, std::make_integer_sequence<int, kMaxFusedRadius>{});
    }
    // Buffers of the path in use: sums of 4 for the portable fused kernels (W >= 9); window sums
    // and doubling scratch for the unfused one.
    if (fused_.quads != nullptr) quads_.assign(static_cast<size_t>(planes_a_ + 2) * ext_len_, 0.0f);
    chunked_ = channels == 3 && fused_.apply != nullptr;
#ifdef TURBID_HAVE_COLUMN_QUADS3
    fuse_quads_ = chunked_ && !quads_.empty() && enhancer_internal::UseHandWrittenAvx2();
#endif
    if (fused_.apply == nullptr) {
      sums_.assign(static_cast<size_t>(planes_a_ + 2) * w_, 0.0f);
      t0_.resize(ext_len_);
      t1_.resize(ext_len_);
      if (running) {
        CV_Assert(channels == 1);
        running_.resize(static_cast<size_t>(w_) + window_);
        return;
      }
#ifdef TURBID_HAVE_ROLLING_QUADS
      if (enhancer_internal::UseHandWrittenAvx2()) {
        doubling_.resize(DoublingScratchFloats(w_, window_));
      }
#endif
    }
  }

  // Whether stage A prefetches the input row of its next step (default on; off for a stream
  // whose rows another stream of the same image has fetched already).
  void SetPrefetchNextRow(bool on) { prefetch_next_ = on; }

  // Writes output row t (rows must be asked for in order 0, 1, ..., h-1).
  void Row(int t, float* dst) {
    const int need = std::min(t + r_, h_ - 1);
    while (next_a_ <= need) StageA(next_a_++);
    const int ka = planes_a_, kb = planes_a_ + 1;
    if (t % kAnchorRows == 0) {
      WindowRows(t, a_ring_, &rows_u_, true);
      WindowRows(t, b_ring_, &rows_v_, true);
      AnchorSums<false, true, false>(rows_u_.data(), rows_v_.data(),
                                     static_cast<int>(rows_u_.size()), w_, Ext(ka) + pad_, nullptr,
                                     Ext(kb) + pad_, nullptr);
    } else {
      const int add = t + r_ < h_ ? (t + r_) % ring_ : -1;
      const int sub = t - r_ - 1 >= 0 ? (t - r_ - 1) % ring_ : -1;
      if (chunked_) {
        const float* a_add = RingRow(a_ring_, add);
        const float* a_sub = RingRow(a_ring_, sub);
        const float* b_add = RingRow(b_ring_, add);
        const float* b_sub = RingRow(b_ring_, sub);
        const float inv_cy = 1.0f / static_cast<float>(InvCount(t, r_, h_));
        const float* guide = guide_.ptr<float>(t);
        Chunked(
            ka,
            [&](int c0, int n) {
              return ColumnChunk<false>(ka, c0, n, a_add, a_sub, b_add, b_sub);
            },
            [&](int o0, int n) {
              SplitAtBorders(o0, n, [&](int x0, int m, bool uniform) {
                (uniform ? fused_.apply_uniform : fused_.apply)(
                    Ext(ka) + x0, Ext(kb) + x0, Offset(Quad(ka), x0), Offset(Quad(kb), x0),
                    guide + x0, inv_cx_.data() + x0, inv_cy, dst + x0, m);
              });
            });
        return;
      }
      ColumnStepPair(Ext(ka) + pad_, Ext(kb) + pad_, RingRow(a_ring_, add), RingRow(a_ring_, sub),
                     RingRow(b_ring_, add), RingRow(b_ring_, sub), w_);
    }
    const float inv_cy = 1.0f / static_cast<float>(InvCount(t, r_, h_));
    const float* guide = guide_.ptr<float>(t);
    if (fused_.apply != nullptr) {
      if (fused_.quads != nullptr) fused_.quads(Ext(ka), Ext(kb), Quad(ka), Quad(kb), w_);
      fused_.apply(Ext(ka), Ext(kb), Quad(ka), Quad(kb), guide, inv_cx_.data(), inv_cy, dst, w_);
      return;
    }
    WindowSumsOf(ka);
    WindowSumsOf(kb);
    ApplyCoefficients(Sum(ka), Sum(kb), guide, inv_cx_.data(), inv_cy, dst, w_);
  }

 private:
  float* Ext(int k) { return ext_.data() + static_cast<size_t>(k) * ext_len_; }
  // Null where the kernels form their sums of 4 themselves (they ignore the argument).
  float* Quad(int k) {
    return quads_.empty() ? nullptr : quads_.data() + static_cast<size_t>(k) * ext_len_;
  }
  float* Sum(int k) { return sums_.data() + static_cast<size_t>(k) * w_; }
  template <typename T>
  static T* Offset(T* p, int n) {
    return p == nullptr ? nullptr : p + n;
  }
  // The sums of 4 formed with the column-sum update of a chunk trail its first column by this many
  // padded positions (ColumnStepQuads3 reads the 16 column sums before the chunk).
  static constexpr int kQuadLag = 16;
  // The chunk's column-sum update of planes k, k + 1 (kSquare: stage A's I and I^2 from one row
  // pair; else stage B's a and b) on values [c0, c0 + n); where fuse_quads_, with the sums of 4 at
  // padded positions [max(pad + c0 - kQuadLag, 0), + m) (ColumnStepQuads3; returns m). Its first
  // kQuadLag - pad - c0 values, if any, are updated alone (the kernel reads the 16 column sums
  // before where it starts, which must lie in the padding or earlier chunks).
  template <bool kSquare>
  int ColumnChunk(int k, int c0, int n, const float* add0, const float* sub0, const float* add1,
                  const float* sub1) {
    auto plain = [&](int from, int count) {
      float* e0 = Ext(k) + pad_ + from;
      float* e1 = Ext(k + 1) + pad_ + from;
      if (kSquare) {
        ColumnStepSelf(e0, e1, Offset(add0, from), Offset(sub0, from), count);
      } else {
        ColumnStepPair(e0, e1, Offset(add0, from), Offset(sub0, from), Offset(add1, from),
                       Offset(sub1, from), count);
      }
    };
#ifdef TURBID_HAVE_COLUMN_QUADS3
    const int lead = std::max(kQuadLag - pad_ - c0, 0);
    if (fuse_quads_ && lead < n) {
      if (lead > 0) plain(c0, lead);
      const int from = c0 + lead;
      // The sums of 4 are written from 16 positions before the first column updated here.
      static_assert(kQuadLag == 16, "ColumnStepQuads3's lag");
      return ColumnStepQuads3Rows<kSquare>(
          Ext(k) + pad_ + from, Ext(k + 1) + pad_ + from, Offset(add0, from), Offset(sub0, from),
          Offset(add1, from), Offset(sub1, from), Quad(k) + pad_ + from,
          Quad(k + 1) + pad_ + from, n - lead);  // the update is done (0: no sums formed)
    }
#endif
    plain(c0, n);
    return 0;
  }
  // One running step of the interleaved stream (stage A: planes 0, 1; stage B: a, b), chunk by
  // chunk along the row so that what a chunk's column-sum update writes is still in L1 when the
  // sums of 4 and the window sums read it: update(c0, n) updates the column sums of values
  // [c0, c0 + n) and returns m > 0 when it also formed the sums of 4 at padded positions
  // [pad + c0 - kQuadLag, pad + c0 - kQuadLag + m) (ColumnStepQuads3), else 0; then the missing
  // sums of 4 of planes k, k + 1 and window(o0, n) the outputs [o0, o0 + n) whose windows lie
  // within the updated columns (output x reads the padded sums up to x + 2 pad, i.e. columns up to
  // x + pad; the sums of 4 it reads end sooner). Every value gets the arithmetic of the whole-row
  // passes, so the results are bit-identical to them.
  template <typename Update, typename Window>
  void Chunked(int k, Update&& update, Window&& window) {
    constexpr int kS = 3;                                     // values per pixel
    const int quads_end = w_ + 4 * kS * (window_ / 4 - 1);  // positions QuadSumsPair forms
    int quads_done = 0, out_done = 0;
    for (int c0 = 0; c0 < w_; c0 += kChunkValues) {
      const int c1 = std::min(c0 + kChunkValues, w_);
      const int fused = update(c0, c1 - c0);
      const bool last = c1 == w_;
      if (!quads_.empty()) {
        if (fused > 0) {  // the update formed the sums of 4 at [f0, f0 + fused)
          const int f0 = std::max(pad_ + c0 - kQuadLag, 0);
          if (f0 > quads_done) {  // those before it read only final column sums
            QuadSumsRange<kS>(Ext(k) + quads_done, Ext(k + 1) + quads_done, Quad(k) + quads_done,
                              Quad(k + 1) + quads_done, f0 - quads_done);
          }
          quads_done = std::max(quads_done, f0 + fused);
        }
        // The sum of 4 at i reads the padded sums i .. i + 3 kS.
        const int q1 = last ? quads_end : std::min(pad_ + c1 - 3 * kS, quads_end);
        if (q1 > quads_done) {
          QuadSumsRange<kS>(Ext(k) + quads_done, Ext(k + 1) + quads_done, Quad(k) + quads_done,
                           Quad(k + 1) + quads_done, q1 - quads_done);
          quads_done = q1;
        }
      }
      const int o1 = last ? w_ : c1 - pad_;
      if (o1 > out_done) {
        window(out_done, o1 - out_done);
        out_done = o1;
      }
    }
  }
  // Values [o0, o0 + n) cut where the window counts along x change: f(x0, m, uniform) on each
  // piece, uniform where every value lies at least r pixels from both borders (count 2r + 1).
  template <typename F>
  void SplitAtBorders(int o0, int n, F&& f) {
    const int lo = std::min(pad_, w_), hi = std::max(w_ - pad_, lo), end = o0 + n;
    const int cuts[4] = {o0, std::clamp(lo, o0, end), std::clamp(hi, o0, end), end};
    for (int i = 0; i < 3; ++i) {
      if (cuts[i + 1] > cuts[i]) f(cuts[i], cuts[i + 1] - cuts[i], i == 1);
    }
  }
  // Window sums of plane k's padded column sums into Sum(k) (radii beyond kMaxFusedRadius).
  void WindowSumsOf(int k) {
    if (!running_.empty()) {
#ifdef TURBID_HAVE_ROLLING_QUADS
      if (enhancer_internal::UseHandWrittenAvx2()) {
        RunningWindowSumsAvx2(Ext(k), w_, window_, Sum(k), running_.data());
        return;
      }
#endif
      RunningWindowSumsPortable(Ext(k), w_, window_, Sum(k), running_.data());
      return;
    }
#ifdef TURBID_HAVE_ROLLING_QUADS
    if (!doubling_.empty()) {
      DoublingWindowSumsAvx2(Ext(k), w_, window_, Sum(k), doubling_.data());
      return;
    }
#endif
    WindowSums(Ext(k), w_, window_, Sum(k), t0_.data(), t1_.data());
  }
  static const float* RingRow(const cv::Mat& ring, int slot) {
    return slot >= 0 ? ring.ptr<float>(slot) : nullptr;
  }

  // The rows of the clipped vertical window of row t, top to bottom (from the ring of a or b
  // rows when in_ring).
  void WindowRows(int t, const cv::Mat& m, std::vector<const float*>* rows, bool in_ring = false) {
    rows->clear();
    for (int y = std::max(t - r_, 0); y <= std::min(t + r_, h_ - 1); ++y)
      rows->push_back(m.ptr<float>(in_ring ? y % ring_ : y));
  }

  void StageA(int y) {
    const float* add = y + r_ < h_ ? guide_.ptr<float>(y + r_) : nullptr;
    const float* sub = y - r_ - 1 >= 0 ? guide_.ptr<float>(y - r_ - 1) : nullptr;
    if (y % kAnchorRows == 0) {
      WindowRows(y, guide_, &rows_u_);
      if (self_) {
        AnchorSums<true, false, false>(rows_u_.data(), nullptr, static_cast<int>(rows_u_.size()),
                                       w_, Ext(0) + pad_, Ext(1) + pad_, nullptr, nullptr);
      } else {
        WindowRows(y, src_, &rows_v_);
        AnchorSums<true, true, true>(rows_u_.data(), rows_v_.data(),
                                     static_cast<int>(rows_u_.size()), w_, Ext(0) + pad_,
                                     Ext(1) + pad_, Ext(2) + pad_, Ext(3) + pad_);
      }
    } else if (chunked_) {
      const float inv_cy = 1.0f / static_cast<float>(InvCount(y, r_, h_));
      float* ar = a_ring_.ptr<float>(y % ring_);
      float* br = b_ring_.ptr<float>(y % ring_);
      // The next step's new row follows this one's in memory (a continuous image): fetched into
      // L2 while this row is worked on (else its first reads wait for memory; the hardware
      // prefetchers stop at page boundaries).
      const char* next =
          prefetch_next_ && add != nullptr && y + r_ + 1 < h_
              ? reinterpret_cast<const char*>(add + w_)
              : nullptr;
      Chunked(
          0,
          [&](int c0, int n) {
            if (next != nullptr) {
              const char* end = next + sizeof(float) * (c0 + n);
              for (const char* p = next + sizeof(float) * c0; p < end; p += 64) {
                __builtin_prefetch(p, 0, 2);
              }
            }
            return ColumnChunk<true>(0, c0, n, add, sub, nullptr, nullptr);
          },
          [&](int o0, int n) {
            SplitAtBorders(o0, n, [&](int x0, int m, bool uniform) {
              (uniform ? fused_.self_coefficients_uniform : fused_.self_coefficients)(
                  Ext(0) + x0, Ext(1) + x0, Offset(Quad(0), x0), Offset(Quad(1), x0),
                  inv_cx_.data() + x0, inv_cy, eps_, ar + x0, br + x0, m);
            });
          });
      return;
    } else if (self_) {
      ColumnStepSelf(Ext(0) + pad_, Ext(1) + pad_, add, sub, w_);
    } else {
      ColumnStepGuided(Ext(0) + pad_, Ext(1) + pad_, Ext(2) + pad_, Ext(3) + pad_, add, sub,
                       add != nullptr ? src_.ptr<float>(y + r_) : nullptr,
                       sub != nullptr ? src_.ptr<float>(y - r_ - 1) : nullptr, w_);
    }
    const float inv_cy = 1.0f / static_cast<float>(InvCount(y, r_, h_));
    float* ar = a_ring_.ptr<float>(y % ring_);
    float* br = b_ring_.ptr<float>(y % ring_);
    if (fused_.apply != nullptr) {
      if (fused_.quads != nullptr) {
        for (int k = 0; k < planes_a_; k += 2) {
          fused_.quads(Ext(k), Ext(k + 1), Quad(k), Quad(k + 1), w_);
        }
      }
      if (self_) {
        fused_.self_coefficients(Ext(0), Ext(1), Quad(0), Quad(1), inv_cx_.data(), inv_cy, eps_, ar,
                                 br, w_);
      } else {
        const float* e[4] = {Ext(0), Ext(1), Ext(2), Ext(3)};
        const float* q[4] = {Quad(0), Quad(1), Quad(2), Quad(3)};
        fused_.guided_coefficients(e, q, inv_cx_.data(), inv_cy, eps_, ar, br, w_);
      }
      return;
    }
    for (int k = 0; k < planes_a_; ++k) WindowSumsOf(k);
    if (self_) {
      SelfCoefficients(Sum(0), Sum(1), inv_cx_.data(), inv_cy, eps_, ar, br, w_);
    } else {
      GuidedCoefficients(Sum(0), Sum(2), Sum(1), Sum(3), inv_cx_.data(), inv_cy, eps_, ar, br, w_);
    }
  }

  const cv::Mat guide_, src_;
  const int r_;
  const float eps_;
  const bool self_;
  const int h_, w_, pad_, window_, ext_len_, planes_a_, ring_;  // w_, pad_: values, not pixels
  // Per-plane buffers: column sums with r zeros each side (the clipped window); window sums.
  std::vector<float> ext_, quads_, sums_, t0_, t1_, inv_cx_;
  std::vector<float> doubling_;                // DoublingWindowSumsAvx2's levels (AVX2, radii > 12)
  std::vector<float> running_;                 // sums of 8 (GuidedFilterGrayRunning)
  std::vector<const float*> rows_u_, rows_v_;  // window rows when re-anchoring
  cv::Mat a_ring_, b_ring_;
  FusedKernels fused_;  // empty beyond kMaxFusedRadius (window sums by binary doubling)
  bool chunked_ = false;  // interleaved colour: the running steps chunk by chunk (Chunked)
  [[maybe_unused]] bool fuse_quads_ = false;  // chunked, sums of 4, AVX2: ColumnStepQuads3
  bool prefetch_next_ = true;  // stage A prefetches the next input row (SetPrefetchNextRow)
  int next_a_ = 0;
};

cv::Mat GuidedGray(const cv::Mat& guide, const cv::Mat& src, int r, float eps, bool self,
                   bool running = false,
                   const std::function<void(int, float*)>& row_done = nullptr) {
  GrayStream stream(guide, src, r, eps, self, 1, running);
  // The output from the recycling pool (simulator/image_pool.h): no fresh pages per call.
  cv::Mat q = internal::PooledMat(guide.size(), CV_32F);
  for (int t = 0; t < guide.rows; ++t) {
    stream.Row(t, q.ptr<float>(t));
    if (row_done) row_done(t, q.ptr<float>(t));
  }
  return q;
}

// Coefficients only (for the subsampled variant): a, b at the guide's resolution, then their box
// means. Returns {mean_a, mean_b}.
std::pair<cv::Mat, cv::Mat> GrayCoefficients(const cv::Mat& guide, const cv::Mat& src, int r,
                                             float eps) {
  const int h = guide.rows;
  const int w = guide.cols;
  cv::Mat a(h, w, CV_32F), b(h, w, CV_32F);
  BoxMeansRows({guide, src, guide.mul(guide), guide.mul(src)}, r,
               [&](int y, const std::vector<const float*>& m) {
                 float* ar = a.ptr<float>(y);
                 float* br = b.ptr<float>(y);
                 for (int x = 0; x < w; ++x) {
                   const float var = m[2][x] - m[0][x] * m[0][x];
                   const float cov = m[3][x] - m[0][x] * m[1][x];
                   const float av = cov / (var + eps);
                   ar[x] = av;
                   br[x] = m[1][x] - av * m[0][x];
                 }
               });
  cv::Mat ma(h, w, CV_32F), mb(h, w, CV_32F);
  BoxMeansRows({a, b}, r, [&](int y, const std::vector<const float*>& m) {
    std::copy(m[0], m[0] + w, ma.ptr<float>(y));
    std::copy(m[1], m[1] + w, mb.ptr<float>(y));
  });
  return {ma, mb};
}

// The colour-guide coefficients of one pixel (He 2013 eqs. 19-21) from the 13 box means.
TURBID_ROW_KERNEL void ColorCoefficientRow(const float* const* __restrict m, double eps,
                                           float* __restrict a0, float* __restrict a1,
                                           float* __restrict a2, float* __restrict bb, int w) {
  const float* __restrict m0 = m[0];
  const float* __restrict m1 = m[1];
  const float* __restrict m2 = m[2];
  const float* __restrict m3 = m[3];
  const float* __restrict m4 = m[4];
  const float* __restrict m5 = m[5];
  const float* __restrict m6 = m[6];
  const float* __restrict m7 = m[7];
  const float* __restrict m8 = m[8];
  const float* __restrict m9 = m[9];
  const float* __restrict m10 = m[10];
  const float* __restrict m11 = m[11];
  const float* __restrict m12 = m[12];
  for (int x = 0; x < w; ++x) {
    const double mu0 = m0[x], mu1 = m1[x], mu2 = m2[x], mp = m3[x];
    const double s00 = m4[x] - mu0 * mu0 + eps, s01 = m5[x] - mu0 * mu1, s02 = m6[x] - mu0 * mu2,
                 s11 = m7[x] - mu1 * mu1 + eps, s12 = m8[x] - mu1 * mu2,
                 s22 = m9[x] - mu2 * mu2 + eps;
    const double c0 = m10[x] - mu0 * mp, c1 = m11[x] - mu1 * mp, c2 = m12[x] - mu2 * mp;
    // Symmetric 3x3 inverse by cofactors; Sigma + eps I is positive definite for eps > 0.
    const double i00 = s11 * s22 - s12 * s12, i01 = s02 * s12 - s01 * s22,
                 i02 = s01 * s12 - s02 * s11, i11 = s00 * s22 - s02 * s02,
                 i12 = s01 * s02 - s00 * s12, i22 = s00 * s11 - s01 * s01;
    const double det = s00 * i00 + s01 * i01 + s02 * i02;
    const double inv = 1.0 / det;
    const double v0 = (i00 * c0 + i01 * c1 + i02 * c2) * inv;
    const double v1 = (i01 * c0 + i11 * c1 + i12 * c2) * inv;
    const double v2 = (i02 * c0 + i12 * c1 + i22 * c2) * inv;
    a0[x] = static_cast<float>(v0);
    a1[x] = static_cast<float>(v1);
    a2[x] = static_cast<float>(v2);
    bb[x] = static_cast<float>(mp - v0 * mu0 - v1 * mu1 - v2 * mu2);
  }
}

// q = mean a . I + mean b, in the order (and float roundings) of
// m0.mul(g0) + m1.mul(g1) + m2.mul(g2) + m3.
TURBID_ROW_KERNEL void ColorApplyRow(const float* __restrict m0, const float* __restrict m1,
                                     const float* __restrict m2, const float* __restrict m3,
                                     const float* __restrict g0, const float* __restrict g1,
                                     const float* __restrict g2, float* __restrict q, int w) {
  for (int x = 0; x < w; ++x) {
    const float p0 = m0[x] * g0[x], p1 = m1[x] * g1[x], p2 = m2[x] * g2[x];
    q[x] = ((p0 + p1) + p2) + m3[x];
  }
}

// Colour guide (He 2013 eqs. 19-21): a = (Sigma + eps U)^-1 cov(I, p), b = mean p - a . mean I.
// The 13 planes (I, p, the 6 products I_i I_j and the 3 products I_i p) are box-averaged with the
// products formed row by row; the coefficients go to four full-size planes (the second box
// filter reads them).
std::vector<cv::Mat> ColorCoefficients(const std::vector<cv::Mat>& g, const cv::Mat& src, int r,
                                       double eps) {
  const int h = src.rows;
  const int w = src.cols;
  // Planes 0-3: g0, g1, g2, src; 4-9: g0g0 g0g1 g0g2 g1g1 g1g2 g2g2; 10-12: g0 src, g1 src, g2 src.
  static constexpr int kFactors[13][2] = {{0, -1}, {1, -1}, {2, -1}, {3, -1}, {0, 0},
                                          {0, 1},  {0, 2},  {1, 1},  {1, 2},  {2, 2},
                                          {0, 3},  {1, 3},  {2, 3}};
  const cv::Mat* base[4] = {&g[0], &g[1], &g[2], &src};
  const PlaneRows rows = [&](int k, int y, float* scratch) -> const float* {
    const float* u = base[kFactors[k][0]]->ptr<float>(y);
    if (kFactors[k][1] < 0) return u;
    MultiplyRows(u, base[kFactors[k][1]]->ptr<float>(y), scratch, w);
    return scratch;
  };
  std::vector<cv::Mat> coef(4);
  for (cv::Mat& c : coef) c.create(h, w, CV_32F);
  BoxMeansRows(13, h, w, r, rows, [&](int y, const std::vector<const float*>& m) {
    ColorCoefficientRow(m.data(), eps, coef[0].ptr<float>(y), coef[1].ptr<float>(y),
                        coef[2].ptr<float>(y), coef[3].ptr<float>(y), w);
  });
  return coef;
}

// The colour-guided output from the coefficients (their box means, then a . I + b).
cv::Mat ColorApply(const std::vector<cv::Mat>& coef, const std::vector<cv::Mat>& g, int r) {
  const int w = g[0].cols;
  cv::Mat q = internal::PooledMat(g[0].size(), CV_32F);
  BoxMeansRows(coef, r, [&](int y, const std::vector<const float*>& m) {
    ColorApplyRow(m[0], m[1], m[2], m[3], g[0].ptr<float>(y), g[1].ptr<float>(y),
                  g[2].ptr<float>(y), q.ptr<float>(y), w);
  });
  return q;
}

cv::Mat Continuous(const cv::Mat& m) { return m.isContinuous() ? m : m.clone(); }

}  // namespace

bool GuidedFilterOptions::Check(std::string* why) const {
  if (radius < 0 || radius > 10000) {
    *why = "radius must be in [0, 10000], got " + std::to_string(radius);
    return false;
  }
  if (!std::isfinite(eps) || eps <= 0.0) {
    *why = "eps must be finite and > 0, got " + std::to_string(eps);
    return false;
  }
  if (subsample < 1 || subsample > 64) {
    *why = "subsample must be in [1, 64], got " + std::to_string(subsample);
    return false;
  }
  return true;
}

cv::Mat GuidedFilter(const GuidedFilterOptions& options, const cv::Mat& guide_in,
                     const cv::Mat& src_in) {
  CheckInputs(options, guide_in, src_in);
  if (options.radius == 0) return src_in.clone();
  const float eps = static_cast<float>(options.eps);
  const cv::Mat guide = Continuous(guide_in);
  std::vector<cv::Mat> src_planes;
  if (src_in.channels() == 1) {
    src_planes = {src_in};  // cv::split would copy a one-channel image
  } else {
    cv::split(src_in, src_planes);
  }
  std::vector<cv::Mat> out_planes;
  const int s = options.subsample;
  const bool sub = s > 1 && std::min(guide.rows, guide.cols) >= 2 * s;

  if (!sub) {
    if (guide.channels() == 1) {
      for (const cv::Mat& p : src_planes) {
        const bool self = src_in.channels() == 1 && guide_in.data == src_in.data;
        out_planes.push_back(GuidedGray(guide, self ? guide : p, options.radius, eps, self));
      }
    } else {
      std::vector<cv::Mat> g;
      cv::split(guide, g);
      for (const cv::Mat& p : src_planes) {
        out_planes.push_back(
            ColorApply(ColorCoefficients(g, p, options.radius, options.eps), g, options.radius));
      }
    }
  } else {
    // He & Sun 2015 Alg. 2: coefficients at 1/s, upsampled bilinearly, applied at full size.
    const cv::Size small(std::max(1, (guide.cols + s / 2) / s),
                         std::max(1, (guide.rows + s / 2) / s));
    const int rs =
        std::max(1, static_cast<int>(std::lround(static_cast<double>(options.radius) / s)));
    cv::Mat guide_small;
    cv::resize(guide, guide_small, small, 0, 0, cv::INTER_AREA);
    std::vector<cv::Mat> g, g_small;
    cv::split(guide, g);
    cv::split(guide_small, g_small);
    for (const cv::Mat& p : src_planes) {
      cv::Mat p_small;
      cv::resize(p, p_small, small, 0, 0, cv::INTER_AREA);
      std::vector<cv::Mat> coef;
      if (guide.channels() == 1) {
        auto [ma, mb] = GrayCoefficients(guide_small, p_small, rs, eps);
        coef = {ma, mb};
      } else {
        coef = ColorCoefficients(g_small, p_small, rs, options.eps);
        std::vector<cv::Mat> means(4);
        for (cv::Mat& c : means) c.create(coef[0].size(), CV_32F);
        BoxMeansRows(coef, rs, [&](int y, const std::vector<const float*>& m) {
          for (int k = 0; k < 4; ++k) std::copy(m[k], m[k] + coef[0].cols, means[k].ptr<float>(y));
        });
        coef = means;
      }
      for (cv::Mat& c : coef) cv::resize(c, c, guide.size(), 0, 0, cv::INTER_LINEAR);
      cv::Mat q = coef.back().clone();
      for (size_t c = 0; c + 1 < coef.size(); ++c) q += coef[c].mul(g[c]);
      out_planes.push_back(q);
    }
  }
  cv::Mat out;
  if (out_planes.size() == 1) return out_planes[0];
  cv::merge(out_planes, out);
  return out;
}

cv::Mat GuidedFilterGrayRunning(const cv::Mat& guide_in, const cv::Mat& src_in, int radius,
                                double eps, const std::function<void(int, float*)>& row_done) {
  GuidedFilterOptions options;
  options.radius = radius;
  options.eps = eps;
  CheckInputs(options, guide_in, src_in);
  if (guide_in.channels() != 1 || src_in.channels() != 1) {
    throw Error("guided filter (running sums): guide and source must have one channel");
  }
  if (radius <= kMaxFusedRadius) {
    cv::Mat q = GuidedFilter(options, guide_in, src_in);
    if (row_done) {
      for (int y = 0; y < q.rows; ++y) row_done(y, q.ptr<float>(y));
    }
    return q;
  }
  const cv::Mat guide = Continuous(guide_in);
  const bool self = guide_in.data == src_in.data;
  return GuidedGray(guide, self ? guide : Continuous(src_in), radius, static_cast<float>(eps), self,
                    /*running=*/true, row_done);
}

cv::Mat GuidedFilterSelf(const GuidedFilterOptions& options, const cv::Mat& image) {
  if (image.channels() == 1) return GuidedFilter(options, image, image);
  CheckInputs(options, image, image);
  if (image.channels() == 3 && options.subsample == 1 && options.radius >= 1 &&
      options.radius <= kMaxFusedRadius) {
    // Interleaved, streamed: no per-channel planes.
    const cv::Mat src = Continuous(image);
    GrayStream stream(src, src, options.radius, static_cast<float>(options.eps), true, 3);
    cv::Mat q(src.size(), CV_32FC3);
    for (int t = 0; t < src.rows; ++t) stream.Row(t, q.ptr<float>(t));
    return q;
  }
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (cv::Mat& p : planes) p = GuidedFilter(options, p, p);
  cv::Mat out;
  cv::merge(planes, out);
  return out;
}

void GuidedFilterSelfRows(const std::vector<GuidedFilterOptions>& options, const cv::Mat& image_in,
                          const std::function<void(int, const std::vector<const float*>&)>& emit) {
  const int channels = image_in.channels();
  if (channels != 1 && channels != 3) {
    throw Error("guided filter rows: expected a one- or three-channel image");
  }
  const cv::Mat image = Continuous(image_in);
  std::vector<std::unique_ptr<GrayStream>> streams(options.size());
  std::vector<cv::Mat> whole(options.size());  // variants not streamed: filtered in one go
  for (size_t k = 0; k < options.size(); ++k) {
    CheckInputs(options[k], image, image);
    const bool stream = options[k].radius >= 1 && options[k].subsample == 1 &&
                        (channels == 1 || options[k].radius <= kMaxFusedRadius);
    if (!stream) {
      whole[k] = GuidedFilterSelf(options[k], image);
    } else {
      streams[k] = std::make_unique<GrayStream>(image, image, options[k].radius,
                                                static_cast<float>(options[k].eps), true, channels);
    }
  }
  // The next input row is prefetched by the stream that reads furthest ahead (the largest
  // radius) only: the others read it a few rows later, from L2.
  int widest = -1;
  for (size_t k = 0; k < options.size(); ++k) {
    if (streams[k] && (widest < 0 || options[k].radius > options[widest].radius)) {
      widest = static_cast<int>(k);
    }
  }
  for (size_t k = 0; k < options.size(); ++k) {
    if (streams[k]) streams[k]->SetPrefetchNextRow(static_cast<int>(k) == widest);
  }
  const size_t n = static_cast<size_t>(image.cols) * channels;
  std::vector<float> rows(options.size() * n);
  std::vector<const float*> ptrs(options.size());
  for (int y = 0; y < image.rows; ++y) {
    for (size_t k = 0; k < options.size(); ++k) {
      if (streams[k]) {
        float* dst = rows.data() + k * n;
        streams[k]->Row(y, dst);
        ptrs[k] = dst;
      } else {
        ptrs[k] = whole[k].ptr<float>(y);
      }
    }
    emit(y, ptrs);
  }
}

}  // namespace turbid
