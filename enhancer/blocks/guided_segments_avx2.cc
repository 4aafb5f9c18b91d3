// AVX2 + FMA copies of guided_segments.h's row kernels (the same source, guided_segments_kernels.h,
// over __m256) and its 8 x 8 transposes. Chosen at run time (Stream) on CPUs with AVX2 and FMA.
#include <cstddef>

#include "enhancer/blocks/guided_segments.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,fma")
#endif

#include "enhancer/blocks/guided_segments_transpose.h"

namespace turbid::guided_segments {
namespace {

struct Avx2Fma {
  static constexpr int kLanes = 8;
  using V = __m256;
  static V Load(const float* p) { return _mm256_load_ps(p); }
  static void Store(float* p, V x) { _mm256_store_ps(p, x); }
  static V Add(V a, V b) { return _mm256_add_ps(a, b); }
  static V Sub(V a, V b) { return _mm256_sub_ps(a, b); }
  static V Mul(V a, V b) { return _mm256_mul_ps(a, b); }
  // a / b from the reciprocal estimate and one Newton step (relative error ~2^-22; a division is
  // ~5 cycles a vector on these cores, the kernels' bottleneck).
  static V Div(V a, V b) {
    const V x = _mm256_rcp_ps(b);
    return _mm256_mul_ps(_mm256_mul_ps(a, x), _mm256_fnmadd_ps(b, x, _mm256_set1_ps(2.0f)));
  }
  static V Set1(float x) { return _mm256_set1_ps(x); }
  static V MulAdd(V a, V b, V c) { return _mm256_fmadd_ps(a, b, c); }
  static V NegMulAdd(V a, V b, V c) { return _mm256_fnmadd_ps(a, b, c); }
  struct M {
    __m256i idx;
    __m256 keep;
  };
  static M ShiftBy(int m) {
    const __m256i idx =
        _mm256_add_epi32(_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), _mm256_set1_epi32(m));
    const __m256i inside = _mm256_andnot_si256(_mm256_cmpgt_epi32(_mm256_setzero_si256(), idx),
                                               _mm256_cmpgt_epi32(_mm256_set1_epi32(8), idx));
    return {idx, _mm256_castsi256_ps(inside)};
  }
  static V Shifted(const M& m, V x) {
    return _mm256_and_ps(_mm256_permutevar8x32_ps(x, m.idx), m.keep);
  }
};

#include "enhancer/blocks/guided_segments_kernels.h"  // NOLINT(build/include): the kernels, here

void StageAAvx2(const Geometry& g, float* c_i, float* c_ii, const float* add, const float* sub,
                bool update, const float* inv_x, float inv_y, float eps, float* a, float* b) {
  StageAKernel<Avx2Fma>(g, c_i, c_ii, add, sub, update, inv_x, inv_y, eps, a, b);
}

void StageBAvx2(const Geometry& g, float* c_a, float* c_b, const float* add_a, const float* sub_a,
                const float* add_b, const float* sub_b, bool update, const float* inv_x,
                float inv_y, const float* guide, float* q) {
  StageBKernel<Avx2Fma>(g, c_a, c_b, add_a, sub_a, add_b, sub_b, update, inv_x, inv_y, guide, q);
}

void DirectAvx2(size_t n, const float* const* rows0, const float* const* rows1, int count,
                float* c0, float* c1) {
  DirectColumnsKernel<Avx2Fma>(n, rows0, rows1, count, c0, c1);
}

// Blocks of 8 floats of each segment's run -> 8 segment vectors.
void TransposeInAvx2(const Geometry& g, const float* const* src, float* seg) {
  __m256 r[8];
  for (int j = 0; j < g.L * 3; j += 8) {
    for (int k = 0; k < 8; ++k) r[k] = _mm256_loadu_ps(src[k] + j);
    Transpose8(r);
    for (int i = 0; i < 8; ++i) _mm256_store_ps(seg + static_cast<ptrdiff_t>(j + i) * 8, r[i]);
  }
}

// Values at or past `limit` are not written (the last segments' pixels past the image).
void TransposeOutAvx2(const Geometry& g, const float* seg, float* out, int limit) {
  const int step = g.L * 3;
  __m256 r[8];
  for (int j = 0; j < step; j += 8) {
    for (int i = 0; i < 8; ++i) r[i] = _mm256_load_ps(seg + static_cast<ptrdiff_t>(j + i) * 8);
    Transpose8(r);
    for (int k = 0; k < 8; ++k) {
      const int at = k * step + j;
      if (at + 8 <= limit) {
        _mm256_storeu_ps(out + at, r[k]);
      } else if (at < limit) {
        alignas(32) float tail[8];
        _mm256_store_ps(tail, r[k]);
        for (int i = 0; at + i < limit; ++i) out[at + i] = tail[i];
      }
    }
  }
}

}  // namespace

Kernels Avx2FmaKernels() {
  Kernels k;
  k.stage_a = StageAAvx2;
  k.stage_b = StageBAvx2;
  k.direct = DirectAvx2;
  k.transpose_in = TransposeInAvx2;
  k.transpose_out = TransposeOutAvx2;
  k.lanes = Avx2Fma::kLanes;
  return k;
}

}  // namespace turbid::guided_segments

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

#else  // no AVX2 copies in this build

namespace turbid::guided_segments {
Kernels Avx2FmaKernels() { return {}; }
}  // namespace turbid::guided_segments

#endif
