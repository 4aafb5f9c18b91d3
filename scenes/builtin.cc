#include "scenes/builtin.h"

#include <opencv2/core/utility.hpp>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>

#include "scenes/builtin_internal.h"
#include "core/cpu.h"
#include "core/error.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNoHit = std::numeric_limits<double>::infinity();
// Albedo bounds: textures never saturate, so every later stage (haze, noise, enhancement) has
// headroom on both sides.
constexpr double kAlbedoMin = 0.05;
constexpr double kAlbedoMax = 0.95;

std::atomic<bool> g_vector_textures{true};  // SetBuiltinVectorTextures
bool BuiltinVectorTexturesEnabled() { return g_vector_textures.load(std::memory_order_relaxed); }

// ---------------------------------------------------------------------------------------------
// Deterministic hash-based noise. Integer hashing keeps textures identical on every run and
// thread count; value noise with a quintic fade is smooth enough to give stable gradients for
// feature detectors.

uint32_t Mix(uint32_t h) {
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

double Lattice(int64_t x, int64_t y, int64_t z, uint32_t seed) {
  // One avalanche round over a linear combination of the coordinates: the mixer's full
  // avalanche hides the combination's correlations.
  const uint32_t h = Mix(static_cast<uint32_t>(x) * 0x8da6b343u + static_cast<uint32_t>(y) * 0xd8163841u +
                         static_cast<uint32_t>(z) * 0xcb1ab31fu + seed * 0x9e3779b9u);
  return h * (1.0 / 4294967296.0);
}

double Fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
double Lerp(double a, double b, double t) { return a + (b - a) * t; }
double Clamp01(double v) { return std::min(1.0, std::max(0.0, v)); }
double SmoothStep(double e0, double e1, double x) {
  const double t = Clamp01((x - e0) / (e1 - e0));
  return t * t * (3.0 - 2.0 * t);
}

// Value noise in [0, 1].
double Noise2(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double tx = Fade(x - fx), ty = Fade(y - fy);
  const double a = Lerp(Lattice(ix, iy, 0, seed), Lattice(ix + 1, iy, 0, seed), tx);
  const double b = Lerp(Lattice(ix, iy + 1, 0, seed), Lattice(ix + 1, iy + 1, 0, seed), tx);
  return Lerp(a, b, ty);
}

double Noise3(double x, double y, double z, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy),
             iz = static_cast<int64_t>(fz);
  const double tx = Fade(x - fx), ty = Fade(y - fy), tz = Fade(z - fz);
  double layer[2];
  for (int k = 0; k < 2; ++k) {
    const double a =
        Lerp(Lattice(ix, iy, iz + k, seed), Lattice(ix + 1, iy, iz + k, seed), tx);
    const double b =
        Lerp(Lattice(ix, iy + 1, iz + k, seed), Lattice(ix + 1, iy + 1, iz + k, seed), tx);
    layer[k] = Lerp(a, b, ty);
  }
  return Lerp(layer[0], layer[1], tz);
}

// Fractal sum of `octaves` noise layers (frequency x2, amplitude x0.5), normalised to [0, 1].
double Fbm2(double x, double y, int octaves, uint32_t seed) {
  double sum = 0.0, amplitude = 1.0, norm = 0.0;
  for (int i = 0; i < octaves; ++i) {
    sum += amplitude * Noise2(x, y, seed + 101u * i);
    norm += amplitude;
    x = x * 2.03 + 17.1;
    y = y * 2.03 - 5.3;
    amplitude *= 0.5;
  }
  return sum / norm;
}

double Fbm3(const cv::Vec3d& p, int octaves, uint32_t seed) {
  double sum = 0.0, amplitude = 1.0, norm = 0.0;
  cv::Vec3d q = p;
  for (int i = 0; i < octaves; ++i) {
    sum += amplitude * Noise3(q[0], q[1], q[2], seed + 131u * i);
    norm += amplitude;
    q = q * 2.03 + cv::Vec3d(7.7, -3.1, 11.3);
    amplitude *= 0.5;
  }
  return sum / norm;
}

// Cellular noise: one random feature point per unit cell; returns the distance (in cell units) to
// the nearest one and that point's random id in [0, 1).
struct Cell {
  double distance;
  double id;
};
// The nearest point is the first of the 3 x 3 candidates at the least std::hypot distance.
// hypot is slow, so it is computed only for the candidates whose squared distance dx^2 + dy^2
// (within a few ulps of hypot^2) is within a relative 1e-9 of the least: the others' hypot is
// certainly larger than the nearest's, and leaving them out changes neither the least distance nor
// its first index. The id is looked up for the winner only.
Cell Cellular2(double x, double y, uint32_t seed) {
  const auto ix = static_cast<int64_t>(std::floor(x)), iy = static_cast<int64_t>(std::floor(y));
  double dx[9], dy[9], d2[9];
  double least = std::numeric_limits<double>::infinity();
  for (int c = 0; c < 9; ++c) {
    const int64_t i = ix - 1 + c % 3, j = iy - 1 + c / 3;
    const double px = i + Lattice(i, j, 1, seed), py = j + Lattice(i, j, 2, seed);
    dx[c] = px - x;
    dy[c] = py - y;
    d2[c] = dx[c] * dx[c] + dy[c] * dy[c];
    least = std::min(least, d2[c]);
  }
  const double bound = least * (1.0 + 1e-9) + 1e-300;
  Cell best{1e9, 0.0};
  int best_c = -1;
  for (int c = 0; c < 9; ++c) {
    if (!(d2[c] <= bound)) continue;
    const double d = std::hypot(dx[c], dy[c]);
    if (d < best.distance) {
      best.distance = d;
      best_c = c;
    }
  }
  if (best_c >= 0) best.id = Lattice(ix - 1 + best_c % 3, iy - 1 + best_c / 3, 3, seed);
  return best;
}

cv::Vec3d Gray(double v) { return {v, v, v}; }
cv::Vec3d MixColor(const cv::Vec3d& a, const cv::Vec3d& b, double t) { return a + (b - a) * t; }

// ---------------------------------------------------------------------------------------------
// Geometry. World frame: the frame the scene is modelled in; camera frame = world for hull and
// seafloor. A ray is origin + t * direction with the camera-frame direction's z = 1, so t is the
// z-depth directly.

// Where a ray met a surface, in the object's own frame for texturing.
struct SurfacePoint {
  cv::Vec3d world;  // hit point, world frame
  cv::Vec3d local;  // plane: (u, v, 0) along the plane's axes; box/sphere: offset in object frame
  cv::Vec3d normal_world;  // outward (towards the incoming ray) unit normal
};

using Texture = std::function<cv::Vec3d(const SurfacePoint&)>;  // RGB albedo, linear
// Optional: the same texture for n points at once (rgb[k] = texture(points[k]), the same values).
using TextureBatch = void (*)(const SurfacePoint* points, int n, cv::Vec3d* rgb);

struct Object {
  enum class Kind { kPlane, kSphere, kBox };
  Kind kind = Kind::kPlane;
  // Plane: passes through `center` with unit normal `axis_w`; texture axes axis_u, axis_v.
  // Sphere: `center`, `radius`. Box: `center`, orthonormal axes (u, v, w), half sizes.
  cv::Vec3d center;
  cv::Vec3d axis_u{1, 0, 0}, axis_v{0, 1, 0}, axis_w{0, 0, 1};
  cv::Vec3d half_size{0, 0, 0};
  double radius = 0.0;
  Texture texture;
  TextureBatch texture_batch = nullptr;

  // Ray parameter of the first hit with t > t_min, or kNoHit; fills the hit's normal and local
  // coordinates.
  double Intersect(const cv::Vec3d& origin, const cv::Vec3d& dir, double t_min,
                   SurfacePoint* hit) const {
    switch (kind) {
      case Kind::kPlane: {
        const double denom = axis_w.dot(dir);
        if (std::abs(denom) < 1e-12) return kNoHit;
        const double t = axis_w.dot(center - origin) / denom;
        if (!(t > t_min)) return kNoHit;
        hit->world = origin + dir * t;
        const cv::Vec3d rel = hit->world - center;
        hit->local = {rel.dot(axis_u), rel.dot(axis_v), 0.0};
        hit->normal_world = denom < 0 ? axis_w : -axis_w;
        return t;
      }
      case Kind::kSphere: {
        const cv::Vec3d oc = origin - center;
        const double a = dir.dot(dir), b = oc.dot(dir), c = oc.dot(oc) - radius * radius;
        const double disc = b * b - a * c;
        if (disc < 0) return kNoHit;
        const double root = std::sqrt(disc);
        double t = (-b - root) / a;
        if (!(t > t_min)) t = (-b + root) / a;
        if (!(t > t_min)) return kNoHit;
        hit->world = origin + dir * t;
        hit->local = hit->world - center;
        hit->normal_world = hit->local / radius;
        if (hit->normal_world.dot(dir) > 0) hit->normal_world = -hit->normal_world;
        return t;
      }
      case Kind::kBox: {
        const cv::Vec3d rel = origin - center;
        const cv::Vec3d axes[3] = {axis_u, axis_v, axis_w};
        double t_near = -kNoHit, t_far = kNoHit;
        int near_axis = 0;
        double near_sign = 1.0;
        for (int k = 0; k < 3; ++k) {
          const double o = rel.dot(axes[k]), d = dir.dot(axes[k]);
          if (std::abs(d) < 1e-12) {
            if (std::abs(o) > half_size[k]) return kNoHit;
            continue;
          }
          double t0 = (-half_size[k] - o) / d, t1 = (half_size[k] - o) / d;
          double sign = -1.0;  // entering through the -axis face
          if (t0 > t1) {
            std::swap(t0, t1);
            sign = 1.0;
          }
          if (t0 > t_near) {
            t_near = t0;
            near_axis = k;
            near_sign = sign;
          }
          t_far = std::min(t_far, t1);
        }
        if (t_near > t_far || !(t_near > t_min)) return kNoHit;  // camera is never inside a box
        hit->world = origin + dir * t_near;
        const cv::Vec3d p = hit->world - center;
        hit->local = {p.dot(axis_u), p.dot(axis_v), p.dot(axis_w)};
        hit->normal_world = axes[near_axis] * near_sign;
        return t_near;
      }
    }
    return kNoHit;
  }
};

// A built-in scene's model: camera, pose (world = rotation * camera + position), objects.
struct Model {
  CameraIntrinsics camera;  // native size
  bool gray = false;
  cv::Matx33d world_from_camera = cv::Matx33d::eye();
  cv::Vec3d camera_in_world{0, 0, 0};
  std::vector<Object> objects;
  cv::Vec3d background{0.05, 0.05, 0.05};  // albedo where no object is hit
};

cv::Vec3d Normalized(const cv::Vec3d& v) { return v / cv::norm(v); }

// Plane through `point` with unit normal `normal`; texture axes: u orthogonal to `normal` and as
// close as possible to `u_hint`, v = w x u.
Object MakePlane(const cv::Vec3d& point, const cv::Vec3d& normal, const cv::Vec3d& u_hint,
                 Texture texture) {
  Object o;
  o.kind = Object::Kind::kPlane;
  o.center = point;
  o.axis_w = Normalized(normal);
  o.axis_u = Normalized(u_hint - o.axis_w * u_hint.dot(o.axis_w));
  o.axis_v = o.axis_w.cross(o.axis_u);
  o.texture = std::move(texture);
  return o;
}

Object MakeSphere(const cv::Vec3d& center, double radius, Texture texture) {
  Object o;
  o.kind = Object::Kind::kSphere;
  o.center = center;
  o.radius = radius;
  o.texture = std::move(texture);
  return o;
}

// Box with axis w along `up`, rotated by `yaw_rad` about it from the u hint.
Object MakeBox(const cv::Vec3d& center, const cv::Vec3d& up, const cv::Vec3d& u_hint,
               double yaw_rad, const cv::Vec3d& half_size, Texture texture) {
  Object o;
  o.kind = Object::Kind::kBox;
  o.center = center;
  o.axis_w = Normalized(up);
  const cv::Vec3d u0 = Normalized(u_hint - o.axis_w * u_hint.dot(o.axis_w));
  const cv::Vec3d v0 = o.axis_w.cross(u0);
  o.axis_u = u0 * std::cos(yaw_rad) + v0 * std::sin(yaw_rad);
  o.axis_v = o.axis_w.cross(o.axis_u);
  o.half_size = half_size;
  o.texture = std::move(texture);
  return o;
}

cv::Matx33d RotationX(double a) {
  return {1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a)};
}
cv::Matx33d RotationY(double a) {
  return {std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)};
}

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
    if (r < 0.011 && Lattice(static_cast<int64_t>(k), static_cast<int64_t>(strake), 5, seed) > 0.12) {
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
  *outside = _mm256_or_pd(*outside, _mm256_xor_pd(inside, _mm256_castsi256_pd(_mm256_set1_epi32(-1))));
  return _mm256_cvttpd_epi32(f);
}

inline __m256d Noise2X4(__m256d x, __m256d y, uint32_t seed,
                                                         __m256d* outside) {
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

inline __m256d Fbm2X4(__m256d x, __m256d y, int octaves,
                                                       uint32_t seed, __m256d* outside) {
  __m256d sum = _mm256_setzero_pd();
  double amplitude = 1.0, norm = 0.0;
  for (int i = 0; i < octaves; ++i) {
    sum = _mm256_add_pd(sum, _mm256_mul_pd(_mm256_set1_pd(amplitude),
                                           Noise2X4(x, y, seed + 101u * i, outside)));
    norm += amplitude;
    x = _mm256_add_pd(_mm256_mul_pd(x, _mm256_set1_pd(2.03)), _mm256_set1_pd(17.1));
    y = _mm256_sub_pd(_mm256_mul_pd(y, _mm256_set1_pd(2.03)), _mm256_set1_pd(5.3));
    amplitude *= 0.5;
  }
  return _mm256_div_pd(sum, _mm256_set1_pd(norm));
}

inline __m256d MulX4(__m256d a, double b) { return _mm256_mul_pd(a, _mm256_set1_pd(b)); }

// HullNoiseAt(u[k], v[k]) for k < n.
void HullNoiseAvx2(const double* u, const double* v, int n,
                                                   HullNoise* out) {
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

Model HullModel() {
  Model model;
  model.gray = true;
  // ACFR-like 1360x1024 camera (assumed ~45 degree horizontal field of view; the real ACFR
  // calibration is not part of our data).
  model.camera = {1650.0, 1650.0, 679.5, 511.5, 1360, 1024};
  // Plate 2.2 m ahead on the optical axis, turned 35 degrees about y and 12 about x: depth runs
  // from about 1.6 m (left) to 3.2 m (right) across the view.
  const cv::Vec3d normal = RotationX(-12.0 * kPi / 180) * RotationY(35.0 * kPi / 180) *
                           cv::Vec3d(0, 0, -1);
  model.objects.push_back(MakePlane({0, 0, 2.2}, normal, {1, 0, 0}, HullTexture));
  model.objects.back().texture_batch = HullTextureBatch;
  return model;
}

// ---------------------------------------------------------------------------------------------
// Seafloor: sloped sand plane with ripples, shell fragments and sediment patches; rocks as
// spheres and boxes partly sunk into it. Colours are RGB albedos.

cv::Vec3d SandTexture(const SurfacePoint& p) {
  const double u = p.local[0], v = p.local[1];
  const cv::Vec3d sand{0.60, 0.53, 0.38};
  double shade = 0.85 + 0.30 * (Fbm2(u * 2.5, v * 2.5, 4, 31u) - 0.5);
  const double phase = 2.0 * kPi * (v / 0.11 + 0.8 * Fbm2(u * 1.5, v * 1.5, 3, 32u));
  const double ripple = std::sin(phase);
  shade *= 0.88 + 0.12 * ripple * std::abs(ripple) + 0.05 * (Noise2(u * 140, v * 140, 33u) - 0.5);
  cv::Vec3d color = sand * shade;
  // Sediment / algae patches.
  const double patch = SmoothStep(0.58, 0.66, Fbm2(u * 0.9 + 5, v * 0.9, 4, 34u));
  color = MixColor(color, cv::Vec3d(0.22, 0.28, 0.16) * (0.8 + 0.4 * Noise2(u * 60, v * 60, 35u)),
                   patch * 0.85);
  // Shell fragments and pebbles.
  const Cell cell = Cellular2(u / 0.06, v / 0.06, 36u);
  const double size = 0.12 + 0.18 * Lattice(static_cast<int64_t>(cell.id * 1e6), 0, 0, 37u);
  if (cell.distance < size) {
    color = cell.id < 0.5 ? cv::Vec3d(0.88, 0.84, 0.76) : cv::Vec3d(0.18, 0.16, 0.15);
  }
  return color;
}

cv::Vec3d RockTexture(const SurfacePoint& p, const cv::Vec3d& tint, uint32_t seed) {
  const cv::Vec3d q = p.local * 7.0;
  double shade = 0.45 + 0.9 * (Fbm3(q, 5, seed) - 0.5);
  // Cracks: thin dark veins where a noise field crosses its median.
  const double vein = std::abs(Fbm3(p.local * 3.0, 3, seed + 7) - 0.5);
  if (vein < 0.012) shade *= 0.45;
  cv::Vec3d color = tint * (0.6 + shade);
  // Encrusting growth: orange / green spots.
  const double growth = Fbm3(p.local * 12.0 + cv::Vec3d(3, 1, 2), 3, seed + 9);
  if (growth > 0.66) color = (growth > 0.72) ? cv::Vec3d(0.85, 0.45, 0.20) : cv::Vec3d(0.30, 0.55, 0.30);
  return color;
}

Model SeafloorModel() {
  Model model;
  model.camera = {560.0, 560.0, 319.5, 239.5, 640, 480};
  // Seabed below and ahead of a camera pitched down; slight roll. Depth from ~1.6 m (bottom rows)
  // to ~6 m (top rows).
  const cv::Vec3d n = Normalized({0.10, -0.80, -0.60});  // towards the camera (y is down)
  const cv::Vec3d base{0, 0, 2.5};
  model.objects.push_back(MakePlane(base, n, {1, 0, 0}, SandTexture));
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
    model.objects.push_back(MakeSphere(c, r.radius, [tint, s](const SurfacePoint& p) {
      return RockTexture(p, tint, s);
    }));
  }
  // Two slab rocks.
  model.objects.push_back(MakeBox(on_seabed(-0.05, -0.15) + up * 0.08, up, seabed_u, 0.5,
                                  {0.30, 0.18, 0.12}, [](const SurfacePoint& p) {
                                    return RockTexture(p, {0.40, 0.38, 0.33}, 61u);
                                  }));
  model.objects.push_back(MakeBox(on_seabed(-0.60, 1.90) + up * 0.10, up, seabed_u, -0.3,
                                  {0.35, 0.25, 0.15}, [](const SurfacePoint& p) {
                                    return RockTexture(p, {0.36, 0.37, 0.38}, 62u);
                                  }));
  return model;
}

// ---------------------------------------------------------------------------------------------
// Room: an ICL-NUIM-like living-room box. World frame: x right, y up, z forward; the camera
// frame has y up as well because fy < 0 (ICL-NUIM convention), so image row 0 looks upward.

cv::Vec3d FloorTexture(const SurfacePoint& p) {
  const double x = p.world[0], z = p.world[2];
  // Planks 18 cm wide along z with staggered ends every 1.2 m.
  const double plank = std::floor(x / 0.18);
  const double offset = Lattice(static_cast<int64_t>(plank), 0, 0, 71u) * 1.2;
  const double end = std::floor((z + offset) / 1.2);
  const double tone = Lattice(static_cast<int64_t>(plank), static_cast<int64_t>(end), 0, 72u);
  const double grain = Fbm2(x * 60.0, z * 4.0, 4, 73u);
  cv::Vec3d color = cv::Vec3d(0.50, 0.34, 0.20) * (0.75 + 0.3 * tone + 0.35 * (grain - 0.5));
  const double fx = x / 0.18 - plank, fz = (z + offset) / 1.2 - end;
  if (fx < 0.03 || fz < 0.006) color = {0.12, 0.08, 0.06};  // gaps between planks
  // Rug with a stripe-and-diamond pattern.
  if (std::abs(x - 0.2) < 0.9 && std::abs(z - 2.2) < 0.6) {
    const double a = std::abs(x - 0.2), b = std::abs(z - 2.2);
    if (a > 0.8 || b > 0.5) {
      color = {0.70, 0.62, 0.40};  // border
    } else {
      const double diamond = std::fmod(std::abs(a / 0.15) + std::abs(b / 0.15), 2.0);
      color = diamond < 1.0 ? cv::Vec3d(0.62, 0.16, 0.14) : cv::Vec3d(0.18, 0.22, 0.48);
      color *= 0.85 + 0.3 * Noise2(x * 150, z * 150, 74u);
    }
  }
  return color;
}

cv::Vec3d WallTexture(const SurfacePoint& p, const cv::Vec3d& paint, uint32_t seed) {
  const double u = p.local[0], v = p.local[1];
  cv::Vec3d color = paint * (0.92 + 0.16 * (Fbm2(u * 6.0, v * 6.0, 4, seed) - 0.5));
  // Posters: framed rectangles on a 1.3 m grid (some cells empty) filled with coloured blobs.
  const double cu = std::floor(u / 1.3), cv_ = std::floor(v / 1.0);
  const double fu = u / 1.3 - cu, fv = v / 1.0 - cv_;
  const auto ci = static_cast<int64_t>(cu), cj = static_cast<int64_t>(cv_);
  if (Lattice(ci, cj, 0, seed + 1) > 0.35 && fu > 0.15 && fu < 0.85 && fv > 0.2 && fv < 0.8) {
    if (fu < 0.18 || fu > 0.82 || fv < 0.23 || fv > 0.77) return {0.10, 0.09, 0.08};  // frame
    const uint32_t s = seed + 10 + static_cast<uint32_t>(ci * 7 + cj * 13);
    const cv::Vec3d rgb{Fbm2(u * 9, v * 9, 3, s), Fbm2(u * 9, v * 9, 3, s + 1),
                        Fbm2(u * 9, v * 9, 3, s + 2)};
    cv::Vec3d poster = (rgb - cv::Vec3d(0.5, 0.5, 0.5)) * 2.2 + cv::Vec3d(0.5, 0.5, 0.5);
    // A checker inset gives sharp corners for detectors.
    if (fu > 0.55 && fv < 0.4) {
      const bool odd = (static_cast<int>(std::floor(u / 0.05)) + static_cast<int>(std::floor(v / 0.05))) & 1;
      poster = odd ? cv::Vec3d(0.9, 0.9, 0.85) : cv::Vec3d(0.1, 0.1, 0.12);
    }
    return poster;
  }
  // Skirting board near the floor (v is height above the floor for walls).
  if (v < 0.12) return {0.85, 0.84, 0.80};
  return color;
}

cv::Vec3d CardboardTexture(const SurfacePoint& p) {
  const cv::Vec3d& q = p.local;
  cv::Vec3d color = cv::Vec3d(0.62, 0.45, 0.28) * (0.85 + 0.3 * (Fbm3(q * 20.0, 3, 81u) - 0.5));
  if (std::abs(q[0]) < 0.03) color = {0.80, 0.75, 0.55};  // tape
  // Printed label: small checker on one region of each face.
  const double a = q[1], b = q[2];
  if (a > 0.02 && a < 0.16 && b > -0.05 && b < 0.10) {
    const bool odd = (static_cast<int>(std::floor(a / 0.02)) + static_cast<int>(std::floor(b / 0.03))) & 1;
    color = odd ? cv::Vec3d(0.1, 0.1, 0.1) : cv::Vec3d(0.9, 0.9, 0.9);
  }
  return color;
}

cv::Vec3d CubeTexture(const SurfacePoint& p) {
  const cv::Vec3d& q = p.local;
  const int i = static_cast<int>(std::floor(q[0] / 0.06)), j = static_cast<int>(std::floor(q[1] / 0.06)),
            k = static_cast<int>(std::floor(q[2] / 0.06));
  const bool odd = (i + j + k) & 1;
  const cv::Vec3d colors[4] = {{0.8, 0.2, 0.15}, {0.15, 0.55, 0.25}, {0.2, 0.3, 0.8}, {0.85, 0.75, 0.2}};
  const int pick = static_cast<int>(Lattice(i, j, k, 91u) * 4) & 3;
  return odd ? colors[pick] : cv::Vec3d(0.9, 0.88, 0.85);
}

Model RoomModel() {
  Model model;
  model.camera = {481.20, -480.00, 319.5, 239.5, 640, 480};
  // Camera 1.3 m above the floor, yawed 18 degrees and pitched 10 degrees down.
  model.world_from_camera = RotationY(18.0 * kPi / 180) * RotationX(10.0 * kPi / 180);
  model.camera_in_world = {-0.4, 0.0, 0.3};
  const double floor_y = -1.3, ceiling_y = 1.3, left_x = -2.2, right_x = 2.4, back_z = 4.5,
               front_z = -1.5;
  model.objects.push_back(MakePlane({0, floor_y, 0}, {0, 1, 0}, {1, 0, 0}, FloorTexture));
  model.objects.push_back(MakePlane({0, ceiling_y, 0}, {0, -1, 0}, {1, 0, 0}, [](const SurfacePoint& p) {
    return Gray(0.82 + 0.08 * (Fbm2(p.local[0] * 4, p.local[1] * 4, 3, 75u) - 0.5));
  }));
  // Walls: texture v axis is height above the floor (plane centre sits on the floor line).
  model.objects.push_back(MakePlane({0, floor_y, back_z}, {0, 0, -1}, {1, 0, 0},
                                    [](const SurfacePoint& p) {
                                      SurfacePoint q = p;
                                      q.local[1] = p.world[1] + 1.3;
                                      return WallTexture(q, {0.70, 0.66, 0.52}, 100u);
                                    }));
  model.objects.push_back(MakePlane({left_x, floor_y, 0}, {1, 0, 0}, {0, 0, 1},
                                    [](const SurfacePoint& p) {
                                      SurfacePoint q = p;
                                      q.local = {p.world[2], p.world[1] + 1.3, 0};
                                      return WallTexture(q, {0.45, 0.58, 0.66}, 200u);
                                    }));
  model.objects.push_back(MakePlane({right_x, floor_y, 0}, {-1, 0, 0}, {0, 0, 1},
                                    [](const SurfacePoint& p) {
                                      SurfacePoint q = p;
                                      q.local = {p.world[2], p.world[1] + 1.3, 0};
                                      return WallTexture(q, {0.66, 0.50, 0.45}, 300u);
                                    }));
  model.objects.push_back(MakePlane({0, floor_y, front_z}, {0, 0, 1}, {1, 0, 0},
                                    [](const SurfacePoint& p) {
                                      SurfacePoint q = p;
                                      q.local = {p.world[0], p.world[1] + 1.3, 0};
                                      return WallTexture(q, {0.60, 0.60, 0.60}, 400u);
                                    }));
  const cv::Vec3d up{0, 1, 0};
  model.objects.push_back(MakeBox({0.9, floor_y + 0.25, 2.8}, up, {1, 0, 0}, 0.35,
                                  {0.35, 0.25, 0.25}, CardboardTexture));
  model.objects.push_back(MakeBox({-0.9, floor_y + 0.2, 2.4}, up, {1, 0, 0}, -0.6,
                                  {0.2, 0.2, 0.2}, CubeTexture));
  model.objects.push_back(MakeSphere({0.1, floor_y + 0.15, 1.7}, 0.15, [](const SurfacePoint& p) {
    const double band = std::sin(p.local[1] / 0.15 * 3.0 * kPi + 4.0 * std::atan2(p.local[2], p.local[0]));
    return band > 0 ? cv::Vec3d(0.85, 0.25, 0.2) : cv::Vec3d(0.9, 0.85, 0.3);
  }));
  return model;
}

Model ModelFor(const std::string& name) {
  if (name == "hull") return HullModel();
  if (name == "seafloor") return SeafloorModel();
  if (name == "room") return RoomModel();
  std::string known;
  for (const std::string& n : BuiltinSceneNames()) known += (known.empty() ? "" : ", ") + n;
  throw Error("builtin scene '" + name + "'", "unknown (known: " + known + ")");
}

// Nearest hit along a world ray; returns the object index or -1.
int Trace(const Model& model, const cv::Vec3d& dir_world, SurfacePoint* hit, double* t_hit) {
  int best = -1;
  double best_t = kNoHit;
  SurfacePoint candidate;
  for (size_t i = 0; i < model.objects.size(); ++i) {
    const double t = model.objects[i].Intersect(model.camera_in_world, dir_world, 1e-6, &candidate);
    if (t < best_t) {
      best_t = t;
      best = static_cast<int>(i);
      *hit = candidate;
    }
  }
  *t_hit = best_t;
  return best;
}

cv::Vec3d ClampAlbedo(const cv::Vec3d& rgb) {
  return {std::clamp(rgb[0], kAlbedoMin, kAlbedoMax), std::clamp(rgb[1], kAlbedoMin, kAlbedoMax),
          std::clamp(rgb[2], kAlbedoMin, kAlbedoMax)};
}

// Scratch space of Albedos, reused across rows.
struct AlbedoScratch {
  std::vector<SurfacePoint> points, group;
  std::vector<int> owner;
  std::vector<cv::Vec3d> group_rgb;
};

// Clamped albedos of n sample rays (world frame): each is the texture of the nearest hit, or the
// background. Objects with a batch texture get all their points in one call.
void Albedos(const Model& model, const cv::Vec3d* dirs_world, int n, cv::Vec3d* rgb,
             AlbedoScratch* scratch) {
  std::vector<SurfacePoint>& points = scratch->points;
  std::vector<int>& owner = scratch->owner;
  points.resize(n);
  owner.resize(n);
  bool any_batch = false;
  for (int k = 0; k < n; ++k) {
    double t;
    const int index = Trace(model, dirs_world[k], &points[k], &t);
    owner[k] = index;
    if (index < 0) {
      rgb[k] = model.background;
    } else if (model.objects[index].texture_batch) {
      any_batch = true;
    } else {
      rgb[k] = model.objects[index].texture(points[k]);
    }
  }
  if (any_batch) {
    std::vector<SurfacePoint>& group = scratch->group;
    std::vector<cv::Vec3d>& group_rgb = scratch->group_rgb;
    for (size_t o = 0; o < model.objects.size(); ++o) {
      if (!model.objects[o].texture_batch) continue;
      group.clear();
      for (int k = 0; k < n; ++k)
        if (owner[k] == static_cast<int>(o)) group.push_back(points[k]);
      if (group.empty()) continue;
      group_rgb.resize(group.size());
      model.objects[o].texture_batch(group.data(), static_cast<int>(group.size()), group_rgb.data());
      size_t next = 0;
      for (int k = 0; k < n; ++k)
        if (owner[k] == static_cast<int>(o)) rgb[k] = group_rgb[next++];
    }
  }
  for (int k = 0; k < n; ++k) rgb[k] = ClampAlbedo(rgb[k]);
}

// The plane object seen at the most pixel centres, in the camera frame.
std::optional<Plane> DominantPlane(const Model& model, const cv::Mat& labels) {
  std::vector<int> counts(model.objects.size(), 0);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
      if (labels.at<int>(y, x) >= 0) ++counts[labels.at<int>(y, x)];
  int best = -1;
  for (size_t i = 0; i < model.objects.size(); ++i) {
    if (model.objects[i].kind != Object::Kind::kPlane) continue;
    if (best < 0 || counts[i] > counts[best]) best = static_cast<int>(i);
  }
  if (best < 0 || counts[best] == 0) return std::nullopt;
  const Object& o = model.objects[best];
  // Camera-frame plane: X_w = R X_c + C, n_w . (X_w - P) = 0 -> (R^T n_w) . X_c + n_w . (C - P) = 0.
  const cv::Matx33d camera_from_world = model.world_from_camera.t();
  Plane plane;
  plane.normal = camera_from_world * o.axis_w;
  plane.offset_m = o.axis_w.dot(model.camera_in_world - o.center);
  if (plane.offset_m < 0) {  // orient towards the camera
    plane.normal = -plane.normal;
    plane.offset_m = -plane.offset_m;
  }
  return plane;
}

}  // namespace

bool BuiltinSceneOptions::Check(std::string* why) const {
  if (!std::isfinite(scale) || scale <= 0.0 || scale > 1.0) {
    if (why) *why = "scale must be in (0, 1]";
    return false;
  }
  if (supersampling < 1 || supersampling > 8) {
    if (why) *why = "supersampling must be in 1..8";
    return false;
  }
  return true;
}

std::vector<std::string> BuiltinSceneNames() { return {"hull", "seafloor", "room"}; }

CameraIntrinsics BuiltinSceneCamera(const std::string& name) { return ModelFor(name).camera; }

CameraIntrinsics ScaleIntrinsics(const CameraIntrinsics& camera, double scale) {
  CameraIntrinsics out = camera;
  out.width = std::max(1, static_cast<int>(std::lround(camera.width * scale)));
  out.height = std::max(1, static_cast<int>(std::lround(camera.height * scale)));
  const double sx = static_cast<double>(out.width) / camera.width;
  const double sy = static_cast<double>(out.height) / camera.height;
  out.fx = camera.fx * sx;
  out.fy = camera.fy * sy;
  out.cx = (camera.cx + 0.5) * sx - 0.5;
  out.cy = (camera.cy + 0.5) * sy - 0.5;
  return out;
}

std::vector<cv::Vec3d> DvlBeamHits(const Plane& plane, double beam_half_angle_rad) {
  std::vector<cv::Vec3d> hits;
  const double s = std::sin(beam_half_angle_rad), c = std::cos(beam_half_angle_rad);
  for (int k = 0; k < 4; ++k) {
    const double azimuth = (45.0 + 90.0 * k) * kPi / 180.0;
    const cv::Vec3d beam{s * std::cos(azimuth), s * std::sin(azimuth), c};
    const double denom = plane.normal.dot(beam);
    if (std::abs(denom) < 1e-12) continue;
    const double t = -plane.offset_m / denom;
    if (t > 0) hits.push_back(beam * t);
  }
  return hits;
}

Scene MakeBuiltinScene(const std::string& name, const BuiltinSceneOptions& options) {
  ThrowIfInvalid(options, "builtin scene '" + name + "'");
  const Model model = ModelFor(name);
  Scene scene;
  scene.name = name;
  scene.camera = ScaleIntrinsics(model.camera, options.scale);
  const CameraIntrinsics& cam = scene.camera;
  const cv::Size size(cam.width, cam.height);
  cv::Mat color(size, CV_32FC3);
  scene.depth_m.create(size, CV_32FC1);
  scene.normals.create(size, CV_32FC3);
  cv::Mat labels(size, CV_32SC1);
  const int ss = options.supersampling;
  const cv::Matx33d& rotation = model.world_from_camera;
  const cv::Matx33d camera_from_world = rotation.t();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Each pixel depends only on its own coordinates, so any row split gives the same bytes.
  cv::parallel_for_(cv::Range(0, cam.height), [&](const cv::Range& rows) {
    // One row's sample rays, then their albedos in one call (batch textures), summed per pixel in
    // sample order.
    std::vector<cv::Vec3d> dirs(static_cast<size_t>(cam.width) * ss * ss), albedo(dirs.size());
    AlbedoScratch scratch;
    for (int y = rows.start; y < rows.end; ++y) {
      for (int x = 0; x < cam.width; ++x) {
        for (int j = 0; j < ss; ++j) {
          for (int i = 0; i < ss; ++i) {
            const double u = x + (i + 0.5) / ss - 0.5, v = y + (j + 0.5) / ss - 0.5;
            dirs[(static_cast<size_t>(x) * ss + j) * ss + i] = rotation * cam.Ray(u, v);
          }
        }
      }
      Albedos(model, dirs.data(), static_cast<int>(dirs.size()), albedo.data(), &scratch);
      auto* rgb_row = color.ptr<cv::Vec3f>(y);
      auto* depth_row = scene.depth_m.ptr<float>(y);
      auto* normal_row = scene.normals.ptr<cv::Vec3f>(y);
      auto* label_row = labels.ptr<int>(y);
      for (int x = 0; x < cam.width; ++x) {
        const cv::Vec3d ray = cam.Ray(x, y);
        SurfacePoint hit;
        double t;
        const int index = Trace(model, rotation * ray, &hit, &t);
        label_row[x] = index;
        if (index < 0) {
          depth_row[x] = nan;
          normal_row[x] = {nan, nan, nan};
        } else {
          depth_row[x] = static_cast<float>(t);
          cv::Vec3d n = camera_from_world * hit.normal_world;
          if (n.dot(ray) > 0) n = -n;
          n /= cv::norm(n);
          normal_row[x] = cv::Vec3f(n);
        }
        cv::Vec3d sum{0, 0, 0};
        const cv::Vec3d* samples = &albedo[static_cast<size_t>(x) * ss * ss];
        for (int k = 0; k < ss * ss; ++k) sum += samples[k];
        sum /= static_cast<double>(ss * ss);
        rgb_row[x] = cv::Vec3f(static_cast<float>(sum[2]), static_cast<float>(sum[1]),
                               static_cast<float>(sum[0]));  // BGR, as OpenCV
      }
    }
  });
  if (model.gray) {
    cv::extractChannel(color, scene.image, 0);
  } else {
    scene.image = color;
  }
  scene.dominant_plane = DominantPlane(model, labels);
  if (scene.dominant_plane) scene.dvl_points_in_camera = DvlBeamHits(*scene.dominant_plane);
  scene.Validate();
  return scene;
}

namespace builtin_internal {

void SetBuiltinVectorTextures(bool enabled) { g_vector_textures.store(enabled); }

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

void Cellular2ForTest(double x, double y, uint32_t seed, double* distance, double* id) {
  const Cell cell = Cellular2(x, y, seed);
  *distance = cell.distance;
  *id = cell.id;
}

}  // namespace builtin_internal

}  // namespace turbid
