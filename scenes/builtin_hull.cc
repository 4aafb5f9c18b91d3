// The built-in hull scene: a painted steel plate with weld seams, rivets, rust streaks and fouling
// (docs/formats.md); its texture's fractal sums have an AVX2 version (same values).
#include <opencv2/core.hpp>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include <atomic>
#include <vector>

#include "core/cpu.h"
#include "scenes/builtin_internal.h"
#include "scenes/builtin_model.h"

namespace turbid {
namespace builtin_model {
namespace {

std::atomic<bool> g_vector_textures{true};  // SetBuiltinVectorTextures

// ---------------------------------------------------------------------------------------------
// Hull: a painted steel plate seen obliquely, with weld seams, rivet rows, rust streaks and
// fouling (barnacle clusters). Plate coordinates (u, v) in metres.

// The texture's four fractal sums, which every point needs (HullNoiseX4 computes the same values
// four points at a time); HullTextureFrom does the rest.
struct HullNoise {
  double paint, speckle, streaks, fouling_patch;
};

HullNoise HullNoiseAt(double u, double v) {
  return {Fbm2(u * 3.0, v * 3.0, 5, 11u), Fbm2(u * 45.0, v * 45.0, 3, 12u),
          Fbm2(u * 25.0, v * 1.2, 3, 13u), Fbm2(u * 1.3 + 3.0, v * 1.3 - 2.0, 4, 16u)};
}

cv::Vec3d HullTextureFrom(double u, double v, const HullNoise& noise) {
  double value = 0.42 + 0.16 * (noise.paint - 0.5) + 0.10 * (noise.speckle - 0.5);
  // Vertical rust streaks: stretched noise, darker.
  value -= 0.10 * SmoothStep(0.55, 0.8, noise.streaks);
  // Horizontal seams every 0.9 m; vertical butt welds every 1.4 m, staggered by strake.
  const double strake = std::floor(v / 0.9);
  const double dv = std::abs(v - std::round(v / 0.9) * 0.9);
  const double stagger = std::fmod(std::abs(strake), 2.0) * 0.7;
  const double du = std::abs((u - stagger) - std::round((u - stagger) / 1.4) * 1.4);
  const double seam = std::min(dv, du);
  const double along = dv < du ? u : v;
  if (seam < 0.014) {
    // Weld bead: bright with ripples along the seam.
    value = 0.60 + 0.10 * std::sin(2.0 * kPi * along / 0.007) +
            0.08 * (Noise2(u * 300.0, v * 300.0, 14u) - 0.5);
  } else if (seam < 0.022) {
    value = 0.22 + 0.05 * Noise2(u * 200.0, v * 200.0, 15u);  // heat-tinted edge
  }
  // Rivet rows 6 cm either side of each horizontal seam, pitch 9 cm, and along butt welds.
  auto rivet = [&](double across, double along_pos, uint32_t seed) {
    const double k = std::round(along_pos / 0.09);
    const double d = along_pos - k * 0.09;
    // hypot only near a rivet: where across^2 + d^2 (within a few ulps of hypot^2) is above
    // (1.01 * 0.011)^2, hypot is certainly above 0.011.
    if (!(across * across + d * d < 1.2343e-4)) return;
    const double r = std::hypot(across, d);
    if (r < 0.011 &&
        Lattice(static_cast<int64_t>(k), static_cast<int64_t>(strake), 5, seed) > 0.12) {
      const double x = r / 0.011;
      value = x > 0.8 ? 0.15 : 0.78 - 0.35 * x * x;  // domed head with a dark rim
    }
  };
  const double v_seam = std::round(v / 0.9) * 0.9;
  rivet(std::abs(v - v_seam) - 0.06, u, 21u);
  const double u_seam = std::round((u - stagger) / 1.4) * 1.4 + stagger;
  rivet(std::abs(u - u_seam) - 0.06, v, 22u);
  // Fouling patches: irregular blobs filled with barnacles (cellular rings).
  const double coverage = SmoothStep(0.56, 0.62, noise.fouling_patch);
  if (coverage > 0.0) {
    const Cell cell = Cellular2(u / 0.025, v / 0.025, 17u);
    double fouling = 0.20 + 0.12 * Fbm2(u * 80.0, v * 80.0, 2, 18u);
    const double radius = 0.25 + 0.2 * cell.id;
    if (cell.distance < radius) {
      const double x = cell.distance / radius;
      fouling = x > 0.55 ? 0.70 - 0.25 * x : 0.12;  // white shell ring, dark opening
    }
    value = Lerp(value, fouling, coverage);
  }
  return Gray(value);
}

cv::Vec3d HullTexture(const SurfacePoint& p) {
  const double u = p.local[0], v = p.local[1];
  return HullTextureFrom(u, v, HullNoiseAt(u, v));
}

// Four points at a time: HullNoiseAt's operations, in the same order, on AVX2 lanes (no FMA, so
// every product and sum rounds as in the scalar code; floor is exact, the lattice hash is the same
// 32-bit integer arithmetic). The cell coordinates go through int32, exact while |floor| < 2^31:
// lanes outside (never on the built-in plates) are redone by the scalar code.
#if defined(__x86_64__) && defined(__GNUC__)
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

// HullNoiseAt(u[k], v[k]) for k < n.
void HullNoiseAvx2(const double* u, const double* v, int n, HullNoise* out) {
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const __m256d uu = _mm256_loadu_pd(u + k), vv = _mm256_loadu_pd(v + k);
    __m256d outside = _mm256_setzero_pd();
    alignas(32) double lanes[4][4];
    _mm256_store_pd(lanes[0], Fbm2X4(MulX4(uu, 3.0), MulX4(vv, 3.0), 5, 11u, &outside));
    _mm256_store_pd(lanes[1], Fbm2X4(MulX4(uu, 45.0), MulX4(vv, 45.0), 3, 12u, &outside));
    _mm256_store_pd(lanes[2], Fbm2X4(MulX4(uu, 25.0), MulX4(vv, 1.2), 3, 13u, &outside));
    _mm256_store_pd(lanes[3],
                    Fbm2X4(_mm256_add_pd(MulX4(uu, 1.3), _mm256_set1_pd(3.0)),
                           _mm256_sub_pd(MulX4(vv, 1.3), _mm256_set1_pd(2.0)), 4, 16u, &outside));
    if (_mm256_movemask_pd(outside) != 0) {
      for (int i = 0; i < 4; ++i) out[k + i] = HullNoiseAt(u[k + i], v[k + i]);
      continue;
    }
    for (int i = 0; i < 4; ++i) out[k + i] = {lanes[0][i], lanes[1][i], lanes[2][i], lanes[3][i]};
  }
  for (; k < n; ++k) out[k] = HullNoiseAt(u[k], v[k]);
}
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif  // TURBID_BUILTIN_AVX2

// HullNoiseAt for n points: the AVX2 version where the CPU has it (same values).
void HullNoiseBatch(const double* u, const double* v, int n, HullNoise* out) {
#ifdef TURBID_BUILTIN_AVX2
  static const bool avx2 = CpuHas(CpuLevel::kAvx2);
  if (avx2 && BuiltinVectorTexturesEnabled()) {
    HullNoiseAvx2(u, v, n, out);
    return;
  }
#endif
  for (int k = 0; k < n; ++k) out[k] = HullNoiseAt(u[k], v[k]);
}

void HullTextureBatch(const SurfacePoint* points, int n, cv::Vec3d* rgb) {
  // Kept per thread: a row's buffers are above malloc's mmap threshold, and mapping them afresh
  // for every row cost ~0.4 s of page faults per 1360 x 1024 scene.
  thread_local std::vector<double> u, v;
  thread_local std::vector<HullNoise> noise;
  u.resize(n);
  v.resize(n);
  noise.resize(n);
  for (int k = 0; k < n; ++k) {
    u[k] = points[k].local[0];
    v[k] = points[k].local[1];
  }
  HullNoiseBatch(u.data(), v.data(), n, noise.data());
  for (int k = 0; k < n; ++k) rgb[k] = HullTextureFrom(u[k], v[k], noise[k]);
}

}  // namespace

bool BuiltinVectorTexturesEnabled() { return g_vector_textures.load(std::memory_order_relaxed); }

Model HullModel() {
  Model model;
  model.gray = true;
  // ACFR-like 1360x1024 camera (assumed ~45 degree horizontal field of view; the real ACFR
  // calibration is not part of our data).
  model.camera = {1650.0, 1650.0, 679.5, 511.5, 1360, 1024};
  // Plate 2.2 m ahead on the optical axis, turned 35 degrees about y and 12 about x: depth runs
  // from about 1.6 m (left) to 3.2 m (right) across the view.
  const cv::Vec3d normal =
      RotationX(-12.0 * kPi / 180) * RotationY(35.0 * kPi / 180) * cv::Vec3d(0, 0, -1);
  model.objects.push_back(MakePlane({0, 0, 2.2}, normal, {1, 0, 0}, HullTexture));
  model.objects.back().texture_batch = HullTextureBatch;
  return model;
}

}  // namespace builtin_model

namespace builtin_internal {

using namespace builtin_model;  // NOLINT: the hull's internals

void SetBuiltinVectorTextures(bool enabled) { builtin_model::g_vector_textures.store(enabled); }

void BuiltinHullNoiseForTest(const double* u, const double* v, int n, double* out) {
  std::vector<HullNoise> noise(n);
  HullNoiseBatch(u, v, n, noise.data());
  for (int k = 0; k < n; ++k) {
    out[4 * k] = noise[k].paint;
    out[4 * k + 1] = noise[k].speckle;
    out[4 * k + 2] = noise[k].streaks;
    out[4 * k + 3] = noise[k].fouling_patch;
  }
}

}  // namespace builtin_internal

}  // namespace turbid
