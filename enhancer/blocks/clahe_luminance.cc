// Colour CLAHE's luminance steps: Rec. 709 luminance of interleaved rows and the channels
// scaled by the equalised luminance's ratio (portable and AVX2 twins, bit-identical).
#include "enhancer/blocks/clahe_luminance.h"

#include <algorithm>

#include "core/row_kernel.h"
#include "enhancer/simd_switch.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace turbid::clahe_internal {
namespace {

// Rec. 709 luminance of an interleaved B, G, R row (kRgb: R, G, B; the same sum in the same
// order either way, so the same values).
template <bool kRgb>
TURBID_ROW_KERNEL void LuminanceRowT(const float* __restrict px, float* __restrict lum, int w) {
  constexpr int b = kRgb ? 2 : 0, r = kRgb ? 0 : 2;
  for (int x = 0; x < w; ++x) {
    lum[x] = 0.0722f * px[3 * x + b] + 0.7152f * px[3 * x + 1] + 0.2126f * px[3 * x + r];
  }
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// AVX2 twins of LuminanceRowT and LuminanceRatioRow (GCC does not vectorise the stride-3 channel
// reads). Eight pixels are 24 interleaved floats in three vectors v0 v1 v2; two blends gather one
// channel's eight values (in the order 0 3 6 1 4 7 2 5 for channel 0, and likewise rotated for 1
// and 2) and one lane permutation puts them in order. The arithmetic is the portable loops' (the
// same products and sums in the same order, no FMA: the target does not enable it), so the
// values are bit-identical.
struct Channels {
  __m256 c0, c1, c2;
};
__attribute__((target("avx2"))) inline Channels Deinterleave(const float* px) {
  const __m256 v0 = _mm256_loadu_ps(px), v1 = _mm256_loadu_ps(px + 8),
               v2 = _mm256_loadu_ps(px + 16);
  // Lanes taken from v1 (0x92: lanes 1, 4, 7) and v2 (0x24: lanes 2, 5) for channel 0; the other
  // channels' masks are these rotated by one lane.
  const __m256 t0 = _mm256_blend_ps(_mm256_blend_ps(v0, v1, 0x92), v2, 0x24);
  const __m256 t1 = _mm256_blend_ps(_mm256_blend_ps(v0, v1, 0x24), v2, 0x49);
  const __m256 t2 = _mm256_blend_ps(_mm256_blend_ps(v0, v1, 0x49), v2, 0x92);
  return {_mm256_permutevar8x32_ps(t0, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5)),
          _mm256_permutevar8x32_ps(t1, _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6)),
          _mm256_permutevar8x32_ps(t2, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7))};
}

template <bool kRgb>
__attribute__((target("avx2"))) inline __m256 Luminance8(const float* px) {
  const Channels c = Deinterleave(px);
  const __m256 b = kRgb ? c.c2 : c.c0, r = kRgb ? c.c0 : c.c2;
  return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(0.0722f), b),
                                     _mm256_mul_ps(_mm256_set1_ps(0.7152f), c.c1)),
                       _mm256_mul_ps(_mm256_set1_ps(0.2126f), r));
}

template <bool kRgb>
__attribute__((target("avx2"))) void LuminanceRowAvx2(const float* px, float* lum, int w) {
  int x = 0;
  for (; x + 8 <= w; x += 8) _mm256_storeu_ps(lum + x, Luminance8<kRgb>(px + 3 * x));
  LuminanceRowT<kRgb>(px + 3 * x, lum + x, w - x);
}
#define TURBID_HAVE_LUMINANCE_AVX2 1
#endif

}  // namespace

void LuminanceRow(const float* px, float* lum, int w, bool rgb) {
#ifdef TURBID_HAVE_LUMINANCE_AVX2
  if (enhancer_internal::UseHandWrittenAvx2()) {
    if (rgb) {
      LuminanceRowAvx2<true>(px, lum, w);
    } else {
      LuminanceRowAvx2<false>(px, lum, w);
    }
    return;
  }
#endif
  if (rgb) {
    LuminanceRowT<true>(px, lum, w);
  } else {
    LuminanceRowT<false>(px, lum, w);
  }
}

namespace {

// The channels scaled by the luminance ratio (hue kept), in place over `bgr` (each value read
// and then written at the same index; one pointer, so the loop vectorises without an aliasing
// check). Where the luminance is ~0, gray at the equalised value. Branch-free (the ratio is
// formed everywhere and dropped where l is ~0).
TURBID_ROW_KERNEL void LuminanceRatioRow(float* __restrict bgr, const float* __restrict lum,
                                         const float* __restrict eq, int w) {
  for (int x = 0; x < w; ++x) {
    const float l = lum[x], e = eq[x];
    const float g = e / l;
    const bool dark = l <= 1e-6f;
    for (int c = 0; c < 3; ++c) {
      const float v = std::min(std::max(bgr[3 * x + c] * g, 0.0f), 1.0f);
      bgr[3 * x + c] = dark ? e : v;
    }
  }
}

#ifdef TURBID_HAVE_LUMINANCE_AVX2
// The luminance of each pixel (as LuminanceRowT computes it) and the ratio step of
// LuminanceRatioRow in one pass over the row, in place: per 8 pixels the luminance from the
// deinterleaved channels, g = e / l, then g, e and the dark test spread back to the three
// interleaved vectors by lane permutations. Same operations in the same order; std::max(x, 0)
// and std::min(x, 1) as max_ps(0, x) and min_ps(1, x) (NaN and -0 come out the same).
template <bool kRgb>
__attribute__((target("avx2"))) void LuminanceRatioRowAvx2(float* bgr, const float* eq, int w,
                                                           float* lum_tail, const float* next) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), tiny = _mm256_set1_ps(1e-6f);
  const __m256i spread0 = _mm256_setr_epi32(0, 0, 0, 1, 1, 1, 2, 2);
  const __m256i spread1 = _mm256_setr_epi32(2, 3, 3, 3, 4, 4, 4, 5);
  const __m256i spread2 = _mm256_setr_epi32(5, 5, 6, 6, 6, 7, 7, 7);
  int x = 0;
  for (; x + 8 <= w; x += 8) {
    float* p = bgr + 3 * x;
    if (next != nullptr) {
      __builtin_prefetch(next + 3 * x, 1, 3);
      __builtin_prefetch(next + 3 * x + 16, 1, 3);
    }
    const __m256 l = Luminance8<kRgb>(p), e = _mm256_loadu_ps(eq + x);
    const __m256 g = _mm256_div_ps(e, l);
    const __m256 dark = _mm256_cmp_ps(l, tiny, _CMP_LE_OQ);
    const __m256i spread[3] = {spread0, spread1, spread2};
    if (_mm256_movemask_ps(dark) == 0) {  // no dark pixel (the usual case): no blend with e
      for (int k = 0; k < 3; ++k) {
        const __m256 gk = _mm256_permutevar8x32_ps(g, spread[k]);
        const __m256 v = _mm256_mul_ps(_mm256_loadu_ps(p + 8 * k), gk);
        _mm256_storeu_ps(p + 8 * k, _mm256_min_ps(one, _mm256_max_ps(zero, v)));
      }
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const __m256 gk = _mm256_permutevar8x32_ps(g, spread[k]);
      const __m256 ek = _mm256_permutevar8x32_ps(e, spread[k]);
      const __m256 dk = _mm256_permutevar8x32_ps(dark, spread[k]);
      const __m256 v = _mm256_mul_ps(_mm256_loadu_ps(p + 8 * k), gk);
      const __m256 c = _mm256_min_ps(one, _mm256_max_ps(zero, v));
      _mm256_storeu_ps(p + 8 * k, _mm256_blendv_ps(c, ek, dk));
    }
  }
  LuminanceRowT<kRgb>(bgr + 3 * x, lum_tail, w - x);
  LuminanceRatioRow(bgr + 3 * x, lum_tail, eq + x, w - x);
}
#endif

}  // namespace

void LuminanceRatioRowInPlace(float* row, const float* e, int cols, float* lum, const float* next,
                              bool rgb) {
#ifdef TURBID_HAVE_LUMINANCE_AVX2
  if (enhancer_internal::UseHandWrittenAvx2()) {
    if (rgb) {
      LuminanceRatioRowAvx2<true>(row, e, cols, lum, next);
    } else {
      LuminanceRatioRowAvx2<false>(row, e, cols, lum, next);
    }
    return;
  }
#endif
  LuminanceRow(row, lum, cols, rgb);
  LuminanceRatioRow(row, lum, e, cols);
}

}  // namespace turbid::clahe_internal
