// AVX-512 copy of simplified_rows.h's output step for the 16-lane layout (guided_segments' AVX-512
// path): per block of 16 segment columns, the 48 boosted vectors (16 columns x 3 channels) are
// clamped, their luminance formed lane by lane, and three 16 x 16 transposes write them, one
// transpose the luminance. With non-temporal stores the row is formed in an L1 staging row first
// and streamed out in order (one write stream). The 8-lane layout goes to the AVX2 kernel.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "enhancer/paper/simplified_rows.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#if defined(__clang__)
#pragma clang attribute push( \
    __attribute__((target("avx512f,avx512dq,avx512vl,avx512bw,avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")
// The luminance must be clahe_luminance.cc's products and sums, not contracted into FMAs (the
// boost's FMA is an explicit intrinsic). Clang contracts only within one expression.
#pragma GCC optimize("fp-contract=off")
// GCC 12 warns of -Wmaybe-uninitialized inside avx512fintrin.h's own _mm512_undefined_* operands
// (GCC bug 105593, fixed in its headers in GCC 13).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include "enhancer/blocks/guided_segments_transpose16.h"

namespace turbid::simplified_internal {
namespace {

using guided_segments::FirstLanes;
using guided_segments::Transpose16;

template <bool kLum, bool kRgb>
bool BoostOut16T(const BoostOutArgs& a) {
  constexpr int b = kRgb ? 2 : 0, r = kRgb ? 0 : 2;
  const int step = 3 * a.L, limit = 3 * a.cols;
  const __m512 va = _mm512_set1_ps(a.alpha);
  const __m512 max_finite = _mm512_set1_ps(std::numeric_limits<float>::max());
  const __m512 zero = _mm512_setzero_ps(), one = _mm512_set1_ps(1.0f);
  const __m512 wb = _mm512_set1_ps(0.0722f), wg = _mm512_set1_ps(0.7152f),
               wr = _mm512_set1_ps(0.2126f);
  __mmask16 finite = 0xffff;
  for (int j = 0; j < a.L; j += 16) {
    const int n = std::min(16, a.L - j);  // columns in this block (16, or 8 at a row's end)
    __m512 q[48];                         // vector t = 3 i + c: column j + i, channel c
    const float* f = a.i_f + static_cast<ptrdiff_t>(j) * 48;
    const float* g = a.i_g + static_cast<ptrdiff_t>(j) * 48;
    for (int t = 0; t < 48; ++t) {
      if (t >= 3 * n) {
        q[t] = zero;
        continue;
      }
      const __m512 vg = _mm512_load_ps(g + t * 16);
      const __m512 v = _mm512_fmadd_ps(va, _mm512_sub_ps(_mm512_load_ps(f + t * 16), vg), vg);
      finite &= _mm512_cmp_ps_mask(_mm512_abs_ps(v), max_finite, _CMP_LE_OQ);
      // NaN to 0, then max(min(x, 1), 0) as BoostClampRowAvx2.
      const __m512 x = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(v, v, _CMP_ORD_Q), v);
      q[t] = _mm512_max_ps(zero, _mm512_min_ps(one, x));
    }
    if (kLum) {
      __m512 l[16];
      for (int i = 0; i < 16; ++i) {
        l[i] = _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(wb, q[3 * i + b]), _mm512_mul_ps(wg, q[3 * i + 1])),
            _mm512_mul_ps(wr, q[3 * i + r]));
      }
      Transpose16(l);
      const __mmask16 cols = FirstLanes(n);
      for (int k = 0; k < 16; ++k) _mm512_mask_storeu_ps(a.lum + k * a.L + j, cols, l[k]);
    }
    for (int m = 0; m < 3; ++m) {
      const int part = 3 * j + 16 * m;  // the block's floats [part, part + 16) of each segment
      if (part >= 3 * (j + n)) break;
      Transpose16(q + 16 * m);
      for (int k = 0; k < 16; ++k) {
        const int at = k * step + part;
        if (at >= limit) break;
        _mm512_mask_storeu_ps(a.dst + at, FirstLanes(std::min(3 * (j + n) - part, limit - at)),
                              q[16 * m + k]);
      }
    }
  }
  return finite == 0xffff;
}

bool BoostOut16Plain(const BoostOutArgs& a) {
  if (a.lum == nullptr) return BoostOut16T<false, false>(a);
  return a.rgb ? BoostOut16T<true, true>(a) : BoostOut16T<true, false>(a);
}

// n floats src -> dst with non-temporal stores where dst is 64-byte aligned (the head before the
// first aligned float and the tail: masked plain stores).
void StreamCopy(const float* src, float* dst, int n) {
  const int head = std::min(
      n, static_cast<int>(((64 - reinterpret_cast<uintptr_t>(dst) % 64) % 64) / sizeof(float)));
  if (head > 0) _mm512_mask_storeu_ps(dst, FirstLanes(head), _mm512_loadu_ps(src));
  int i = head;
  for (; i + 16 <= n; i += 16) _mm512_stream_ps(dst + i, _mm512_loadu_ps(src + i));
  if (i < n)
    _mm512_mask_storeu_ps(dst + i, FirstLanes(n - i),
                          _mm512_maskz_loadu_ps(FirstLanes(n - i), src + i));
}

bool BoostOut16(const BoostOutArgs& a) {
  if (a.lanes != 16) return BoostOutAvx2Fma()(a);  // the 8-lane layout: the AVX2 kernel
  if (!a.stream) return BoostOut16Plain(a);
  // Non-temporal: the 16 x 16 transposes write 16 segments' runs at once, more than the
  // write-combining buffers; so the row goes to a staging row (stays in L1), then out in order.
  thread_local std::vector<float> stage;
  const size_t n = static_cast<size_t>(a.cols) * 3;
  if (stage.size() < n + 16) stage.resize(n + 16);
  BoostOutArgs b = a;
  b.dst = stage.data();
  const bool finite = BoostOut16Plain(b);
  StreamCopy(stage.data(), a.dst, static_cast<int>(n));
  return finite;
}

}  // namespace

BoostOutFn BoostOutAvx512() { return BoostOutAvx2Fma() != nullptr ? BoostOut16 : nullptr; }

}  // namespace turbid::simplified_internal

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif

#else  // no AVX-512 copy in this build

namespace turbid::simplified_internal {
BoostOutFn BoostOutAvx512() { return nullptr; }
}  // namespace turbid::simplified_internal

#endif
