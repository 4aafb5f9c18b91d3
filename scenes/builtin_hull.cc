// The built-in hull scene: a painted steel plate with weld seams, rivets, rust streaks and fouling
// (docs/formats.md); its texture's fractal sums have an AVX2 version (same values).
#include <atomic>
#include <opencv2/core.hpp>
#include <vector>

#include "core/cpu.h"
#include "scenes/builtin_internal.h"
#include "scenes/builtin_model.h"
#include "scenes/builtin_noise_x4.h"

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

// Four points at a time: HullNoiseAt's operations, in the same order, on AVX2 lanes
// (scenes/builtin_noise_x4.h); lanes outside the int32 cell range are redone by the scalar code.
#ifdef TURBID_BUILTIN_AVX2
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

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
