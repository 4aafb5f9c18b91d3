// The built-in hull's clean image, bit for bit, against the pre-optimisation implementation.
//
// Regression tables are reproduced bit for bit from the built-in scenes, so the hull's faster
// texture (AVX2 fractal noise four points at a time, hypot only near rivets and feature points,
// one batch of sample rays per row) must give the same bytes. `Reference...` below is a copy of
// scenes/builtin.cc as of commit 3ef7f8e (before that work): the hull's texture, its noise and
// cellular functions, its plane and the supersampled albedo loop of MakeBuiltinScene.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "scenes/builtin.h"
#include "scenes/builtin_internal.h"

namespace turbid {
namespace {

// --- Copy of 3ef7f8e's scenes/builtin.cc (hull only). ---------------------------------------
constexpr double kPi = 3.14159265358979323846;

uint32_t ReferenceMix(uint32_t h) {
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

double ReferenceLattice(int64_t x, int64_t y, int64_t z, uint32_t seed) {
  const uint32_t h =
      ReferenceMix(static_cast<uint32_t>(x) * 0x8da6b343u + static_cast<uint32_t>(y) * 0xd8163841u +
                   static_cast<uint32_t>(z) * 0xcb1ab31fu + seed * 0x9e3779b9u);
  return h * (1.0 / 4294967296.0);
}

double ReferenceFade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
double ReferenceLerp(double a, double b, double t) { return a + (b - a) * t; }
double ReferenceClamp01(double v) { return std::min(1.0, std::max(0.0, v)); }
double ReferenceSmoothStep(double e0, double e1, double x) {
  const double t = ReferenceClamp01((x - e0) / (e1 - e0));
  return t * t * (3.0 - 2.0 * t);
}

double ReferenceNoise2(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double tx = ReferenceFade(x - fx), ty = ReferenceFade(y - fy);
  const double a =
      ReferenceLerp(ReferenceLattice(ix, iy, 0, seed), ReferenceLattice(ix + 1, iy, 0, seed), tx);
  const double b = ReferenceLerp(ReferenceLattice(ix, iy + 1, 0, seed),
                                 ReferenceLattice(ix + 1, iy + 1, 0, seed), tx);
  return ReferenceLerp(a, b, ty);
}

double ReferenceFbm2(double x, double y, int octaves, uint32_t seed) {
  double sum = 0.0, amplitude = 1.0, norm = 0.0;
  for (int i = 0; i < octaves; ++i) {
    sum += amplitude * ReferenceNoise2(x, y, seed + 101u * i);
    norm += amplitude;
    x = x * 2.03 + 17.1;
    y = y * 2.03 - 5.3;
    amplitude *= 0.5;
  }
  return sum / norm;
}

struct ReferenceCell {
  double distance;
  double id;
};
ReferenceCell ReferenceCellular2(double x, double y, uint32_t seed) {
  const auto ix = static_cast<int64_t>(std::floor(x)), iy = static_cast<int64_t>(std::floor(y));
  ReferenceCell best{1e9, 0.0};
  for (int64_t j = iy - 1; j <= iy + 1; ++j) {
    for (int64_t i = ix - 1; i <= ix + 1; ++i) {
      const double px = i + ReferenceLattice(i, j, 1, seed),
                   py = j + ReferenceLattice(i, j, 2, seed);
      const double d = std::hypot(px - x, py - y);
      if (d < best.distance) best = {d, ReferenceLattice(i, j, 3, seed)};
    }
  }
  return best;
}

double ReferenceHullTexture(double u, double v) {
  double value = 0.42 + 0.16 * (ReferenceFbm2(u * 3.0, v * 3.0, 5, 11u) - 0.5) +
                 0.10 * (ReferenceFbm2(u * 45.0, v * 45.0, 3, 12u) - 0.5);
  value -= 0.10 * ReferenceSmoothStep(0.55, 0.8, ReferenceFbm2(u * 25.0, v * 1.2, 3, 13u));
  const double strake = std::floor(v / 0.9);
  const double dv = std::abs(v - std::round(v / 0.9) * 0.9);
  const double stagger = std::fmod(std::abs(strake), 2.0) * 0.7;
  const double du = std::abs((u - stagger) - std::round((u - stagger) / 1.4) * 1.4);
  const double seam = std::min(dv, du);
  const double along = dv < du ? u : v;
  if (seam < 0.014) {
    value = 0.60 + 0.10 * std::sin(2.0 * kPi * along / 0.007) +
            0.08 * (ReferenceNoise2(u * 300.0, v * 300.0, 14u) - 0.5);
  } else if (seam < 0.022) {
    value = 0.22 + 0.05 * ReferenceNoise2(u * 200.0, v * 200.0, 15u);
  }
  auto rivet = [&](double across, double along_pos, uint32_t seed) {
    const double k = std::round(along_pos / 0.09);
    const double r = std::hypot(across, along_pos - k * 0.09);
    if (r < 0.011 &&
        ReferenceLattice(static_cast<int64_t>(k), static_cast<int64_t>(strake), 5, seed) > 0.12) {
      const double x = r / 0.011;
      value = x > 0.8 ? 0.15 : 0.78 - 0.35 * x * x;
    }
  };
  const double v_seam = std::round(v / 0.9) * 0.9;
  rivet(std::abs(v - v_seam) - 0.06, u, 21u);
  const double u_seam = std::round((u - stagger) / 1.4) * 1.4 + stagger;
  rivet(std::abs(u - u_seam) - 0.06, v, 22u);
  const double patch = ReferenceFbm2(u * 1.3 + 3.0, v * 1.3 - 2.0, 4, 16u);
  const double coverage = ReferenceSmoothStep(0.56, 0.62, patch);
  if (coverage > 0.0) {
    const ReferenceCell cell = ReferenceCellular2(u / 0.025, v / 0.025, 17u);
    double fouling = 0.20 + 0.12 * ReferenceFbm2(u * 80.0, v * 80.0, 2, 18u);
    const double radius = 0.25 + 0.2 * cell.id;
    if (cell.distance < radius) {
      const double x = cell.distance / radius;
      fouling = x > 0.55 ? 0.70 - 0.25 * x : 0.12;
    }
    value = ReferenceLerp(value, fouling, coverage);
  }
  return value;
}

cv::Vec3d ReferenceNormalized(const cv::Vec3d& v) { return v / cv::norm(v); }

// The hull's clean image (the plane, its texture, clamping, supersampling) as 3ef7f8e made it.
cv::Mat ReferenceHullImage(double scale, int ss) {
  const CameraIntrinsics cam = ScaleIntrinsics(BuiltinSceneCamera("hull"), scale);
  const cv::Matx33d rx(1, 0, 0, 0, std::cos(-12.0 * kPi / 180), -std::sin(-12.0 * kPi / 180), 0,
                       std::sin(-12.0 * kPi / 180), std::cos(-12.0 * kPi / 180));
  const double ay = 35.0 * kPi / 180;
  const cv::Matx33d ry(std::cos(ay), 0, std::sin(ay), 0, 1, 0, -std::sin(ay), 0, std::cos(ay));
  const cv::Vec3d normal = rx * ry * cv::Vec3d(0, 0, -1);
  const cv::Vec3d center{0, 0, 2.2}, u_hint{1, 0, 0};
  const cv::Vec3d axis_w = ReferenceNormalized(normal);
  const cv::Vec3d axis_u = ReferenceNormalized(u_hint - axis_w * u_hint.dot(axis_w));
  const cv::Vec3d axis_v = axis_w.cross(axis_u);
  const cv::Matx33d rotation = cv::Matx33d::eye();
  const cv::Vec3d origin{0, 0, 0};
  auto albedo = [&](const cv::Vec3d& dir) {
    double value = 0.05;  // background
    const double denom = axis_w.dot(dir);
    if (std::abs(denom) >= 1e-12) {
      const double t = axis_w.dot(center - origin) / denom;
      if (t > 1e-6) {
        const cv::Vec3d world = origin + dir * t;
        const cv::Vec3d rel = world - center;
        value = ReferenceHullTexture(rel.dot(axis_u), rel.dot(axis_v));
      }
    }
    const double c = std::clamp(value, 0.05, 0.95);
    return cv::Vec3d(c, c, c);
  };
  cv::Mat image(cam.height, cam.width, CV_32FC1);
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      cv::Vec3d sum{0, 0, 0};
      for (int j = 0; j < ss; ++j) {
        for (int i = 0; i < ss; ++i) {
          const double u = x + (i + 0.5) / ss - 0.5, v = y + (j + 0.5) / ss - 0.5;
          sum += albedo(rotation * cam.Ray(u, v));
        }
      }
      sum /= static_cast<double>(ss * ss);
      image.at<float>(y, x) = static_cast<float>(sum[2]);
    }
  }
  return image;
}
// --- End of the copy. -------------------------------------------------------------------------

int DifferingPixels(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return -1;
  int count = 0;
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x)
      if (std::memcmp(&a.at<float>(y, x), &b.at<float>(y, x), sizeof(float)) != 0) ++count;
  return count;
}

struct VectorTextures {  // switches the vectorised path for one scope
  explicit VectorTextures(bool on) { builtin_internal::SetBuiltinVectorTextures(on); }
  ~VectorTextures() { builtin_internal::SetBuiltinVectorTextures(true); }
};

// The fractal sums as doubles (the image, in float, hides most last-bit differences): random
// points on and far off the plate, both paths, against the reference's Fbm2 calls. Points beyond
// +-2^31 lattice cells (u ~ 1e7 m) take the scalar code inside the vector path.
TEST(BuiltinHullReference, FractalSumsAreBitIdentical) {
  cv::RNG rng(2026);
  std::vector<double> u, v;
  for (int k = 0; k < 20000; ++k) {
    const double range = k < 15000 ? 4.0 : k < 19000 ? 1e4 : 3e8;
    u.push_back(rng.uniform(-range, range));
    v.push_back(rng.uniform(-range, range));
  }
  for (double w : {0.0, -0.0, 1e-300, -1e-300, 0.5, -0.5, 1.0 / 3.0}) {  // edges, odd count
    u.push_back(w);
    v.push_back(-w);
  }
  const int n = static_cast<int>(u.size());
  for (bool vector : {true, false}) {
    SCOPED_TRACE(vector ? "vector" : "scalar");
    const VectorTextures mode(vector);
    std::vector<double> got(4 * static_cast<size_t>(n));
    builtin_internal::BuiltinHullNoiseForTest(u.data(), v.data(), n, got.data());
    int differing = 0;
    for (int k = 0; k < n; ++k) {
      const double want[4] = {ReferenceFbm2(u[k] * 3.0, v[k] * 3.0, 5, 11u),
                              ReferenceFbm2(u[k] * 45.0, v[k] * 45.0, 3, 12u),
                              ReferenceFbm2(u[k] * 25.0, v[k] * 1.2, 3, 13u),
                              ReferenceFbm2(u[k] * 1.3 + 3.0, v[k] * 1.3 - 2.0, 4, 16u)};
      if (std::memcmp(want, &got[4 * static_cast<size_t>(k)], sizeof(want)) != 0) ++differing;
    }
    EXPECT_EQ(differing, 0) << "of " << n;
  }
}

// The cellular noise (the hull's barnacles and the seafloor's pebbles use it) takes std::hypot only
// for the feature points whose squared distance is within 1e-9 of the least: the same nearest
// distance and id as the reference's nine hypot calls, on random points, points on cell edges and
// on feature points themselves, points midway between two feature points (near ties),
// and far from the origin.
TEST(BuiltinHullReference, CellularNoiseIsBitIdentical) {
  cv::RNG rng(17);
  std::vector<std::pair<double, double>> points;
  for (int k = 0; k < 40000; ++k) {
    const double range = k < 30000 ? 200.0 : 1e9;
    points.emplace_back(rng.uniform(-range, range), rng.uniform(-range, range));
  }
  for (int i = -3; i <= 3; ++i) {
    for (int j = -3; j <= 3; ++j) {
      points.emplace_back(i, j);
      points.emplace_back(i + 0.5, j);
      // The feature points of cell (i, j) and the midpoint towards cell (i + 1, j)'s.
      const double px = i + ReferenceLattice(i, j, 1, 36u), py = j + ReferenceLattice(i, j, 2, 36u);
      const double qx = i + 1 + ReferenceLattice(i + 1, j, 1, 36u);
      const double qy = j + ReferenceLattice(i + 1, j, 2, 36u);
      points.emplace_back(px, py);
      points.emplace_back(0.5 * (px + qx), 0.5 * (py + qy));
    }
  }
  int differing = 0;
  for (const uint32_t seed : {17u, 36u}) {
    for (const auto& [x, y] : points) {
      const ReferenceCell want = ReferenceCellular2(x, y, seed);
      double distance = 0.0, id = 0.0;
      builtin_internal::Cellular2ForTest(x, y, seed, &distance, &id);
      if (std::memcmp(&want.distance, &distance, sizeof(double)) != 0 ||
          std::memcmp(&want.id, &id, sizeof(double)) != 0) {
        ++differing;
      }
    }
  }
  EXPECT_EQ(differing, 0) << "of " << 2 * points.size();
}

// Native size (the one sweeps use), half and quarter size, 1 and 3 samples per side; the
// vectorised texture path (the default) and the scalar one.
TEST(BuiltinHullReference, SameBytesAsThePreOptimisationCode) {
  struct Case {
    double scale;
    int ss;
    bool vector;
  };
  const Case cases[] = {{1.0, 2, true},  {0.5, 2, true},  {0.25, 2, true},
                        {0.23, 3, true}, {0.3, 2, false}, {0.25, 1, false}};
  for (const Case& c : cases) {
    SCOPED_TRACE(::testing::Message() << "scale " << c.scale << ", supersampling " << c.ss
                                      << (c.vector ? ", vector" : ", scalar"));
    const VectorTextures mode(c.vector);
    const Scene scene =
        MakeBuiltinScene("hull", {.scale = c.scale, .supersampling = c.ss, .pose = {}});
    const cv::Mat expected = ReferenceHullImage(c.scale, c.ss);
    EXPECT_EQ(DifferingPixels(scene.image, expected), 0);
  }
}

}  // namespace
}  // namespace turbid
