// Vector types for row kernels written once over their width (issue 29 item 6): Vec8 (AVX2 with
// FMA, 8 floats) and Vec16 (AVX-512F, 16 floats) give the same operations under the same names,
// each the same per-lane arithmetic, so a kernel gives the same bits at either width.
//
// A kernel template cannot carry a target attribute that depends on its vector type, and GCC and
// Clang refuse to inline the types' target-specific operations into a function compiled without
// that target. So a kernel's body is written once in a `.inc` file that its .cc includes twice,
// in two namespaces, with `V` (the vector type) and TURBID_VEC_TARGET (its target attribute)
// defined before each inclusion (TURBID_VEC8_TARGET / TURBID_VEC16_TARGET below):
// enhancer/simd_widths.inc does both inclusions. Callers pick the 16-lane copy when
// KernelCpuLevel() >= CpuLevel::kAvx512.
#pragma once

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define TURBID_HAVE_SIMD_VEC 1
#include <immintrin.h>

#define TURBID_VEC8_TARGET __attribute__((target("avx2,fma")))
#define TURBID_VEC16_TARGET __attribute__((target("avx512f,avx2,fma")))
#define TURBID_VEC8_OP __attribute__((always_inline, target("avx2,fma"))) static inline
#define TURBID_VEC16_OP __attribute__((always_inline, target("avx512f,avx2,fma"))) static inline

// GCC 12 warns of -Wmaybe-uninitialized inside avx512fintrin.h's own _mm512_undefined_* operands
// (GCC bug 105593, fixed in its headers in GCC 13): the 16-lane copies are wrapped in these.
#if defined(__clang__)
#define TURBID_VEC16_WARNINGS_OFF
#define TURBID_VEC16_WARNINGS_ON
#else
#define TURBID_VEC16_WARNINGS_OFF \
  _Pragma("GCC diagnostic push") _Pragma("GCC diagnostic ignored \"-Wmaybe-uninitialized\"")
#define TURBID_VEC16_WARNINGS_ON _Pragma("GCC diagnostic pop")
#endif

namespace turbid::simd {

struct Vec8 {
  using F = __m256;
  using I = __m256i;
  using Mask = __m256;  // all-ones lanes where true
  static constexpr int kLanes = 8;
  TURBID_VEC8_OP F Load(const float* p) { return _mm256_loadu_ps(p); }
  TURBID_VEC8_OP void Store(float* p, F v) { _mm256_storeu_ps(p, v); }
  TURBID_VEC8_OP F Set(float v) { return _mm256_set1_ps(v); }
  TURBID_VEC8_OP F Zero() { return _mm256_setzero_ps(); }
  TURBID_VEC8_OP F Add(F a, F b) { return _mm256_add_ps(a, b); }
  TURBID_VEC8_OP F Sub(F a, F b) { return _mm256_sub_ps(a, b); }
  TURBID_VEC8_OP F Mul(F a, F b) { return _mm256_mul_ps(a, b); }
  TURBID_VEC8_OP F Div(F a, F b) { return _mm256_div_ps(a, b); }
  // a b + c and a b - c, fused.
  TURBID_VEC8_OP F MulAdd(F a, F b, F c) { return _mm256_fmadd_ps(a, b, c); }
  TURBID_VEC8_OP F MulSub(F a, F b, F c) { return _mm256_fmsub_ps(a, b, c); }
  // vminps / vmaxps: the second operand unless the first compares less / greater (NaN in a:
  // b).
  TURBID_VEC8_OP F Min(F a, F b) { return _mm256_min_ps(a, b); }
  TURBID_VEC8_OP F Max(F a, F b) { return _mm256_max_ps(a, b); }
  TURBID_VEC8_OP Mask LessEqual(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
  // mask ? b : a.
  TURBID_VEC8_OP F Select(Mask m, F a, F b) { return _mm256_blendv_ps(a, b, m); }
  TURBID_VEC8_OP I Bits(F v) { return _mm256_castps_si256(v); }
  TURBID_VEC8_OP F FromBits(I v) { return _mm256_castsi256_ps(v); }
  TURBID_VEC8_OP I SetI(int v) { return _mm256_set1_epi32(v); }
  TURBID_VEC8_OP I AddI(I a, I b) { return _mm256_add_epi32(a, b); }
  TURBID_VEC8_OP I SubI(I a, I b) { return _mm256_sub_epi32(a, b); }
  TURBID_VEC8_OP I AndI(I a, I b) { return _mm256_and_si256(a, b); }
  TURBID_VEC8_OP I OrI(I a, I b) { return _mm256_or_si256(a, b); }
  template <int kShift>
  TURBID_VEC8_OP I ShiftRightI(I a) {
    return _mm256_srli_epi32(a, kShift);
  }
  TURBID_VEC8_OP I LoadI(const int* p) {
    return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
  }
  // v[index] per lane, index in 0 ... 7.
  TURBID_VEC8_OP F Permute(F v, I index) { return _mm256_permutevar8x32_ps(v, index); }
  // Per lane float(double(v) s), s the lanes' doubles (lo: lanes 0 ... 3, hi: 4 ... 7).
  using D = __m256d;
  TURBID_VEC8_OP D LoadD(const double* p) { return _mm256_loadu_pd(p); }
  TURBID_VEC8_OP F MulInDouble(F v, D lo, D hi) {
    const __m128 a = _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(v)), lo));
    const __m128 b =
        _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(v, 1)), hi));
    return _mm256_insertf128_ps(_mm256_castps128_ps256(a), b, 1);
  }
  // Whether any lane of m is true.
  TURBID_VEC8_OP bool Any(Mask m) { return _mm256_movemask_ps(m) != 0; }
  // The three channels of 8 interleaved pixels (24 floats at p): two blends gather one channel's
  // values (in the order 0 3 6 1 4 7 2 5 for channel 0, likewise rotated for 1 and 2) and one
  // lane permutation puts them in order.
  TURBID_VEC8_OP void Deinterleave3(const float* p, F* c) {
    const F v0 = _mm256_loadu_ps(p), v1 = _mm256_loadu_ps(p + 8), v2 = _mm256_loadu_ps(p + 16);
    // Lanes from v1 (0x92: 1, 4, 7) and v2 (0x24: 2, 5) for channel 0; rotated for the others.
    const F t0 = _mm256_blend_ps(_mm256_blend_ps(v0, v1, 0x92), v2, 0x24);
    const F t1 = _mm256_blend_ps(_mm256_blend_ps(v0, v1, 0x24), v2, 0x49);
    const F t2 = _mm256_blend_ps(_mm256_blend_ps(v0, v1, 0x49), v2, 0x92);
    c[0] = _mm256_permutevar8x32_ps(t0, _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
    c[1] = _mm256_permutevar8x32_ps(t1, _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6));
    c[2] = _mm256_permutevar8x32_ps(t2, _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
  }
  // a0 b0 a1 b1 ... a7 b7 at p (16 floats).
  TURBID_VEC8_OP void StoreInterleaved(float* p, F a, F b) {
    const F lo = _mm256_unpacklo_ps(a, b);  // a0 b0 a1 b1 | a4 b4 a5 b5
    const F hi = _mm256_unpackhi_ps(a, b);  // a2 b2 a3 b3 | a6 b6 a7 b7
    _mm256_storeu_ps(p, _mm256_permute2f128_ps(lo, hi, 0x20));
    _mm256_storeu_ps(p + 8, _mm256_permute2f128_ps(lo, hi, 0x31));
  }
  // table[index] per lane, index in 0 ... 15 (two permutes and a blend on bit 3).
  TURBID_VEC8_OP F Lookup16(const float* table, I index) {
    const F lo = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table), index);
    const F hi = _mm256_permutevar8x32_ps(_mm256_loadu_ps(table + 8), index);
    return _mm256_blendv_ps(lo, hi, _mm256_castsi256_ps(_mm256_slli_epi32(index, 28)));
  }
};

struct Vec16 {
  using F = __m512;
  using I = __m512i;
  using Mask = __mmask16;
  static constexpr int kLanes = 16;
  TURBID_VEC16_OP F Load(const float* p) { return _mm512_loadu_ps(p); }
  TURBID_VEC16_OP void Store(float* p, F v) { _mm512_storeu_ps(p, v); }
  TURBID_VEC16_OP F Set(float v) { return _mm512_set1_ps(v); }
  TURBID_VEC16_OP F Zero() { return _mm512_setzero_ps(); }
  TURBID_VEC16_OP F Add(F a, F b) { return _mm512_add_ps(a, b); }
  TURBID_VEC16_OP F Sub(F a, F b) { return _mm512_sub_ps(a, b); }
  TURBID_VEC16_OP F Mul(F a, F b) { return _mm512_mul_ps(a, b); }
  TURBID_VEC16_OP F Div(F a, F b) { return _mm512_div_ps(a, b); }
  TURBID_VEC16_OP F MulAdd(F a, F b, F c) { return _mm512_fmadd_ps(a, b, c); }
  TURBID_VEC16_OP F MulSub(F a, F b, F c) { return _mm512_fmsub_ps(a, b, c); }
  // vminps / vmaxps as Vec8's (the same NaN rule).
  TURBID_VEC16_OP F Min(F a, F b) { return _mm512_min_ps(a, b); }
  TURBID_VEC16_OP F Max(F a, F b) { return _mm512_max_ps(a, b); }
  TURBID_VEC16_OP Mask LessEqual(F a, F b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
  TURBID_VEC16_OP F Select(Mask m, F a, F b) { return _mm512_mask_blend_ps(m, a, b); }
  TURBID_VEC16_OP I Bits(F v) { return _mm512_castps_si512(v); }
  TURBID_VEC16_OP F FromBits(I v) { return _mm512_castsi512_ps(v); }
  TURBID_VEC16_OP I SetI(int v) { return _mm512_set1_epi32(v); }
  TURBID_VEC16_OP I AddI(I a, I b) { return _mm512_add_epi32(a, b); }
  TURBID_VEC16_OP I SubI(I a, I b) { return _mm512_sub_epi32(a, b); }
  TURBID_VEC16_OP I AndI(I a, I b) { return _mm512_and_si512(a, b); }
  TURBID_VEC16_OP I OrI(I a, I b) { return _mm512_or_si512(a, b); }
  template <int kShift>
  TURBID_VEC16_OP I ShiftRightI(I a) {
    return _mm512_srli_epi32(a, kShift);
  }
  TURBID_VEC16_OP I LoadI(const int* p) { return _mm512_loadu_si512(p); }
  // v[index] per lane, index in 0 ... 15.
  TURBID_VEC16_OP F Permute(F v, I index) { return _mm512_permutexvar_ps(index, v); }
  // Per lane float(double(v) s), s the lanes' doubles (lo: lanes 0 ... 7, hi: 8 ... 15).
  using D = __m512d;
  TURBID_VEC16_OP D LoadD(const double* p) { return _mm512_loadu_pd(p); }
  TURBID_VEC16_OP F MulInDouble(F v, D lo, D hi) {
    const __m256 a = _mm512_cvtpd_ps(_mm512_mul_pd(_mm512_cvtps_pd(_mm512_castps512_ps256(v)), lo));
    const __m256 b = _mm512_cvtpd_ps(_mm512_mul_pd(
        _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1))), hi));
    return _mm512_castpd_ps(
        _mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(a)), _mm256_castps_pd(b), 1));
  }
  TURBID_VEC16_OP bool Any(Mask m) { return m != 0; }
  // The three channels of 16 interleaved pixels (48 floats at p): channel c's lane l is float
  // 3 l + c; two-source permutes take those below 32 from v0 v1, then the rest from v2.
  TURBID_VEC16_OP void Deinterleave3(const float* p, F* c) {
    const F v0 = _mm512_loadu_ps(p), v1 = _mm512_loadu_ps(p + 16), v2 = _mm512_loadu_ps(p + 32);
    const I a0 = _mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 0, 0, 0, 0, 0);
    const I b0 = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 17, 20, 23, 26, 29);
    const I a1 = _mm512_setr_epi32(1, 4, 7, 10, 13, 16, 19, 22, 25, 28, 31, 0, 0, 0, 0, 0);
    const I b1 = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 18, 21, 24, 27, 30);
    const I a2 = _mm512_setr_epi32(2, 5, 8, 11, 14, 17, 20, 23, 26, 29, 0, 0, 0, 0, 0, 0);
    const I b2 = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 16, 19, 22, 25, 28, 31);
    c[0] = _mm512_permutex2var_ps(_mm512_permutex2var_ps(v0, a0, v1), b0, v2);
    c[1] = _mm512_permutex2var_ps(_mm512_permutex2var_ps(v0, a1, v1), b1, v2);
    c[2] = _mm512_permutex2var_ps(_mm512_permutex2var_ps(v0, a2, v1), b2, v2);
  }
  // a0 b0 a1 b1 ... a15 b15 at p (32 floats).
  TURBID_VEC16_OP void StoreInterleaved(float* p, F a, F b) {
    const I first = _mm512_setr_epi32(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23);
    const I second = _mm512_add_epi32(first, _mm512_set1_epi32(8));
    _mm512_storeu_ps(p, _mm512_permutex2var_ps(a, first, b));
    _mm512_storeu_ps(p + 16, _mm512_permutex2var_ps(a, second, b));
  }
  // table[index] per lane, index in 0 ... 15 (one permute).
  TURBID_VEC16_OP F Lookup16(const float* table, I index) {
    return _mm512_permutexvar_ps(index, _mm512_loadu_ps(table));
  }
};

}  // namespace turbid::simd

#endif
