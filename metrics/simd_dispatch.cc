#include "metrics/simd_dispatch.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "core/cpu.h"
#include "metrics/simd_edges_avx2.h"

// The same loops compiled twice; the AVX2 + FMA copy is chosen at run time when the CPU has both
// (checked once). Results of the two copies differ in the last float bits (FMA contraction), so
// scores can differ by ~1e-7 between machines; on one machine they are deterministic.
namespace turbid::simd {

// An optimisation barrier on a double: a product passed through it cannot be contracted with a
// following addition into an FMA (this file is compiled with -ffp-contract=fast), for kernels
// that must round exactly as their scalar reference.
#if defined(__x86_64__) && defined(__GNUC__)
#define TURBID_NO_CONTRACT(...) __asm__("" : "+x"(__VA_ARGS__))
#else
#define TURBID_NO_CONTRACT(...) __asm__("" : "+m"(__VA_ARGS__))
#endif

namespace base {
#include "metrics/simd_kernels.inc"

// Plain references of the fused SSIM kernels (the AVX2 copies below add in the same order).
void SymmetricColumnPair(const float* const* rows, const float* weights, int taps, float* out0,
                         float* out1, int n) {
  const int r = taps / 2;
  for (int j = 0; j < n; ++j) {
    float a0 = weights[r] * rows[r][j];
    float a1 = weights[r] * rows[r + 1][j];
    for (int k = 1; k <= r; ++k) {
      a0 += weights[r + k] * (rows[r - k][j] + rows[r + k][j]);
      a1 += weights[r + k] * (rows[r + 1 - k][j] + rows[r + 1 + k][j]);
    }
    out0[j] = a0;
    out1[j] = a1;
  }
}

void SymmetricColumnQuad(const float* const* rows, const float* weights, int taps,
                         float* const* out, int n) {
  SymmetricColumnPair(rows, weights, taps, out[0], out[1], n);
  SymmetricColumnPair(rows + 2, weights, taps, out[2], out[3], n);
}

void SsimHorizontalFormula(const float* const* moments, const float* weights, int taps, int n,
                           double offset, double c1, double c2, double* out) {
  const int r = taps / 2;
  for (int j = 0; j < n; ++j) {
    float m[4];
    for (int q = 0; q < 4; ++q) {
      const float* p = moments[q] + j;
      float a = weights[r] * p[0];
      for (int k = 1; k <= r; ++k) a += weights[r + k] * (p[-k] + p[k]);
      m[q] = a;
    }
    SsimFormulaRow(&m[0], &m[1], &m[2], &m[3], 1, offset, c1, c2, out + j);
  }
}
}  // namespace base

#if defined(__x86_64__) && defined(__GNUC__)
#define TURBID_HAVE_AVX2_COPY 1
#if defined(__clang__)  // the sanitizer build (CMakeLists.txt, TURBID_SANITIZE)
#pragma clang attribute push(__attribute__((target("avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,fma")
#endif
namespace avx2 {
#include "metrics/simd_kernels.inc"

// Vertical pass, two output rows: rows[r - k] + rows[r + k] feeds row 0 and rows[r + 1 - k] +
// rows[r + 2 + k - 1] row 1; walking k outwards, each input row is loaded once for both outputs
// (taps + 1 loads per two outputs instead of 2 * taps). 16 columns per step: four independent
// chains keep both FMA pipes busy while the loads stream from L2.
template <int kRadius>
void SymmetricColumnPairFast(const float* const* rows, const float* weights, int taps, float* out0,
                             float* out1, int n) {
  const int r = kRadius > 0 ? kRadius : taps / 2;
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    __m256 lo_prev[2], hi[2], acc0[2], acc1[2];
    const __m256 wc = _mm256_broadcast_ss(weights + r);
    for (int l = 0; l < 2; ++l) {
      lo_prev[l] = _mm256_loadu_ps(rows[r] + j + 8 * l);
      hi[l] = _mm256_loadu_ps(rows[r + 1] + j + 8 * l);
      acc0[l] = _mm256_mul_ps(wc, lo_prev[l]);
      acc1[l] = _mm256_mul_ps(wc, hi[l]);
    }
    for (int k = 1; k <= r; ++k) {
      const __m256 w = _mm256_broadcast_ss(weights + r + k);
      const float* lo_row = rows[r - k] + j;
      const float* hi_row = rows[r + 1 + k] + j;
      for (int l = 0; l < 2; ++l) {
        const __m256 lo = _mm256_loadu_ps(lo_row + 8 * l);
        const __m256 hi_next = _mm256_loadu_ps(hi_row + 8 * l);
        acc0[l] = _mm256_fmadd_ps(w, _mm256_add_ps(lo, hi[l]), acc0[l]);
        acc1[l] = _mm256_fmadd_ps(w, _mm256_add_ps(lo_prev[l], hi_next), acc1[l]);
        lo_prev[l] = lo;
        hi[l] = hi_next;
      }
    }
    for (int l = 0; l < 2; ++l) {
      _mm256_storeu_ps(out0 + j + 8 * l, acc0[l]);
      _mm256_storeu_ps(out1 + j + 8 * l, acc1[l]);
    }
  }
  for (; j < n; ++j) {
    float a0 = weights[r] * rows[r][j];
    float a1 = weights[r] * rows[r + 1][j];
    for (int k = 1; k <= r; ++k) {
      a0 = std::fma(weights[r + k], rows[r - k][j] + rows[r + k][j], a0);
      a1 = std::fma(weights[r + k], rows[r + 1 - k][j] + rows[r + 1 + k][j], a1);
    }
    out0[j] = a0;
    out1[j] = a1;
  }
}

// Four output rows from taps + 3 input rows, 8 columns at a time: the input vectors are loaded once
// (from L2: the ring of four moments does not fit L1) and reused from registers or L1 for all four
// rows, which cuts the L2 traffic of the vertical pass from 6 to 3.5 loads per output.
template <int kRadius>
void SymmetricColumnQuadFast(const float* const* rows, const float* weights, float* const* out,
                             int n) {
  constexpr int kTaps = 2 * kRadius + 1;
  __m256 w[kRadius + 1];
  for (int k = 0; k <= kRadius; ++k) w[k] = _mm256_broadcast_ss(weights + kRadius + k);
  const auto row_sum = [&](const __m256* v, int t) {
    __m256 acc = _mm256_mul_ps(w[0], v[kRadius + t]);
    for (int k = 1; k <= kRadius; ++k)
      acc = _mm256_fmadd_ps(w[k], _mm256_add_ps(v[kRadius + t - k], v[kRadius + t + k]), acc);
    return acc;
  };
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    __m256 v[kTaps + 3];
    for (int s = 0; s < kTaps + 3; ++s) v[s] = _mm256_loadu_ps(rows[s] + j);
    for (int t = 0; t < 4; ++t) _mm256_storeu_ps(out[t] + j, row_sum(v, t));
  }
  for (; j < n; ++j)
    for (int t = 0; t < 4; ++t) {
      float acc = weights[kRadius] * rows[kRadius + t][j];
      for (int k = 1; k <= kRadius; ++k)
        acc = std::fma(weights[kRadius + k], rows[kRadius + t - k][j] + rows[kRadius + t + k][j],
                       acc);
      out[t][j] = acc;
    }
}

// SSIM of eight columns from their moments, in float: the moments themselves are float sums, so
// the formula in double would only carry their rounding further, at twice the cost and two double
// divides. As in SsimFormulaRow, the denominators are numerator + difference terms
// (ux^2 + uy^2 = 2 ux uy + (ux - uy)^2, vx + vy = 2 vxy + var(x - y)): identical inputs then give
// exactly 1, and the offset never cancels in ux - uy.
inline __m256 FormulaPs(__m256 dx, __m256 dy, __m256 mxy, __m256 mdd, __m256 offset, __m256 c1,
                        __m256 c2) {
  const __m256 two = _mm256_set1_ps(2.0f);
  const __m256 ux = _mm256_add_ps(dx, offset);
  const __m256 uy = _mm256_add_ps(dy, offset);
  const __m256 vxy = _mm256_fnmadd_ps(dx, dy, mxy);
  const __m256 a1 = _mm256_fmadd_ps(_mm256_mul_ps(two, ux), uy, c1);
  const __m256 a2 = _mm256_fmadd_ps(two, vxy, c2);
  const __m256 d = _mm256_sub_ps(dx, dy);
  const __m256 d2 = _mm256_mul_ps(d, d);
  const __m256 b1 = _mm256_add_ps(a1, d2);
  const __m256 b2 = _mm256_add_ps(a2, _mm256_sub_ps(mdd, d2));
  return _mm256_div_ps(_mm256_mul_ps(a1, a2), _mm256_mul_ps(b1, b2));
}

// The filtered moment q of eight columns at p: every column takes this arithmetic, whichever block
// it falls in.
template <int kRadius>
inline __m256 HorizontalTaps(const float* p, const float* weights, int r) {
  __m256 m = _mm256_mul_ps(_mm256_broadcast_ss(weights + r), _mm256_loadu_ps(p));
  for (int k = 1; k <= r; ++k)
    m = _mm256_fmadd_ps(_mm256_broadcast_ss(weights + r + k),
                        _mm256_add_ps(_mm256_loadu_ps(p - k), _mm256_loadu_ps(p + k)), m);
  return m;
}

inline void StoreSsim(__m256 s, double* out) {
  _mm256_storeu_pd(out, _mm256_cvtps_pd(_mm256_castps256_ps128(s)));
  _mm256_storeu_pd(out + 4, _mm256_cvtps_pd(_mm256_extractf128_ps(s, 1)));
}

// Horizontal pass of the four moments, 16 columns at a time (two blocks of 8 whose windows overlap,
// so the loads at offsets 8 - r .. r serve both), straight into the formula: the filtered moments
// never leave registers. A ragged end is done as (overlapping) blocks of 8, so every column takes
// the same arithmetic wherever the column range starts.
template <int kRadius>
void SsimHorizontalFormulaFast(const float* const* moments, const float* weights, int taps, int n,
                               double offset, double c1, double c2, double* out) {
  const int r = kRadius > 0 ? kRadius : taps / 2;
  if (n < 8) {
    // Fewer than 8 columns: the same vector arithmetic on a zero-extended copy, so that a narrow
    // column range gives bit for bit what the wide one gives for the same columns.
    constexpr int kMaxRadius = 64;
    alignas(32) float copy[4][8 + 2 * kMaxRadius] = {};
    const float* rows[4];
    for (int q = 0; q < 4; ++q) {
      std::copy(moments[q] - r, moments[q] + n + r, copy[q]);
      rows[q] = copy[q] + r;
    }
    double block[8];
    SsimHorizontalFormulaFast<kRadius>(rows, weights, taps, 8, offset, c1, c2, block);
    std::copy(block, block + n, out);
    return;
  }
  const __m256 o = _mm256_set1_ps(static_cast<float>(offset));
  const __m256 vc1 = _mm256_set1_ps(static_cast<float>(c1));
  const __m256 vc2 = _mm256_set1_ps(static_cast<float>(c2));
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    __m256 m0[4], m1[4];
    for (int q = 0; q < 4; ++q) {
      m0[q] = HorizontalTaps<kRadius>(moments[q] + j, weights, r);
      m1[q] = HorizontalTaps<kRadius>(moments[q] + j + 8, weights, r);
    }
    StoreSsim(FormulaPs(m0[0], m0[1], m0[2], m0[3], o, vc1, vc2), out + j);
    StoreSsim(FormulaPs(m1[0], m1[1], m1[2], m1[3], o, vc1, vc2), out + j + 8);
  }
  for (; j < n; j += 8) {
    const int b = std::min(j, n - 8);
    __m256 m[4];
    for (int q = 0; q < 4; ++q) m[q] = HorizontalTaps<kRadius>(moments[q] + b, weights, r);
    StoreSsim(FormulaPs(m[0], m[1], m[2], m[3], o, vc1, vc2), out + b);
  }
}

// Four pixels per step: the chroma and l² gathered from tables, the division and the square
// root in 4-lane double (each correctly rounded, as the scalar ones).
void UciqeSaturationFast(const uint8_t* lab, int n, const double* chroma, double* out,
                         double* chr_out) {
  // l² = (L / 255)² for the 256 values of L, rounded as the scalar code does.
  static const std::array<double, 256> l_squared = [] {
    std::array<double, 256> t{};
    for (int v = 0; v < 256; ++v) {
      const double l = v / 255.0;
      double l2 = l * l;
      TURBID_NO_CONTRACT(l2);
      t[v] = l2;
    }
    return t;
  }();
  const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const uint8_t* p = lab + 3 * k;
    const __m128i l8 = _mm_setr_epi32(p[0], p[3], p[6], p[9]);
    const __m128i ab = _mm_setr_epi32(p[1] * 256 + p[2], p[4] * 256 + p[5], p[7] * 256 + p[8],
                                      p[10] * 256 + p[11]);
    const __m256d l2 = _mm256_mask_i32gather_pd(_mm256_setzero_pd(), l_squared.data(), l8, all, 8);
    const __m256d chr = _mm256_mask_i32gather_pd(_mm256_setzero_pd(), chroma, ab, all, 8);
    _mm256_storeu_pd(chr_out + k, chr);
    __m256d chr2 = _mm256_mul_pd(chr, chr);
    TURBID_NO_CONTRACT(chr2);  // no FMA: the sum is rounded after each product
    const __m256d sum = _mm256_add_pd(chr2, l2);
    _mm256_storeu_pd(out + k, _mm256_div_pd(chr, _mm256_sqrt_pd(sum)));
  }
  UciqeSaturation(lab + 3 * k, n - k, chroma, out + k, chr_out + k);
}

void UciqeSpreadFast(const uint8_t* lab, int n, const double* chroma, double mean, double* out) {
  const __m256d m = _mm256_set1_pd(mean);
  const __m256d one = _mm256_set1_pd(1.0);
  const __m256d sign = _mm256_set1_pd(-0.0);
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const uint8_t* p = lab + 3 * k;
    const __m128i ab = _mm_setr_epi32(p[1] * 256 + p[2], p[4] * 256 + p[5], p[7] * 256 + p[8],
                                      p[10] * 256 + p[11]);
    const __m256d chr = _mm256_mask_i32gather_pd(_mm256_setzero_pd(), chroma, ab,
                                                 _mm256_castsi256_pd(_mm256_set1_epi64x(-1)), 8);
    const __m256d q = _mm256_div_pd(m, chr);
    __m256d q2 = _mm256_mul_pd(q, q);
    TURBID_NO_CONTRACT(q2);  // no FMA: 1 − q² rounded after the product
    _mm256_storeu_pd(out + k, _mm256_andnot_pd(sign, _mm256_sub_pd(one, q2)));
  }
  UciqeSpread(lab + 3 * k, n - k, chroma, mean, out + k);
}

// Eight pixels per step. Zen 4 and most x86 cores serve a gather at about one element per cycle,
// a third of what plain loads reach (measured: a gather version took ~1.8× as long), so the look-ups
// are loads: per pixel, X, Y, Z as one 128-bit sum of its three {X, Y, Z, 0} term rows, then f(t)
// of each; L, a, b, the clamping packs and the interleaving are vector code over the 8 pixels. Each step stores 2 × 16 bytes of which 24 are its pixels, so it runs while two more
// pixels follow; the portable loop does the rest.
void BgrToLab8Fast(const uint8_t* bgr, int n, const Lab8Tables& t, uint8_t* lab) {
  const __m256i l_scale = _mm256_set1_epi32(kLab8LScale);
  const __m256i l_shift = _mm256_set1_epi32(kLab8LShift);
  const __m256i ab_shift = _mm256_set1_epi32(kLab8AbShift);
  const __m256i c500 = _mm256_set1_epi32(500);
  const __m256i c200 = _mm256_set1_epi32(200);
  // L0..L3 a0..a3 b0..b3 (after the packs, per 128-bit lane) → L0 a0 b0 L1 a1 b1 ...
  const __m256i interleave = _mm256_setr_epi8(0, 4, 8, 1, 5, 9, 2, 6, 10, 3, 7, 11, -1, -1, -1, -1,
                                              0, 4, 8, 1, 5, 9, 2, 6, 10, 3, 7, 11, -1, -1, -1, -1);
  int k = 0;
  for (; k + 10 <= n; k += 8) {
    alignas(32) int32_t f[3][8];
    for (int i = 0; i < 8; ++i) {
      // X, Y, Z of one pixel in one 128-bit sum of its three term rows.
      const uint8_t* p = bgr + 3 * (k + i);
      const __m128i sum = _mm_srai_epi32(
          _mm_add_epi32(
              _mm_add_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(t.xyz[0][p[0]])),
                            _mm_load_si128(reinterpret_cast<const __m128i*>(t.xyz[1][p[1]]))),
              _mm_load_si128(reinterpret_cast<const __m128i*>(t.xyz[2][p[2]]))),
          12);
      f[0][i] = t.cbrt[_mm_cvtsi128_si32(sum)];
      f[1][i] = t.cbrt[_mm_extract_epi32(sum, 1)];
      f[2][i] = t.cbrt[_mm_extract_epi32(sum, 2)];
    }
    const __m256i x = _mm256_load_si256(reinterpret_cast<const __m256i*>(f[0]));
    const __m256i y = _mm256_load_si256(reinterpret_cast<const __m256i*>(f[1]));
    const __m256i z = _mm256_load_si256(reinterpret_cast<const __m256i*>(f[2]));
    const __m256i l =
        _mm256_srai_epi32(_mm256_add_epi32(_mm256_mullo_epi32(y, l_scale), l_shift), 15);
    const __m256i a = _mm256_srai_epi32(
        _mm256_add_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(x, y), c500), ab_shift), 15);
    const __m256i b = _mm256_srai_epi32(
        _mm256_add_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(y, z), c200), ab_shift), 15);
    const __m256i la = _mm256_packus_epi32(l, a);  // u16: L0-3 a0-3 | L4-7 a4-7
    const __m256i b0 = _mm256_packus_epi32(b, _mm256_setzero_si256());  // u16: b0-3 0 | b4-7 0
    const __m256i bytes = _mm256_shuffle_epi8(_mm256_packus_epi16(la, b0), interleave);
    uint8_t* out = lab + 3 * k;
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out), _mm256_castsi256_si128(bytes));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 12), _mm256_extracti128_si256(bytes, 1));
  }
  avx2::BgrToLab8(bgr + 3 * k, n - k, t, lab + 3 * k);
}

}  // namespace avx2
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif

#if defined(TURBID_HAVE_AVX2_COPY)
#define TURBID_HAVE_AVX512_COPY 1
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f,avx2,fma")
#endif
// 16-lane copies of the two SSIM kernels that do most of the work. Every lane takes exactly the
// arithmetic of the 8-lane AVX2 kernels (same operations in the same order), so the results are
// bit for bit the same; what changes is the instruction count (on Zen 4 a 512-bit operation is one
// instruction for two 256-bit halves), which is what limits these loops.
namespace avx512 {

template <int kRadius>
void SymmetricColumnQuadFast(const float* const* rows, const float* weights, float* const* out,
                             int n) {
  constexpr int kTaps = 2 * kRadius + 1;
  __m512 w[kRadius + 1];
  for (int k = 0; k <= kRadius; ++k) w[k] = _mm512_set1_ps(weights[kRadius + k]);
  const auto row_sum = [&](const __m512* v, int t) {
    __m512 acc = _mm512_mul_ps(w[0], v[kRadius + t]);
    for (int k = 1; k <= kRadius; ++k)
      acc = _mm512_fmadd_ps(w[k], _mm512_add_ps(v[kRadius + t - k], v[kRadius + t + k]), acc);
    return acc;
  };
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    __m512 v[kTaps + 3];
    for (int s = 0; s < kTaps + 3; ++s) v[s] = _mm512_loadu_ps(rows[s] + j);
    for (int t = 0; t < 4; ++t) _mm512_storeu_ps(out[t] + j, row_sum(v, t));
  }
  if (j < n) {
    const float* rest[kTaps + 3];
    float* rest_out[4];
    for (int s = 0; s < kTaps + 3; ++s) rest[s] = rows[s] + j;
    for (int t = 0; t < 4; ++t) rest_out[t] = out[t] + j;
    avx2::SymmetricColumnQuadFast<kRadius>(rest, weights, rest_out, n - j);
  }
}

inline __m512 FormulaPs(__m512 dx, __m512 dy, __m512 mxy, __m512 mdd, __m512 offset, __m512 c1,
                        __m512 c2) {
  const __m512 two = _mm512_set1_ps(2.0f);
  const __m512 ux = _mm512_add_ps(dx, offset);
  const __m512 uy = _mm512_add_ps(dy, offset);
  const __m512 vxy = _mm512_fnmadd_ps(dx, dy, mxy);
  const __m512 a1 = _mm512_fmadd_ps(_mm512_mul_ps(two, ux), uy, c1);
  const __m512 a2 = _mm512_fmadd_ps(two, vxy, c2);
  const __m512 d = _mm512_sub_ps(dx, dy);
  const __m512 d2 = _mm512_mul_ps(d, d);
  const __m512 b1 = _mm512_add_ps(a1, d2);
  const __m512 b2 = _mm512_add_ps(a2, _mm512_sub_ps(mdd, d2));
  return _mm512_div_ps(_mm512_mul_ps(a1, a2), _mm512_mul_ps(b1, b2));
}

template <int kRadius>
inline __m512 HorizontalTaps(const float* p, const float* weights) {
  __m512 m = _mm512_mul_ps(_mm512_set1_ps(weights[kRadius]), _mm512_loadu_ps(p));
  for (int k = 1; k <= kRadius; ++k)
    m = _mm512_fmadd_ps(_mm512_set1_ps(weights[kRadius + k]),
                        _mm512_add_ps(_mm512_loadu_ps(p - k), _mm512_loadu_ps(p + k)), m);
  return m;
}

// (The zero-masking forms: GCC 12 warns about the unmasked ones' undefined pass-through.)
inline void StoreSsim(__m512 s, double* out) {
  const __m256d lo = _mm512_maskz_extractf64x4_pd(0xF, _mm512_castps_pd(s), 0);
  _mm512_storeu_pd(out, _mm512_maskz_cvtps_pd(0xFF, _mm256_castpd_ps(lo)));
  const __m256d hi = _mm512_maskz_extractf64x4_pd(0xF, _mm512_castps_pd(s), 1);
  _mm512_storeu_pd(out + 8, _mm512_maskz_cvtps_pd(0xFF, _mm256_castpd_ps(hi)));
}

template <int kRadius>
void SsimHorizontalFormulaFast(const float* const* moments, const float* weights, int taps, int n,
                               double offset, double c1, double c2, double* out) {
  if (n < 16)
    return avx2::SsimHorizontalFormulaFast<kRadius>(moments, weights, taps, n, offset, c1, c2, out);
  const __m512 o = _mm512_set1_ps(static_cast<float>(offset));
  const __m512 vc1 = _mm512_set1_ps(static_cast<float>(c1));
  const __m512 vc2 = _mm512_set1_ps(static_cast<float>(c2));
  for (int j0 = 0; j0 < n; j0 += 16) {
    const int j = std::min(j0, n - 16);
    __m512 m[4];
    for (int q = 0; q < 4; ++q) m[q] = HorizontalTaps<kRadius>(moments[q] + j, weights);
    StoreSsim(FormulaPs(m[0], m[1], m[2], m[3], o, vc1, vc2), out + j);
  }
}

}  // namespace avx512
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif

namespace {
SimdLevel CpuSimdLevel() {
#ifdef TURBID_HAVE_AVX2_COPY
  const CpuLevel cpu = DetectedCpuLevel();
  if (cpu < CpuLevel::kAvx2Fma) return SimdLevel::kBaseline;
  return cpu >= CpuLevel::kAvx512 ? SimdLevel::kAvx512 : SimdLevel::kAvx2;
#else
  return SimdLevel::kBaseline;
#endif
}

std::atomic<int> simd_level_cap{static_cast<int>(SimdLevel::kAvx512)};
// min(CPU level, cap), or −1 before the first use: one relaxed load per dispatched call (the
// window kernels are called a few times per 7×7 window).
std::atomic<int> active_level{-1};

int ComputeActiveLevel() {
  static const SimdLevel cpu = CpuSimdLevel();
  const int level = std::min(static_cast<int>(cpu), simd_level_cap.load(std::memory_order_relaxed));
  active_level.store(level, std::memory_order_relaxed);
  return level;
}

inline SimdLevel ActiveLevel() {
  const int level = active_level.load(std::memory_order_relaxed);
  return static_cast<SimdLevel>(level >= 0 ? level : ComputeActiveLevel());
}

inline bool UseAvx2() { return ActiveLevel() >= SimdLevel::kAvx2; }
inline bool UseAvx512() { return ActiveLevel() >= SimdLevel::kAvx512; }
}  // namespace

SimdLevel ActiveSimdLevel() { return ActiveLevel(); }

void SetSimdLevelCap(SimdLevel cap) {
  simd_level_cap.store(static_cast<int>(cap), std::memory_order_relaxed);
  ComputeActiveLevel();
}

#ifdef TURBID_HAVE_AVX2_COPY
#define TURBID_DISPATCH(call) return UseAvx2() ? avx2::call : base::call
#else
#define TURBID_DISPATCH(call) return base::call
#endif

void SymmetricColumnPair(const float* const* rows, const float* weights, int taps, float* out0,
                         float* out1, int n) {
#ifdef TURBID_HAVE_AVX2_COPY
  // The default window (sigma 1.5, truncate 3.5: 11 taps) with the tap loop unrolled.
  if (UseAvx2() && taps == 11)
    return avx2::SymmetricColumnPairFast<5>(rows, weights, taps, out0, out1, n);
  if (UseAvx2()) return avx2::SymmetricColumnPairFast<0>(rows, weights, taps, out0, out1, n);
#endif
  base::SymmetricColumnPair(rows, weights, taps, out0, out1, n);
}

void SymmetricColumnQuad(const float* const* rows, const float* weights, int taps,
                         float* const* out, int n) {
#ifdef TURBID_HAVE_AVX2_COPY
#ifdef TURBID_HAVE_AVX512_COPY
  if (UseAvx512() && taps == 11) return avx512::SymmetricColumnQuadFast<5>(rows, weights, out, n);
#endif
  if (UseAvx2() && taps == 11) return avx2::SymmetricColumnQuadFast<5>(rows, weights, out, n);
  if (UseAvx2()) {
    SymmetricColumnPair(rows, weights, taps, out[0], out[1], n);
    return SymmetricColumnPair(rows + 2, weights, taps, out[2], out[3], n);
  }
#endif
  base::SymmetricColumnQuad(rows, weights, taps, out, n);
}

void SsimHorizontalFormula(const float* const* moments, const float* weights, int taps, int n,
                           double offset, double c1, double c2, double* out) {
#ifdef TURBID_HAVE_AVX512_COPY
  if (UseAvx512() && taps == 11)
    return avx512::SsimHorizontalFormulaFast<5>(moments, weights, taps, n, offset, c1, c2, out);
#endif
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return taps == 11
               ? avx2::SsimHorizontalFormulaFast<5>(moments, weights, taps, n, offset, c1, c2, out)
               : avx2::SsimHorizontalFormulaFast<0>(moments, weights, taps, n, offset, c1, c2, out);
#endif
  base::SsimHorizontalFormula(moments, weights, taps, n, offset, c1, c2, out);
}

void CentredMomentsU8(const uint8_t* x, const uint8_t* y, int step, float offset, float* cx,
                      float* cy, float* xy, float* dd, int n) {
  TURBID_DISPATCH(CentredMomentsU8(x, y, step, offset, cx, cy, xy, dd, n));
}

double OrderedSum(const double* values, int n) { TURBID_DISPATCH(OrderedSum(values, n)); }

uint64_t SquaredDifferenceSumU8(const uint8_t* a, const uint8_t* b, size_t n) {
  TURBID_DISPATCH(SquaredDifferenceSumU8(a, b, n));
}

double SquaredDifferenceSumF32(const float* a, const float* b, size_t n) {
  TURBID_DISPATCH(SquaredDifferenceSumF32(a, b, n));
}

void WeberWindowSums(const double* table, int table_stride, const uint8_t* value,
                     const uint8_t* tests, int stride, int size, int s_min, int s_max,
                     double* sums_v, double* sums_h, double* counts_v, double* counts_h) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return avx2::WeberWindowSumsFast(table, table_stride, value, tests, stride, size, s_min, s_max,
                                     sums_v, sums_h, counts_v, counts_h);
#endif
  base::WeberWindowSums(table, table_stride, value, tests, stride, size, s_min, s_max, sums_v,
                        sums_h, counts_v, counts_h);
}

void AddPackedPairs(const uint8_t* value, const uint8_t* tests, int stride, int rows, int cols,
                    bool paper, int clip_lo, int clip_hi, double* acc) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return avx2::AddPackedPairsFast(value, tests, stride, rows, cols, paper, clip_lo, clip_hi, acc);
#endif
  base::AddPackedPairs(value, tests, stride, rows, cols, paper, clip_lo, clip_hi, acc);
}

void AddPackedBlocks(const uint8_t* value, const uint8_t* tests, int stride, bool paper,
                     const PackedBlock* blocks, int n_blocks) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::AddPackedBlocksFast(value, tests, stride, paper, blocks, n_blocks);
#endif
  base::AddPackedBlocks(value, tests, stride, paper, blocks, n_blocks);
}

PackedMaximum PackedContrasts(const double* const* parts, int n_parts, int s_min, int s_max,
                              double tie_width, double* contrast) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return avx2::PackedContrastsFast(parts, n_parts, s_min, s_max, tie_width, contrast);
#endif
  return base::PackedContrasts(parts, n_parts, s_min, s_max, tie_width, contrast);
}

PackedMaximum PackedContrastsWithStrip(const double* const* parts, int n_parts, double* strip,
                                       const double* const* adds, int n_add, int strip_lo,
                                       int strip_hi, int s_min, int s_max, double tie_width,
                                       double* contrast) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return avx2::PackedContrastsWithStripFast(parts, n_parts, strip, adds, n_add, strip_lo,
                                              strip_hi, s_min, s_max, tie_width, contrast);
#endif
  return base::PackedContrastsWithStrip(parts, n_parts, strip, adds, n_add, strip_lo, strip_hi,
                                        s_min, s_max, tie_width, contrast);
}

void IfsttarStrongRow(const uint8_t* tests, const uint8_t* row, const uint8_t* up, int n, int k,
                      int k_ratio, uint8_t* strong) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::IfsttarStrongRowFast(tests, row, up, n, k, k_ratio, strong);
#endif
  base::IfsttarStrongRow(tests, row, up, n, k, k_ratio, strong);
}

void SeparatedPairRows(const uint8_t* tests, int stride, int s0, unsigned* rows) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::SeparatedPairRowsFast(tests, stride, s0, rows);
#endif
  base::SeparatedPairRows(tests, stride, s0, rows);
}

void OctaveGrayU8(const uint8_t* bgr, int n, uint8_t* gray) {
  TURBID_DISPATCH(OctaveGrayU8(bgr, n, gray));
}

void BgrToLab8(const uint8_t* bgr, int n, const Lab8Tables& tables, uint8_t* lab) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::BgrToLab8Fast(bgr, n, tables, lab);
#endif
  base::BgrToLab8(bgr, n, tables, lab);
}

void UciqeSaturation(const uint8_t* lab, int n, const double* chroma, double* saturation,
                     double* chr) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::UciqeSaturationFast(lab, n, chroma, saturation, chr);
#endif
  base::UciqeSaturation(lab, n, chroma, saturation, chr);
}

void UciqeSpread(const uint8_t* lab, int n, const double* chroma, double mean, double* out) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::UciqeSpreadFast(lab, n, chroma, mean, out);
#endif
  base::UciqeSpread(lab, n, chroma, mean, out);
}

}  // namespace turbid::simd
