// The built-in seafloor scene (docs/formats.md): its textures and model.
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

#include "core/cpu.h"
#include "scenes/builtin_internal.h"
#include "scenes/builtin_model.h"
#include "scenes/builtin_noise_x4.h"

namespace turbid::builtin_model {
namespace {

// ---------------------------------------------------------------------------------------------
// Seafloor: sloped sand plane with ripples, shell fragments and sediment patches; rocks as
// spheres and boxes partly sunk into it. Colours are RGB albedos.

// The sand texture's value and cellular noise, which every point needs (SandNoiseAvx2 computes the
// same values four points at a time); SandTextureFrom does the rest.
struct SandNoise {
  double shade, phase, grain, patch, patch_grain;
  Cell shell;  // the shell fragments' cellular noise
};

SandNoise SandNoiseAt(double u, double v) {
  return {Fbm2(u * 2.5, v * 2.5, 4, 31u), Fbm2(u * 1.5, v * 1.5, 3, 32u),
          Noise2(u * 140, v * 140, 33u),  Fbm2(u * 0.9 + 5, v * 0.9, 4, 34u),
          Noise2(u * 60, v * 60, 35u),    Cellular2(u / 0.06, v / 0.06, 36u)};
}

cv::Vec3d SandTextureFrom(double v, const SandNoise& noise) {
  const cv::Vec3d sand{0.60, 0.53, 0.38};
  double shade = 0.85 + 0.30 * (noise.shade - 0.5);
  const double phase = 2.0 * kPi * (v / 0.11 + 0.8 * noise.phase);
  const double ripple = std::sin(phase);
  shade *= 0.88 + 0.12 * ripple * std::abs(ripple) + 0.05 * (noise.grain - 0.5);
  cv::Vec3d color = sand * shade;
  // Sediment / algae patches.
  const double patch = SmoothStep(0.58, 0.66, noise.patch);
  color =
      MixColor(color, cv::Vec3d(0.22, 0.28, 0.16) * (0.8 + 0.4 * noise.patch_grain), patch * 0.85);
  // Shell fragments and pebbles.
  const Cell& cell = noise.shell;
  const double size = 0.12 + 0.18 * Lattice(static_cast<int64_t>(cell.id * 1e6), 0, 0, 37u);
  if (cell.distance < size) {
    color = cell.id < 0.5 ? cv::Vec3d(0.88, 0.84, 0.76) : cv::Vec3d(0.18, 0.16, 0.15);
  }
  return color;
}

cv::Vec3d SandTexture(const SurfacePoint& p) {
  const double u = p.local[0], v = p.local[1];
  return SandTextureFrom(v, SandNoiseAt(u, v));
}

#ifdef TURBID_BUILTIN_AVX2
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

// SandNoiseAt(u[k], v[k]) for k < n, four points at a time (scenes/builtin_noise_x4.h).
void SandNoiseAvx2(const double* u, const double* v, int n, SandNoise* out) {
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const __m256d uu = _mm256_loadu_pd(u + k), vv = _mm256_loadu_pd(v + k);
    __m256d outside = _mm256_setzero_pd();
    alignas(32) double lanes[5][4];
    _mm256_store_pd(lanes[0], Fbm2X4(MulX4(uu, 2.5), MulX4(vv, 2.5), 4, 31u, &outside));
    _mm256_store_pd(lanes[1], Fbm2X4(MulX4(uu, 1.5), MulX4(vv, 1.5), 3, 32u, &outside));
    _mm256_store_pd(lanes[2], Noise2X4(MulX4(uu, 140), MulX4(vv, 140), 33u, &outside));
    _mm256_store_pd(lanes[3], Fbm2X4(_mm256_add_pd(MulX4(uu, 0.9), _mm256_set1_pd(5)),
                                     MulX4(vv, 0.9), 4, 34u, &outside));
    _mm256_store_pd(lanes[4], Noise2X4(MulX4(uu, 60), MulX4(vv, 60), 35u, &outside));
    if (_mm256_movemask_pd(outside) != 0) {
      for (int i = 0; i < 4; ++i) out[k + i] = SandNoiseAt(u[k + i], v[k + i]);
      continue;
    }
    Cell shell[4];
    const __m256d divisor = _mm256_set1_pd(0.06);
    if (!Cellular2X4(_mm256_div_pd(uu, divisor), _mm256_div_pd(vv, divisor), 36u, shell)) {
      for (int i = 0; i < 4; ++i) out[k + i] = SandNoiseAt(u[k + i], v[k + i]);
      continue;
    }
    for (int i = 0; i < 4; ++i)
      out[k + i] = {lanes[0][i], lanes[1][i], lanes[2][i], lanes[3][i], lanes[4][i], shell[i]};
  }
  for (; k < n; ++k) out[k] = SandNoiseAt(u[k], v[k]);
}
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif  // TURBID_BUILTIN_AVX2

// SandNoiseAt for n points: the AVX2 version where the CPU has it (same values).
void SandNoiseBatch(const double* u, const double* v, int n, SandNoise* out) {
#ifdef TURBID_BUILTIN_AVX2
  static const bool avx2 = CpuHas(CpuLevel::kAvx2);
  if (avx2 && BuiltinVectorTexturesEnabled()) {
    SandNoiseAvx2(u, v, n, out);
    return;
  }
#endif
  for (int k = 0; k < n; ++k) out[k] = SandNoiseAt(u[k], v[k]);
}

void SandTextureBatch(const SurfacePoint* points, int n, cv::Vec3d* rgb) {
  thread_local std::vector<double> u, v;  // per thread: see HullTextureBatch
  thread_local std::vector<SandNoise> noise;
  u.resize(n);
  v.resize(n);
  noise.resize(n);
  for (int k = 0; k < n; ++k) {
    u[k] = points[k].local[0];
    v[k] = points[k].local[1];
  }
  SandNoiseBatch(u.data(), v.data(), n, noise.data());
  for (int k = 0; k < n; ++k) rgb[k] = SandTextureFrom(v[k], noise[k]);
}

// The rock texture's three fractal sums, which every point needs (RockNoiseAvx2 computes the same
// values four points at a time); RockTextureFrom does the rest.
struct RockNoise {
  double shade, vein, growth;
};

RockNoise RockNoiseAt(const cv::Vec3d& local, uint32_t seed) {
  return {Fbm3(local * 7.0, 5, seed), Fbm3(local * 3.0, 3, seed + 7),
          Fbm3(local * 12.0 + cv::Vec3d(3, 1, 2), 3, seed + 9)};
}

cv::Vec3d RockTextureFrom(const cv::Vec3d& tint, const RockNoise& noise) {
  double shade = 0.45 + 0.9 * (noise.shade - 0.5);
  // Cracks: thin dark veins where a noise field crosses its median.
  const double vein = std::abs(noise.vein - 0.5);
  if (vein < 0.012) shade *= 0.45;
  cv::Vec3d color = tint * (0.6 + shade);
  // Encrusting growth: orange / green spots.
  const double growth = noise.growth;
  if (growth > 0.66)
    color = (growth > 0.72) ? cv::Vec3d(0.85, 0.45, 0.20) : cv::Vec3d(0.30, 0.55, 0.30);
  return color;
}

cv::Vec3d RockTexture(const SurfacePoint& p, const cv::Vec3d& tint, uint32_t seed) {
  return RockTextureFrom(tint, RockNoiseAt(p.local, seed));
}

#ifdef TURBID_BUILTIN_AVX2
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

// RockNoiseAt(local[k], seed) for k < n, four points at a time (scenes/builtin_noise_x4.h).
void RockNoiseAvx2(const cv::Vec3d* local, int n, uint32_t seed, RockNoise* out) {
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    alignas(32) double xyz[3][4];
    for (int i = 0; i < 4; ++i)
      for (int c = 0; c < 3; ++c) xyz[c][i] = local[k + i][c];
    const __m256d x = _mm256_load_pd(xyz[0]), y = _mm256_load_pd(xyz[1]),
                  z = _mm256_load_pd(xyz[2]);
    __m256d outside = _mm256_setzero_pd();
    alignas(32) double lanes[3][4];
    _mm256_store_pd(lanes[0],
                    Fbm3X4(MulX4(x, 7.0), MulX4(y, 7.0), MulX4(z, 7.0), 5, seed, &outside));
    _mm256_store_pd(lanes[1],
                    Fbm3X4(MulX4(x, 3.0), MulX4(y, 3.0), MulX4(z, 3.0), 3, seed + 7, &outside));
    _mm256_store_pd(
        lanes[2], Fbm3X4(_mm256_add_pd(MulX4(x, 12.0), _mm256_set1_pd(3)),
                         _mm256_add_pd(MulX4(y, 12.0), _mm256_set1_pd(1)),
                         _mm256_add_pd(MulX4(z, 12.0), _mm256_set1_pd(2)), 3, seed + 9, &outside));
    if (_mm256_movemask_pd(outside) != 0) {
      for (int i = 0; i < 4; ++i) out[k + i] = RockNoiseAt(local[k + i], seed);
      continue;
    }
    for (int i = 0; i < 4; ++i) out[k + i] = {lanes[0][i], lanes[1][i], lanes[2][i]};
  }
  for (; k < n; ++k) out[k] = RockNoiseAt(local[k], seed);
}
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif  // TURBID_BUILTIN_AVX2

// RockNoiseAt for n points: the AVX2 version where the CPU has it (same values).
void RockNoiseBatch(const cv::Vec3d* local, int n, uint32_t seed, RockNoise* out) {
#ifdef TURBID_BUILTIN_AVX2
  static const bool avx2 = CpuHas(CpuLevel::kAvx2);
  if (avx2 && BuiltinVectorTexturesEnabled()) {
    RockNoiseAvx2(local, n, seed, out);
    return;
  }
#endif
  for (int k = 0; k < n; ++k) out[k] = RockNoiseAt(local[k], seed);
}

// A rock's texture (tint, seed) for n points at once; the same values as RockTexture.
TextureBatch RockTextureBatch(const cv::Vec3d& tint, uint32_t seed) {
  return [tint, seed](const SurfacePoint* points, int n, cv::Vec3d* rgb) {
    thread_local std::vector<cv::Vec3d> local;  // per thread: see HullTextureBatch
    thread_local std::vector<RockNoise> noise;
    local.resize(n);
    noise.resize(n);
    for (int k = 0; k < n; ++k) local[k] = points[k].local;
    RockNoiseBatch(local.data(), n, seed, noise.data());
    for (int k = 0; k < n; ++k) rgb[k] = RockTextureFrom(tint, noise[k]);
  };
}

// A rock object's textures, scalar and batch.
Object WithRockTexture(Object o, const cv::Vec3d& tint, uint32_t seed) {
  o.texture = [tint, seed](const SurfacePoint& p) { return RockTexture(p, tint, seed); };
  o.texture_batch = RockTextureBatch(tint, seed);
  return o;
}

}  // namespace

Model SeafloorModel() {
  Model model;
  model.camera = {560.0, 560.0, 319.5, 239.5, 640, 480};
  // Seabed below and ahead of a camera pitched down; slight roll. Depth from ~1.6 m (bottom rows)
  // to ~6 m (top rows).
  const cv::Vec3d n = Normalized({0.10, -0.80, -0.60});  // towards the camera (y is down)
  const cv::Vec3d base{0, 0, 2.5};
  model.objects.push_back(MakePlane(base, n, {1, 0, 0}, SandTexture));
  model.objects.back().texture_batch = SandTextureBatch;
  // The seabed's in-plane axes, copied: the push_backs below reallocate model.objects, so a
  // reference to the plane would dangle.
  const cv::Vec3d seabed_u = model.objects.back().axis_u;
  const cv::Vec3d seabed_v = model.objects.back().axis_v;
  // "Up" off the seabed is the plane normal facing the camera.
  const cv::Vec3d up = n;
  auto on_seabed = [&](double u, double v) { return base + seabed_u * u + seabed_v * v; };
  struct Rock {
    double u, v, radius, sink;
    cv::Vec3d tint;
  };
  const Rock spheres[] = {{-0.55, 0.45, 0.28, 0.35, {0.42, 0.40, 0.36}},
                          {0.70, -0.40, 0.35, 0.45, {0.38, 0.36, 0.34}},
                          {0.15, 1.30, 0.22, 0.30, {0.46, 0.40, 0.32}},
                          {-1.10, -0.90, 0.40, 0.50, {0.34, 0.34, 0.36}},
                          {0.95, 1.00, 0.18, 0.25, {0.45, 0.42, 0.38}}};
  uint32_t seed = 40;
  for (const Rock& r : spheres) {
    const cv::Vec3d c = on_seabed(r.u, r.v) + up * (r.radius * (1.0 - 2.0 * r.sink));
    const cv::Vec3d tint = r.tint;
    const uint32_t s = seed++;
    model.objects.push_back(WithRockTexture(MakeSphere(c, r.radius, nullptr), tint, s));
  }
  // Two slab rocks.
  model.objects.push_back(WithRockTexture(
      MakeBox(on_seabed(-0.05, -0.15) + up * 0.08, up, seabed_u, 0.5, {0.30, 0.18, 0.12}, nullptr),
      {0.40, 0.38, 0.33}, 61u));
  model.objects.push_back(WithRockTexture(
      MakeBox(on_seabed(-0.60, 1.90) + up * 0.10, up, seabed_u, -0.3, {0.35, 0.25, 0.15}, nullptr),
      {0.36, 0.37, 0.38}, 62u));
  return model;
}

}  // namespace turbid::builtin_model

namespace turbid::builtin_internal {

void BuiltinSandNoiseForTest(const double* u, const double* v, int n, double* out) {
  std::vector<builtin_model::SandNoise> noise(static_cast<size_t>(n));
  builtin_model::SandNoiseBatch(u, v, n, noise.data());
  for (int k = 0; k < n; ++k) {
    const builtin_model::SandNoise& s = noise[static_cast<size_t>(k)];
    const double values[7] = {s.shade,       s.phase,          s.grain,   s.patch,
                              s.patch_grain, s.shell.distance, s.shell.id};
    for (int i = 0; i < 7; ++i) out[7 * k + i] = values[i];
  }
}

void BuiltinRockNoiseForTest(const double* xyz, int n, uint32_t seed, double* out) {
  std::vector<cv::Vec3d> local(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) local[k] = {xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]};
  std::vector<builtin_model::RockNoise> noise(static_cast<size_t>(n));
  builtin_model::RockNoiseBatch(local.data(), n, seed, noise.data());
  for (int k = 0; k < n; ++k) {
    const builtin_model::RockNoise& r = noise[static_cast<size_t>(k)];
    out[3 * k] = r.shade;
    out[3 * k + 1] = r.vein;
    out[3 * k + 2] = r.growth;
  }
}

}  // namespace turbid::builtin_internal
