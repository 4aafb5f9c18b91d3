// AVX2 + FMA copy of simplified_rows.h's output step: per block of 8 segment columns and group of
// 8 lanes, the 24 boosted vectors (8 columns x 3 channels) are clamped, their luminance formed lane
// by lane (no deinterleaving: a lane is a pixel), and three 8 x 8 transposes write them, one
// transpose the luminance.
#include <cstddef>
#include <cstdint>
#include <limits>

#include "enhancer/paper/simplified_rows.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,fma")
// The luminance must be clahe_luminance.cc's products and sums, not contracted into FMAs (the
// boost's FMA is an explicit intrinsic). Clang contracts only within one expression.
#pragma GCC optimize("fp-contract=off")
#endif

#include "enhancer/blocks/guided_segments_transpose.h"

namespace turbid::simplified_internal {
namespace {

using guided_segments::Transpose8;

// Stores 8 floats at dst + at when all are before `limit`, the part before it otherwise.
template <bool kStream>
inline void StoreLimited(float* dst, int at, int limit, __m256 v) {
  if (at + 8 <= limit) {
    if (kStream) {
      _mm256_stream_ps(dst + at, v);
    } else {
      _mm256_storeu_ps(dst + at, v);
    }
  } else if (at < limit) {
    alignas(32) float tail[8];
    _mm256_store_ps(tail, v);
    for (int i = 0; at + i < limit; ++i) dst[at + i] = tail[i];
  }
}

template <bool kStream, bool kLum, bool kRgb>
bool BoostOutT(const BoostOutArgs& a) {
  constexpr int b = kRgb ? 2 : 0, r = kRgb ? 0 : 2;
  const int step = 3 * a.L, limit = 3 * a.cols;
  const __m256 va = _mm256_set1_ps(a.alpha);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 max_finite = _mm256_set1_ps(std::numeric_limits<float>::max());
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 wb = _mm256_set1_ps(0.0722f), wg = _mm256_set1_ps(0.7152f),
               wr = _mm256_set1_ps(0.2126f);
  const int K = a.lanes;
  __m256 finite = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  for (int h = 0; h < K; h += 8) {  // lanes h .. h + 7, each group along its row
    for (int j = 0; j < a.L; j += 8) {
      __m256 q[24];  // vector t = 3 i + c: column j + i, channel c
      const float* f = a.i_f + static_cast<ptrdiff_t>(j) * 3 * K + h;
      const float* g = a.i_g + static_cast<ptrdiff_t>(j) * 3 * K + h;
      for (int t = 0; t < 24; ++t) {
        const __m256 vg = _mm256_load_ps(g + t * K);
        const __m256 v = _mm256_fmadd_ps(va, _mm256_sub_ps(_mm256_load_ps(f + t * K), vg), vg);
        finite = _mm256_and_ps(finite,
                               _mm256_cmp_ps(_mm256_and_ps(v, abs_mask), max_finite, _CMP_LE_OQ));
        // NaN to 0, then max(min(x, 1), 0) as BoostClampRowAvx2.
        const __m256 x = _mm256_and_ps(v, _mm256_cmp_ps(v, v, _CMP_ORD_Q));
        q[t] = _mm256_max_ps(zero, _mm256_min_ps(one, x));
      }
      if (kLum) {
        __m256 l[8];
        for (int i = 0; i < 8; ++i) {
          l[i] = _mm256_add_ps(
              _mm256_add_ps(_mm256_mul_ps(wb, q[3 * i + b]), _mm256_mul_ps(wg, q[3 * i + 1])),
              _mm256_mul_ps(wr, q[3 * i + r]));
        }
        Transpose8(l);
        for (int k = 0; k < 8; ++k) _mm256_storeu_ps(a.lum + (h + k) * a.L + j, l[k]);
      }
      for (int blk = 0; blk < 3; ++blk) {
        Transpose8(q + blk * 8);
        for (int k = 0; k < 8; ++k) {
          StoreLimited<kStream>(a.dst, (h + k) * step + 3 * j + blk * 8, limit, q[blk * 8 + k]);
        }
      }
    }
  }
  return _mm256_movemask_ps(finite) == 0xff;
}

bool BoostOutAvx2(const BoostOutArgs& a) {
  // Non-temporal stores need 32-byte aligned rows (3 L floats per segment: a multiple of 24).
  const bool stream = a.stream && reinterpret_cast<uintptr_t>(a.dst) % 32 == 0;
  if (a.lum == nullptr) {
    return stream ? BoostOutT<true, false, false>(a) : BoostOutT<false, false, false>(a);
  }
  if (a.rgb) return stream ? BoostOutT<true, true, true>(a) : BoostOutT<false, true, true>(a);
  return stream ? BoostOutT<true, true, false>(a) : BoostOutT<false, true, false>(a);
}

}  // namespace

BoostOutFn BoostOutAvx2Fma() { return BoostOutAvx2; }

}  // namespace turbid::simplified_internal

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

#else  // no AVX2 copy in this build

namespace turbid::simplified_internal {
BoostOutFn BoostOutAvx2Fma() { return nullptr; }
}  // namespace turbid::simplified_internal

#endif
