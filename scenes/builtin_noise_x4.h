// AVX2 versions of the built-in textures' value noise (scenes/builtin_model.h Noise2, Fbm2, Noise3,
// Fbm3), four points at a time, with the same values: the scalar operations in the same order on
// AVX2 lanes (no FMA, so every product and sum rounds as in the scalar code; floor is exact, the
// lattice hash is the same 32-bit integer arithmetic). The cell coordinates go through int32, exact
// while |floor| < 2^31: callers redo the lanes flagged `outside` with the scalar code. Shared by
// the hull's and the seafloor's textures (sand and rocks); defines TURBID_BUILTIN_AVX2 where
// available.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#include <cstdint>
#include <limits>

#include "scenes/builtin_model.h"

namespace turbid::builtin_model {

#define TURBID_BUILTIN_AVX2 1
// AVX2 without FMA: no product and sum may be fused into one rounding.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

inline __m128i MixX4(__m128i h) {
  h = _mm_xor_si128(h, _mm_srli_epi32(h, 16));
  h = _mm_mullo_epi32(h, _mm_set1_epi32(static_cast<int>(0x7feb352du)));
  h = _mm_xor_si128(h, _mm_srli_epi32(h, 15));
  h = _mm_mullo_epi32(h, _mm_set1_epi32(static_cast<int>(0x846ca68bu)));
  h = _mm_xor_si128(h, _mm_srli_epi32(h, 16));
  return h;
}

// Lattice(x, y, 0, seed) for four cells; `seed_term` = seed * 0x9e3779b9 (z = 0 adds nothing).
inline __m256d Lattice2X4(__m128i x, __m128i y, __m128i seed_term) {
  const __m128i sum = _mm_add_epi32(
      _mm_add_epi32(_mm_mullo_epi32(x, _mm_set1_epi32(static_cast<int>(0x8da6b343u))),
                    _mm_mullo_epi32(y, _mm_set1_epi32(static_cast<int>(0xd8163841u)))),
      seed_term);
  // uint32 -> double, exactly: flip the sign bit, convert as int32, add 2^31 back.
  const __m128i h = _mm_xor_si128(MixX4(sum), _mm_set1_epi32(INT32_MIN));
  const __m256d d = _mm256_add_pd(_mm256_cvtepi32_pd(h), _mm256_set1_pd(2147483648.0));
  return _mm256_mul_pd(d, _mm256_set1_pd(1.0 / 4294967296.0));
}

inline __m256d FadeX4(__m256d t) {
  const __m256d t3 = _mm256_mul_pd(_mm256_mul_pd(t, t), t);
  const __m256d inner = _mm256_sub_pd(_mm256_mul_pd(t, _mm256_set1_pd(6.0)), _mm256_set1_pd(15.0));
  return _mm256_mul_pd(t3, _mm256_add_pd(_mm256_mul_pd(t, inner), _mm256_set1_pd(10.0)));
}

inline __m256d LerpX4(__m256d a, __m256d b, __m256d t) {
  return _mm256_add_pd(a, _mm256_mul_pd(_mm256_sub_pd(b, a), t));
}

// Lanes whose cell coordinate is outside [-2^31, 2^31) (or NaN) are flagged in *outside.
inline __m128i CellX4(__m256d f, __m256d* outside) {
  const __m256d inside = _mm256_and_pd(_mm256_cmp_pd(f, _mm256_set1_pd(-2147483648.0), _CMP_GE_OQ),
                                       _mm256_cmp_pd(f, _mm256_set1_pd(2147483648.0), _CMP_LT_OQ));
  *outside =
      _mm256_or_pd(*outside, _mm256_xor_pd(inside, _mm256_castsi256_pd(_mm256_set1_epi32(-1))));
  return _mm256_cvttpd_epi32(f);
}

inline __m256d Noise2X4(__m256d x, __m256d y, uint32_t seed, __m256d* outside) {
  const __m256d fx = _mm256_floor_pd(x), fy = _mm256_floor_pd(y);
  const __m128i ix = CellX4(fx, outside), iy = CellX4(fy, outside);
  const __m128i one = _mm_set1_epi32(1);
  const __m128i ix1 = _mm_add_epi32(ix, one), iy1 = _mm_add_epi32(iy, one);
  const __m128i seed_term = _mm_set1_epi32(static_cast<int>(seed * 0x9e3779b9u));
  const __m256d tx = FadeX4(_mm256_sub_pd(x, fx)), ty = FadeX4(_mm256_sub_pd(y, fy));
  const __m256d a = LerpX4(Lattice2X4(ix, iy, seed_term), Lattice2X4(ix1, iy, seed_term), tx);
  const __m256d b = LerpX4(Lattice2X4(ix, iy1, seed_term), Lattice2X4(ix1, iy1, seed_term), tx);
  return LerpX4(a, b, ty);
}

inline __m256d Fbm2X4(__m256d x, __m256d y, int octaves, uint32_t seed, __m256d* outside) {
  __m256d sum = _mm256_setzero_pd();
  double amplitude = 1.0, norm = 0.0;
  for (int i = 0; i < octaves; ++i) {
    sum = _mm256_add_pd(
        sum, _mm256_mul_pd(_mm256_set1_pd(amplitude), Noise2X4(x, y, seed + 101u * i, outside)));
    norm += amplitude;
    x = _mm256_add_pd(_mm256_mul_pd(x, _mm256_set1_pd(2.03)), _mm256_set1_pd(17.1));
    y = _mm256_sub_pd(_mm256_mul_pd(y, _mm256_set1_pd(2.03)), _mm256_set1_pd(5.3));
    amplitude *= 0.5;
  }
  return _mm256_div_pd(sum, _mm256_set1_pd(norm));
}

inline __m256d MulX4(__m256d a, double b) { return _mm256_mul_pd(a, _mm256_set1_pd(b)); }

// Lattice(x, y, z, seed) for four cells; `seed_term` = seed * 0x9e3779b9.
inline __m256d Lattice3X4(__m128i x, __m128i y, __m128i z, __m128i seed_term) {
  const __m128i z_term = _mm_mullo_epi32(z, _mm_set1_epi32(static_cast<int>(0xcb1ab31fu)));
  return Lattice2X4(x, y, _mm_add_epi32(z_term, seed_term));  // 32-bit sums: any order
}

// Noise3 (scenes/builtin_model.h) for four points.
inline __m256d Noise3X4(__m256d x, __m256d y, __m256d z, uint32_t seed, __m256d* outside) {
  const __m256d fx = _mm256_floor_pd(x), fy = _mm256_floor_pd(y), fz = _mm256_floor_pd(z);
  const __m128i ix = CellX4(fx, outside), iy = CellX4(fy, outside), iz = CellX4(fz, outside);
  const __m128i one = _mm_set1_epi32(1);
  const __m128i ix1 = _mm_add_epi32(ix, one), iy1 = _mm_add_epi32(iy, one);
  const __m128i seed_term = _mm_set1_epi32(static_cast<int>(seed * 0x9e3779b9u));
  const __m256d tx = FadeX4(_mm256_sub_pd(x, fx)), ty = FadeX4(_mm256_sub_pd(y, fy));
  const __m256d tz = FadeX4(_mm256_sub_pd(z, fz));
  __m256d layer[2];
  for (int k = 0; k < 2; ++k) {
    const __m128i izk = _mm_add_epi32(iz, _mm_set1_epi32(k));
    const __m256d a =
        LerpX4(Lattice3X4(ix, iy, izk, seed_term), Lattice3X4(ix1, iy, izk, seed_term), tx);
    const __m256d b =
        LerpX4(Lattice3X4(ix, iy1, izk, seed_term), Lattice3X4(ix1, iy1, izk, seed_term), tx);
    layer[k] = LerpX4(a, b, ty);
  }
  return LerpX4(layer[0], layer[1], tz);
}

// Fbm3 (scenes/builtin_model.h) for four points.
inline __m256d Fbm3X4(__m256d x, __m256d y, __m256d z, int octaves, uint32_t seed,
                      __m256d* outside) {
  __m256d sum = _mm256_setzero_pd();
  double amplitude = 1.0, norm = 0.0;
  for (int i = 0; i < octaves; ++i) {
    sum = _mm256_add_pd(
        sum, _mm256_mul_pd(_mm256_set1_pd(amplitude), Noise3X4(x, y, z, seed + 131u * i, outside)));
    norm += amplitude;
    x = _mm256_add_pd(MulX4(x, 2.03), _mm256_set1_pd(7.7));
    y = _mm256_add_pd(MulX4(y, 2.03), _mm256_set1_pd(-3.1));
    z = _mm256_add_pd(MulX4(z, 2.03), _mm256_set1_pd(11.3));
    amplitude *= 0.5;
  }
  return _mm256_div_pd(sum, _mm256_set1_pd(norm));
}

// Cellular2 (scenes/builtin_model.h) for four points: the 3 x 3 candidates' lattice hashes and
// squared distances on AVX2 (the scalar operations, in order), the nearest (hypot, only for the
// few candidates near the least) with the scalar CellularNearest. false (out untouched) when a
// lane's cell is outside +-2^30 or NaN: the caller uses Cellular2 there.
inline bool Cellular2X4(__m256d x, __m256d y, uint32_t seed, Cell* out) {
  const __m256d fx = _mm256_floor_pd(x), fy = _mm256_floor_pd(y);
  const __m256d limit = _mm256_set1_pd(1073741824.0);
  const __m256d neg_limit = _mm256_set1_pd(-1073741824.0);
  const __m256d inside = _mm256_and_pd(
      _mm256_and_pd(_mm256_cmp_pd(fx, neg_limit, _CMP_GE_OQ), _mm256_cmp_pd(fx, limit, _CMP_LE_OQ)),
      _mm256_and_pd(_mm256_cmp_pd(fy, neg_limit, _CMP_GE_OQ),
                    _mm256_cmp_pd(fy, limit, _CMP_LE_OQ)));
  if (_mm256_movemask_pd(inside) != 0xf) return false;
  const __m128i ix = _mm256_cvttpd_epi32(fx), iy = _mm256_cvttpd_epi32(fy);
  const __m128i seed_term = _mm_set1_epi32(static_cast<int>(seed * 0x9e3779b9u));
  const __m128i z1 = _mm_set1_epi32(1), z2 = _mm_set1_epi32(2);
  alignas(32) double dx[36], dy[36], d2[36], least[4];  // candidate c, lane l at [4c + l]
  __m256d low = _mm256_set1_pd(std::numeric_limits<double>::infinity());
  for (int c = 0; c < 9; ++c) {
    const __m128i i = _mm_add_epi32(ix, _mm_set1_epi32(c % 3 - 1));
    const __m128i j = _mm_add_epi32(iy, _mm_set1_epi32(c / 3 - 1));
    const __m256d px = _mm256_add_pd(_mm256_cvtepi32_pd(i), Lattice3X4(i, j, z1, seed_term));
    const __m256d py = _mm256_add_pd(_mm256_cvtepi32_pd(j), Lattice3X4(i, j, z2, seed_term));
    const __m256d ddx = _mm256_sub_pd(px, x), ddy = _mm256_sub_pd(py, y);
    const __m256d dd = _mm256_add_pd(_mm256_mul_pd(ddx, ddx), _mm256_mul_pd(ddy, ddy));
    _mm256_store_pd(dx + 4 * c, ddx);
    _mm256_store_pd(dy + 4 * c, ddy);
    _mm256_store_pd(d2 + 4 * c, dd);
    low = _mm256_min_pd(dd, low);  // std::min(low, dd): dd < low ? dd : low
  }
  _mm256_store_pd(least, low);
  alignas(16) int32_t cx[4], cy[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(cx), ix);
  _mm_store_si128(reinterpret_cast<__m128i*>(cy), iy);
  for (int l = 0; l < 4; ++l)
    out[l] = CellularNearest(cx[l], cy[l], dx + l, dy + l, d2 + l, 4, least[l], seed);
  return true;
}

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

}  // namespace turbid::builtin_model

#endif  // x86-64 GCC / clang
