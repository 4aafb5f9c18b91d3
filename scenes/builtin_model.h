// Internals of the built-in scenes (scenes/builtin*.cc): the deterministic noise the textures are
// made of, the analytic objects a scene is built from, and the three models. Not part of the API.
// Split from builtin.cc: builtin.cc ray-casts a model into a Scene; builtin_hull.cc,
// builtin_seafloor.cc and builtin_room.cc each build one model with its textures.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <opencv2/core.hpp>
#include <vector>

#include "scenes/scene.h"

namespace turbid::builtin_model {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNoHit = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------
// Deterministic hash-based noise. Integer hashing keeps textures identical on every run and
// thread count; value noise with a quintic fade is smooth enough to give stable gradients for
// feature detectors.

inline uint32_t Mix(uint32_t h) {
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

inline double Lattice(int64_t x, int64_t y, int64_t z, uint32_t seed) {
  // One avalanche round over a linear combination of the coordinates: the mixer's full
  // avalanche hides the combination's correlations.
  const uint32_t h =
      Mix(static_cast<uint32_t>(x) * 0x8da6b343u + static_cast<uint32_t>(y) * 0xd8163841u +
          static_cast<uint32_t>(z) * 0xcb1ab31fu + seed * 0x9e3779b9u);
  return h * (1.0 / 4294967296.0);
}

inline double Fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
inline double Lerp(double a, double b, double t) { return a + (b - a) * t; }
inline double Clamp01(double v) { return std::min(1.0, std::max(0.0, v)); }
inline double SmoothStep(double e0, double e1, double x) {
  const double t = Clamp01((x - e0) / (e1 - e0));
  return t * t * (3.0 - 2.0 * t);
}

// Value noise in [0, 1].
inline double Noise2(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double tx = Fade(x - fx), ty = Fade(y - fy);
  const double a = Lerp(Lattice(ix, iy, 0, seed), Lattice(ix + 1, iy, 0, seed), tx);
  const double b = Lerp(Lattice(ix, iy + 1, 0, seed), Lattice(ix + 1, iy + 1, 0, seed), tx);
  return Lerp(a, b, ty);
}

inline double Noise3(double x, double y, double z, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy),
             iz = static_cast<int64_t>(fz);
  const double tx = Fade(x - fx), ty = Fade(y - fy), tz = Fade(z - fz);
  double layer[2];
  for (int k = 0; k < 2; ++k) {
    const double a = Lerp(Lattice(ix, iy, iz + k, seed), Lattice(ix + 1, iy, iz + k, seed), tx);
    const double b =
        Lerp(Lattice(ix, iy + 1, iz + k, seed), Lattice(ix + 1, iy + 1, iz + k, seed), tx);
    layer[k] = Lerp(a, b, ty);
  }
  return Lerp(layer[0], layer[1], tz);
}

// Fractal sum of `octaves` noise layers (frequency x2, amplitude x0.5), normalised to [0, 1].
inline double Fbm2(double x, double y, int octaves, uint32_t seed) {
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

inline double Fbm3(const cv::Vec3d& p, int octaves, uint32_t seed) {
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
//
// CellularNearest is that second step, given the 3 x 3 candidates' offsets dx, dy from the point,
// their squared distances d2 (element c at [c * stride]; c = 3 * row + column around the cell
// (ix, iy)) and the least d2; shared with the AVX2 version (scenes/builtin_seafloor.cc).
inline Cell CellularNearest(int64_t ix, int64_t iy, const double* dx, const double* dy,
                            const double* d2, int stride, double least, uint32_t seed) {
  const double bound = least * (1.0 + 1e-9) + 1e-300;
  Cell best{1e9, 0.0};
  int best_c = -1;
  for (int c = 0; c < 9; ++c) {
    if (!(d2[c * stride] <= bound)) continue;
    const double d = std::hypot(dx[c * stride], dy[c * stride]);
    if (d < best.distance) {
      best.distance = d;
      best_c = c;
    }
  }
  if (best_c >= 0) best.id = Lattice(ix - 1 + best_c % 3, iy - 1 + best_c / 3, 3, seed);
  return best;
}

inline Cell Cellular2(double x, double y, uint32_t seed) {
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
  return CellularNearest(ix, iy, dx, dy, d2, 1, least, seed);
}

inline cv::Vec3d Gray(double v) { return {v, v, v}; }
inline cv::Vec3d MixColor(const cv::Vec3d& a, const cv::Vec3d& b, double t) {
  return a + (b - a) * t;
}

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
// A std::function so that a batch can carry its object's parameters (the rocks' tint and seed).
using TextureBatch = std::function<void(const SurfacePoint* points, int n, cv::Vec3d* rgb)>;

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
  TextureBatch texture_batch;

  // Ray parameter of the first hit with t > t_min, or kNoHit; fills the hit's normal and local
  // coordinates. A hit at t >= t_max counts as none (kNoHit, *hit untouched).
  double Intersect(const cv::Vec3d& origin, const cv::Vec3d& dir, double t_min, SurfacePoint* hit,
                   double t_max = kNoHit) const {
    switch (kind) {
      case Kind::kPlane: {
        const double denom = axis_w.dot(dir);
        if (std::abs(denom) < 1e-12) return kNoHit;
        const double t = axis_w.dot(center - origin) / denom;
        if (!(t > t_min) || !(t < t_max)) return kNoHit;
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
        if (!(t > t_min) || !(t < t_max)) return kNoHit;
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
        if (t_near > t_far || !(t_near > t_min) || !(t_near < t_max))
          return kNoHit;  // camera is never inside a box
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

inline cv::Vec3d Normalized(const cv::Vec3d& v) { return v / cv::norm(v); }

// Plane through `point` with unit normal `normal`; texture axes: u orthogonal to `normal` and as
// close as possible to `u_hint`, v = w x u.
inline Object MakePlane(const cv::Vec3d& point, const cv::Vec3d& normal, const cv::Vec3d& u_hint,
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

inline Object MakeSphere(const cv::Vec3d& center, double radius, Texture texture) {
  Object o;
  o.kind = Object::Kind::kSphere;
  o.center = center;
  o.radius = radius;
  o.texture = std::move(texture);
  return o;
}

// Box with axis w along `up`, rotated by `yaw_rad` about it from the u hint.
inline Object MakeBox(const cv::Vec3d& center, const cv::Vec3d& up, const cv::Vec3d& u_hint,
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

inline cv::Matx33d RotationX(double a) {
  return {1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a)};
}
inline cv::Matx33d RotationY(double a) {
  return {std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)};
}

// Whether the textures that have a vectorised version use it (builtin_internal::
// SetBuiltinVectorTextures; default true).
bool BuiltinVectorTexturesEnabled();

// The three models, at their native camera size.
Model HullModel();
Model SeafloorModel();
Model RoomModel();

}  // namespace turbid::builtin_model
