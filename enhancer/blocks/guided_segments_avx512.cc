// AVX-512 copies of guided_segments.h's row kernels with 16 lanes (16 segments a row: the same
// source, guided_segments_kernels.h, over __m512) and their 16 x 16 transposes. Chosen at run time
// (Stream) where KernelCpuLevel() is kAvx512.
#include <algorithm>
#include <cstddef>

#include "enhancer/blocks/guided_segments.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#if defined(__clang__)
#pragma clang attribute push( \
    __attribute__((target("avx512f,avx512dq,avx512vl,avx512bw,avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")
// GCC 12 warns of -Wmaybe-uninitialized inside avx512fintrin.h's own _mm512_undefined_* operands
// (GCC bug 105593, fixed in its headers in GCC 13).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include "enhancer/blocks/guided_segments_transpose16.h"

namespace turbid::guided_segments {
namespace {

struct Avx512 {
  static constexpr int kLanes = 16;
  using V = __m512;
  static V Load(const float* p) { return _mm512_load_ps(p); }
  static void Store(float* p, V x) { _mm512_store_ps(p, x); }
  static V Add(V a, V b) { return _mm512_add_ps(a, b); }
  static V Sub(V a, V b) { return _mm512_sub_ps(a, b); }
  static V Mul(V a, V b) { return _mm512_mul_ps(a, b); }
  // a / b from the 14-bit reciprocal estimate and one Newton step (relative error ~2^-23).
  static V Div(V a, V b) {
    const V x = _mm512_rcp14_ps(b);
    return _mm512_mul_ps(_mm512_mul_ps(a, x), _mm512_fnmadd_ps(b, x, _mm512_set1_ps(2.0f)));
  }
  static V Set1(float x) { return _mm512_set1_ps(x); }
  static V MulAdd(V a, V b, V c) { return _mm512_fmadd_ps(a, b, c); }
  static V NegMulAdd(V a, V b, V c) { return _mm512_fnmadd_ps(a, b, c); }
  struct M {
    __m512i idx;
    __mmask16 keep;
  };
  static M ShiftBy(int m) {
    const __m512i idx =
        _mm512_add_epi32(_mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
                         _mm512_set1_epi32(m));
    return {idx, _mm512_cmplt_epu32_mask(idx, _mm512_set1_epi32(16))};
  }
  static V Shifted(const M& m, V x) { return _mm512_maskz_permutexvar_ps(m.keep, m.idx, x); }
};

#include "enhancer/blocks/guided_segments_kernels.h"  // NOLINT(build/include): the kernels, here

void StageAAvx512(const Geometry& g, float* c_i, float* c_ii, const float* add, const float* sub,
                  bool update, const float* inv_x, float inv_y, float eps, float* a, float* b) {
  StageAKernel<Avx512>(g, c_i, c_ii, add, sub, update, inv_x, inv_y, eps, a, b);
}

void StageBAvx512(const Geometry& g, float* c_a, float* c_b, const float* add_a, const float* sub_a,
                  const float* add_b, const float* sub_b, bool update, const float* inv_x,
                  float inv_y, const float* guide, float* q) {
  StageBKernel<Avx512>(g, c_a, c_b, add_a, sub_a, add_b, sub_b, update, inv_x, inv_y, guide, q);
}

void DirectAvx512(size_t n, const float* const* rows0, const float* const* rows1, int count,
                  float* c0, float* c1) {
  DirectColumnsKernel<Avx512>(n, rows0, rows1, count, c0, c1);
}

// Blocks of 16 floats of each segment's run (the last block of a run: what is left of it) -> 16
// segment vectors.
void TransposeInAvx512(const Geometry& g, const float* const* src, float* seg) {
  const int step = g.L * 3;
  __m512 r[16];
  for (int j = 0; j < step; j += 16) {
    const __mmask16 valid = FirstLanes(step - j);
    for (int k = 0; k < 16; ++k) r[k] = _mm512_maskz_loadu_ps(valid, src[k] + j);
    Transpose16(r);
    for (int i = 0; i < 16 && j + i < step; ++i) {
      _mm512_store_ps(seg + static_cast<ptrdiff_t>(j + i) * 16, r[i]);
    }
  }
}

// Values at or past `limit` are not written (the last segments' pixels past the image).
void TransposeOutAvx512(const Geometry& g, const float* seg, float* out, int limit) {
  const int step = g.L * 3;
  __m512 r[16];
  for (int j = 0; j < step && j < limit; j += 16) {
    for (int i = 0; i < 16; ++i) {
      r[i] = j + i < step ? _mm512_load_ps(seg + static_cast<ptrdiff_t>(j + i) * 16)
                          : _mm512_setzero_ps();
    }
    Transpose16(r);
    for (int k = 0; k < 16; ++k) {
      const int at = k * step + j;
      if (at >= limit) break;
      _mm512_mask_storeu_ps(out + at, FirstLanes(std::min(step - j, limit - at)), r[k]);
    }
  }
}

}  // namespace

Kernels Avx512Kernels() {
  Kernels k;
  k.stage_a = StageAAvx512;
  k.stage_b = StageBAvx512;
  k.direct = DirectAvx512;
  k.transpose_in = TransposeInAvx512;
  k.transpose_out = TransposeOutAvx512;
  k.lanes = Avx512::kLanes;
  return k;
}

}  // namespace turbid::guided_segments

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif

#else  // no AVX-512 copies in this build

namespace turbid::guided_segments {
Kernels Avx512Kernels() { return {}; }
}  // namespace turbid::guided_segments

#endif
