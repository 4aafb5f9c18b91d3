// The guided filter's row kernels: window sums along a row (direct, blocked, binary doubling,
// running on a stride of 8; portable and AVX2), the coefficient formulas, and the fused kernels
// of radii 1..12 that form window sums and coefficients in one pass (guided_kernels.h).
#include "enhancer/blocks/guided_kernels.h"

#include <algorithm>
#include <cstdint>
#include <utility>

#include "core/row_kernel.h"
#include "enhancer/simd_switch.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace turbid::guided_internal {

// Row kernels of the one-channel filter (TURBID_ROW_KERNEL). Each processes a whole row of
// contiguous floats, so the loops vectorise.

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

// Sum of W consecutive values from ext[x]; for W >= 9 from the sums of 4 in `quads`.
template <int W>
inline float WindowSumAt(const float* __restrict ext, const float* __restrict quads, int x) {
  if constexpr (W >= 9) {
    constexpr int kQuads = W / 4;
    float s = quads[x];
    for (int q = 1; q < kQuads; ++q) s += quads[x + 4 * q];
    for (int k = 4 * kQuads; k < W; ++k) s += ext[x + k];
    return s;
  } else {
    float s = ext[x];
    for (int k = 1; k < W; ++k) s += ext[x + k];
    return s;
  }
}

// Sums of 4 consecutive values of two padded rows (the first pass of BlockedWindowSums).
template <int W>
TURBID_ROW_KERNEL void QuadSumsPair(const float* __restrict e0, const float* __restrict e1,
                                    float* __restrict q0, float* __restrict q1, int w) {
  const int n = w + 4 * (W / 4 - 1);
  for (int x = 0; x < n; ++x) {
    q0[x] = e0[x] + e0[x + 1] + e0[x + 2] + e0[x + 3];
    q1[x] = e1[x] + e1[x + 1] + e1[x + 2] + e1[x + 3];
  }
}

template <int W>
TURBID_ROW_KERNEL void SelfCoefficientsFused(
    const float* __restrict e_i, const float* __restrict e_ii, const float* __restrict q_i,
    const float* __restrict q_ii, const float* __restrict inv_cx, float inv_cy, float eps,
    float* __restrict a, float* __restrict b, int w) {
  for (int x = 0; x < w; ++x) {
    SelfCoefficient(WindowSumAt<W>(e_i, q_i, x), WindowSumAt<W>(e_ii, q_ii, x), inv_cx[x] * inv_cy,
                    eps, a + x, b + x);
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

template <int W>
TURBID_ROW_KERNEL void ApplyCoefficientsFused(
    const float* __restrict e_a, const float* __restrict e_b, const float* __restrict q_a,
    const float* __restrict q_b, const float* __restrict guide, const float* __restrict inv_cx,
    float inv_cy, float* __restrict q, int w) {
  for (int x = 0; x < w; ++x) {
    q[x] = ApplyCoefficient(WindowSumAt<W>(e_a, q_a, x), WindowSumAt<W>(e_b, q_b, x), guide[x],
                            inv_cx[x] * inv_cy);
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

#undef TURBID_AVX2
#endif

template <int R>
FusedKernels MakeFusedKernels([[maybe_unused]] bool avx2) {
  constexpr int W = 2 * R + 1;
  FusedKernels k;
  k.self_coefficients = &SelfCoefficientsFused<W>;
  k.guided_coefficients = &GuidedCoefficientsFused<W>;
  k.apply = &ApplyCoefficientsFused<W>;
  if constexpr (W >= 9) {
    k.quads = &QuadSumsPair<W>;
#ifdef TURBID_HAVE_ROLLING_QUADS
    if (avx2) {
      k.quads = nullptr;
      k.self_coefficients = &SelfCoefficientsRolling<W>;
      k.guided_coefficients = &GuidedCoefficientsRolling<W>;
      k.apply = &ApplyCoefficientsRolling<W>;
    }
#endif
  }
  return k;
}

// Kernels for radius r.
template <int... R>
FusedKernels FusedKernelsFor(int r, std::integer_sequence<int, R...>) {
  static const FusedKernels portable[] = {MakeFusedKernels<R + 1>(false)...};
  static const FusedKernels avx2[] = {MakeFusedKernels<R + 1>(true)...};
  return enhancer_internal::UseHandWrittenAvx2() ? avx2[r - 1] : portable[r - 1];
}

FusedKernels FusedKernelsFor(int r) {
  return FusedKernelsFor(r, std::make_integer_sequence<int, kMaxFusedRadius>{});
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

}  // namespace turbid::guided_internal
