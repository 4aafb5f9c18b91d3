// `full`'s and `simplified`'s row kernels: the portable loops (TURBID_ROW_KERNEL) and the
// hand-written AVX2 versions with the arithmetic of the portable ones (enhancer/paper/kernels.h).
#include "enhancer/paper/kernels.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/cpu.h"
#include "enhancer/simd_vec.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace turbid::paper_internal {
namespace {

// |I * N| at value i of row b (a above, c below), ch values between horizontal neighbours.
inline float LaplacianAbsAt(const float* a, const float* b, const float* c, int i, int ch) {
  const float v = (a[i - ch] + a[i + ch] + c[i - ch] + c[i + ch]) -
                  2.0f * (a[i] + c[i] + b[i - ch] + b[i + ch]) + 4.0f * b[i];
  return std::abs(v);
}

}  // namespace

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
bool CpuHasFma() { return CpuHas(CpuLevel::kAvx2Fma); }
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
template bool BoostClampRowAvx2<true>(const float*, const float*, double, double, float*, int,
                                      float*, float*);
template bool BoostClampRowAvx2<false>(const float*, const float*, double, double, float*, int,
                                       float*, float*);
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
#endif

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
TURBID_VEC16_WARNINGS_OFF
// Sixteen rows' sums of |I * N| at once with AVX-512 (LaplacianAbsSums8 at twice the width: per
// sixteen values the sixteen rows' vectors are transposed so that lane k holds row k, and added
// to lane k's sum in value order; the same float chain per row, bit for bit).
// (No contraction: a fused 4 b + x would not overflow where the portable loop's 4 b does.)
__attribute__((target("avx512f,avx2,fma"), optimize("fp-contract=off"))) inline __m512
LaplacianAbs16(const float* a, const float* b, const float* c, int i, int ch) {
  __m512 s = _mm512_add_ps(_mm512_loadu_ps(a + i - ch), _mm512_loadu_ps(a + i + ch));
  s = _mm512_add_ps(s, _mm512_loadu_ps(c + i - ch));
  s = _mm512_add_ps(s, _mm512_loadu_ps(c + i + ch));
  __m512 m = _mm512_add_ps(_mm512_loadu_ps(a + i), _mm512_loadu_ps(c + i));
  m = _mm512_add_ps(m, _mm512_loadu_ps(b + i - ch));
  m = _mm512_add_ps(m, _mm512_loadu_ps(b + i + ch));
  const __m512 v = _mm512_add_ps(_mm512_sub_ps(s, _mm512_mul_ps(_mm512_set1_ps(2.0f), m)),
                                 _mm512_mul_ps(_mm512_set1_ps(4.0f), _mm512_loadu_ps(b + i)));
  return _mm512_abs_ps(v);
}

// r[q] lane k <- r[k] lane q (16 x 16).
__attribute__((target("avx512f,avx2,fma"))) inline void Transpose16(__m512* r) {
  __m512 t[16];
  for (int k = 0; k < 16; k += 2) {
    t[k] = _mm512_unpacklo_ps(r[k], r[k + 1]);
    t[k + 1] = _mm512_unpackhi_ps(r[k], r[k + 1]);
  }
  for (int k = 0; k < 16; k += 4) {
    const __m512d t0 = _mm512_castps_pd(t[k]), t1 = _mm512_castps_pd(t[k + 1]);
    const __m512d t2 = _mm512_castps_pd(t[k + 2]), t3 = _mm512_castps_pd(t[k + 3]);
    r[k] = _mm512_castpd_ps(_mm512_unpacklo_pd(t0, t2));
    r[k + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(t0, t2));
    r[k + 2] = _mm512_castpd_ps(_mm512_unpacklo_pd(t1, t3));
    r[k + 3] = _mm512_castpd_ps(_mm512_unpackhi_pd(t1, t3));
  }
  for (int h = 0; h < 16; h += 8) {
    for (int k = 0; k < 4; ++k) {
      t[h + k] = _mm512_shuffle_f32x4(r[h + k], r[h + k + 4], 0x88);
      t[h + k + 4] = _mm512_shuffle_f32x4(r[h + k], r[h + k + 4], 0xdd);
    }
  }
  for (int k = 0; k < 8; ++k) {
    r[k] = _mm512_shuffle_f32x4(t[k], t[k + 8], 0x88);
    r[k + 8] = _mm512_shuffle_f32x4(t[k], t[k + 8], 0xdd);
  }
}

__attribute__((target("avx512f,avx2,fma"), optimize("fp-contract=off"))) void LaplacianAbsSums16(
    const float* const* rows, int ch, int n, float* row) {
  __m512 acc = _mm512_setzero_ps();
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    const int i = j + ch;
    __m512 v[16];
    for (int k = 0; k < 16; ++k) v[k] = LaplacianAbs16(rows[k], rows[k + 1], rows[k + 2], i, ch);
    Transpose16(v);
    for (int q = 0; q < 16; ++q) acc = _mm512_add_ps(acc, v[q]);
  }
  _mm512_storeu_ps(row, acc);
  for (int k = 0; k < 16; ++k) {
    for (int jj = j; jj < n; ++jj) {
      row[k] += LaplacianAbsAt(rows[k], rows[k + 1], rows[k + 2], jj + ch, ch);
    }
  }
}
TURBID_VEC16_WARNINGS_ON
#endif

#ifdef TURBID_HAVE_DEHAZE_AVX2
// Eq. 6 and the step after it at 8 and 16 lanes (kernels_dehaze.inc, written once over the
// width; the same bits at both).
namespace {
#define TURBID_VEC_BODY "enhancer/paper/kernels_dehaze.inc"
#include "enhancer/simd_widths.inc"  // NOLINT(build/include): the body at 8 and 16 lanes
}  // namespace

template <AfterDehaze kAfter>
void DehazeSpreadAvx2(const float* in, const float* e, const double* scale, const float* t,
                      const float* image, float inv_level, float k_detail, float* d, int w) {
  if (KernelCpuLevel() >= CpuLevel::kAvx512) {
    vec16::DehazeSpread<kAfter>(in, e, scale, t, image, inv_level, k_detail, d, w);
  } else {
    vec8::DehazeSpread<kAfter>(in, e, scale, t, image, inv_level, k_detail, d, w);
  }
}
template void DehazeSpreadAvx2<AfterDehaze::kNone>(const float*, const float*, const double*,
                                                   const float*, const float*, float, float, float*,
                                                   int);
template void DehazeSpreadAvx2<AfterDehaze::kScale>(const float*, const float*, const double*,
                                                    const float*, const float*, float, float,
                                                    float*, int);
template void DehazeSpreadAvx2<AfterDehaze::kScaleDetail>(const float*, const float*, const double*,
                                                          const float*, const float*, float, float,
                                                          float*, int);
#endif

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

}  // namespace turbid::paper_internal
