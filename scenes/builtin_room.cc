// The built-in room scene (docs/formats.md): its textures and model.
#include <cmath>
#include <opencv2/core.hpp>

#include "scenes/builtin_model.h"

namespace turbid::builtin_model {
namespace {

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
      const bool odd =
          (static_cast<int>(std::floor(u / 0.05)) + static_cast<int>(std::floor(v / 0.05))) & 1;
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
    const bool odd =
        (static_cast<int>(std::floor(a / 0.02)) + static_cast<int>(std::floor(b / 0.03))) & 1;
    color = odd ? cv::Vec3d(0.1, 0.1, 0.1) : cv::Vec3d(0.9, 0.9, 0.9);
  }
  return color;
}

cv::Vec3d CubeTexture(const SurfacePoint& p) {
  const cv::Vec3d& q = p.local;
  const int i = static_cast<int>(std::floor(q[0] / 0.06)),
            j = static_cast<int>(std::floor(q[1] / 0.06)),
            k = static_cast<int>(std::floor(q[2] / 0.06));
  const bool odd = (i + j + k) & 1;
  const cv::Vec3d colors[4] = {
      {0.8, 0.2, 0.15}, {0.15, 0.55, 0.25}, {0.2, 0.3, 0.8}, {0.85, 0.75, 0.2}};
  const int pick = static_cast<int>(Lattice(i, j, k, 91u) * 4) & 3;
  return odd ? colors[pick] : cv::Vec3d(0.9, 0.88, 0.85);
}

}  // namespace

Model RoomModel() {
  Model model;
  model.camera = {481.20, -480.00, 319.5, 239.5, 640, 480};
  // Camera 1.3 m above the floor, yawed 18 degrees and pitched 10 degrees down.
  model.world_from_camera = RotationY(18.0 * kPi / 180) * RotationX(10.0 * kPi / 180);
  model.camera_in_world = {-0.4, 0.0, 0.3};
  const double floor_y = -1.3, ceiling_y = 1.3, left_x = -2.2, right_x = 2.4, back_z = 4.5,
               front_z = -1.5;
  model.objects.push_back(MakePlane({0, floor_y, 0}, {0, 1, 0}, {1, 0, 0}, FloorTexture));
  model.objects.push_back(
      MakePlane({0, ceiling_y, 0}, {0, -1, 0}, {1, 0, 0}, [](const SurfacePoint& p) {
        return Gray(0.82 + 0.08 * (Fbm2(p.local[0] * 4, p.local[1] * 4, 3, 75u) - 0.5));
      }));
  // Walls: texture v axis is height above the floor (plane centre sits on the floor line).
  model.objects.push_back(
      MakePlane({0, floor_y, back_z}, {0, 0, -1}, {1, 0, 0}, [](const SurfacePoint& p) {
        SurfacePoint q = p;
        q.local[1] = p.world[1] + 1.3;
        return WallTexture(q, {0.70, 0.66, 0.52}, 100u);
      }));
  model.objects.push_back(
      MakePlane({left_x, floor_y, 0}, {1, 0, 0}, {0, 0, 1}, [](const SurfacePoint& p) {
        SurfacePoint q = p;
        q.local = {p.world[2], p.world[1] + 1.3, 0};
        return WallTexture(q, {0.45, 0.58, 0.66}, 200u);
      }));
  model.objects.push_back(
      MakePlane({right_x, floor_y, 0}, {-1, 0, 0}, {0, 0, 1}, [](const SurfacePoint& p) {
        SurfacePoint q = p;
        q.local = {p.world[2], p.world[1] + 1.3, 0};
        return WallTexture(q, {0.66, 0.50, 0.45}, 300u);
      }));
  model.objects.push_back(
      MakePlane({0, floor_y, front_z}, {0, 0, 1}, {1, 0, 0}, [](const SurfacePoint& p) {
        SurfacePoint q = p;
        q.local = {p.world[0], p.world[1] + 1.3, 0};
        return WallTexture(q, {0.60, 0.60, 0.60}, 400u);
      }));
  const cv::Vec3d up{0, 1, 0};
  model.objects.push_back(MakeBox({0.9, floor_y + 0.25, 2.8}, up, {1, 0, 0}, 0.35,
                                  {0.35, 0.25, 0.25}, CardboardTexture));
  model.objects.push_back(
      MakeBox({-0.9, floor_y + 0.2, 2.4}, up, {1, 0, 0}, -0.6, {0.2, 0.2, 0.2}, CubeTexture));
  model.objects.push_back(MakeSphere({0.1, floor_y + 0.15, 1.7}, 0.15, [](const SurfacePoint& p) {
    const double band =
        std::sin(p.local[1] / 0.15 * 3.0 * kPi + 4.0 * std::atan2(p.local[2], p.local[0]));
    return band > 0 ? cv::Vec3d(0.85, 0.25, 0.2) : cv::Vec3d(0.9, 0.85, 0.3);
  }));
  return model;
}

}  // namespace turbid::builtin_model
