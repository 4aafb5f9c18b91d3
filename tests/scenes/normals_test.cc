// Normals from depth against exact geometry: planes, steps, holes, the ray-cast built-ins.
#include "scenes/normals.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/error.h"
#include "scenes/builtin.h"

namespace turbid {
namespace {

const float kNan = std::numeric_limits<float>::quiet_NaN();

CameraIntrinsics SmallCamera() { return {100.0, 100.0, 31.5, 23.5, 64, 48}; }

// Closed-form depth of plane n.X + d = 0 at every pixel.
cv::Mat PlaneDepth(const CameraIntrinsics& camera, const Plane& plane) {
  cv::Mat depth(camera.height, camera.width, CV_32FC1);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x)
      depth.at<float>(y, x) =
          static_cast<float>(-plane.offset_m / plane.normal.dot(camera.Ray(x, y)));
  return depth;
}

double AngleDeg(const cv::Vec3f& a, const cv::Vec3d& b) {
  return std::acos(std::clamp(cv::Vec3d(a).dot(b), -1.0, 1.0)) * 180.0 / M_PI;
}

TEST(NormalsFromDepth, DefaultOptionsPassCheck) {
  std::string why;
  EXPECT_TRUE(NormalsFromDepthOptions{}.Check(&why)) << why;
  NormalsFromDepthOptions bad;
  bad.max_relative_jump = 0.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(NormalsFromDepth(SmallCamera(), cv::Mat(48, 64, CV_32FC1, 1.0f), bad), Error);
  EXPECT_THROW(NormalsFromDepth(SmallCamera(), cv::Mat(48, 64, CV_64FC1, 1.0)), Error);
}

TEST(NormalsFromDepth, TiltedPlaneGivesItsNormalEverywhere) {
  for (double fy_sign : {1.0, -1.0}) {  // -1: ICL-NUIM's negative fy
    CameraIntrinsics camera = SmallCamera();
    camera.fy *= fy_sign;
    const cv::Vec3d n = cv::normalize(cv::Vec3d(0.3, -0.4, -0.8));
    const Plane plane{n, 2.0};
    const cv::Mat normals = NormalsFromDepth(camera, PlaneDepth(camera, plane));
    for (int y = 0; y < camera.height; ++y)
      for (int x = 0; x < camera.width; ++x)
        ASSERT_LT(AngleDeg(normals.at<cv::Vec3f>(y, x), n), 0.05) << x << "," << y;
  }
}

// Two fronto-parallel planes at 1 m and 2 m, split at a column: the normals on both sides of the
// step stay (0, 0, -1) instead of tilting across the jump.
TEST(NormalsFromDepth, DepthStepDoesNotBleed) {
  const CameraIntrinsics camera = SmallCamera();
  cv::Mat depth(camera.height, camera.width, CV_32FC1, 1.0f);
  depth(cv::Rect(32, 0, 32, camera.height)).setTo(2.0f);
  const cv::Mat normals = NormalsFromDepth(camera, depth);
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x)
      ASSERT_LT(AngleDeg(normals.at<cv::Vec3f>(y, x), {0, 0, -1}), 1e-3) << x << "," << y;
}

TEST(NormalsFromDepth, HolesGiveNanOnlyWhereUndefined) {
  const CameraIntrinsics camera = SmallCamera();
  cv::Mat depth(camera.height, camera.width, CV_32FC1, 1.5f);
  depth.at<float>(10, 10) = kNan;  // a hole: its neighbours use the other side
  depth.at<float>(20, 20) = 0.0f;  // 0 = invalid too
  depth.row(30).setTo(kNan);       // row 31 sees no upper neighbour, uses the lower one
  depth.row(32).setTo(kNan);       // row 31 now has neither: undefined
  const cv::Mat normals = NormalsFromDepth(camera, depth);
  auto is_nan = [&](int x, int y) { return std::isnan(normals.at<cv::Vec3f>(y, x)[0]); };
  EXPECT_TRUE(is_nan(10, 10));
  EXPECT_TRUE(is_nan(20, 20));
  EXPECT_FALSE(is_nan(11, 10));
  EXPECT_FALSE(is_nan(10, 11));
  EXPECT_FALSE(is_nan(5, 29));
  EXPECT_TRUE(is_nan(5, 31)) << "neither vertical neighbour valid";
  EXPECT_LT(AngleDeg(normals.at<cv::Vec3f>(10, 11), {0, 0, -1}), 1e-3);
  // Isolated valid pixel.
  cv::Mat lonely(camera.height, camera.width, CV_32FC1, kNan);
  lonely.at<float>(5, 5) = 1.0f;
  EXPECT_TRUE(std::isnan(NormalsFromDepth(camera, lonely).at<cv::Vec3f>(5, 5)[0]));
}

// On the ray-cast room (fy < 0, boxes, a ball), normals from the exact depth agree with the
// ray-cast normals except in the one-pixel bands along concave corners and object edges (where the
// depth jump is too small to reject) and on the small ball (curvature within a pixel).
TEST(NormalsFromDepth, AgreesWithRayCastNormalsOnBuiltinScenes) {
  for (const char* name : {"room", "seafloor"}) {
    SCOPED_TRACE(name);
    const Scene scene = MakeBuiltinScene(name, {.scale = 0.5, .supersampling = 1, .pose = {}});
    const cv::Mat normals = NormalsFromDepth(scene.camera, scene.depth_m);
    int close = 0, defined = 0;
    for (int y = 0; y < scene.height(); ++y) {
      for (int x = 0; x < scene.width(); ++x) {
        const cv::Vec3f n = normals.at<cv::Vec3f>(y, x);
        if (std::isnan(n[0])) continue;
        ++defined;
        ASSERT_NEAR(cv::norm(n), 1.0, 1e-5);
        if (AngleDeg(n, cv::Vec3d(scene.normals.at<cv::Vec3f>(y, x))) < 3.0) ++close;
      }
    }
    EXPECT_GT(defined, 0.999 * scene.width() * scene.height());
    EXPECT_GT(close, 0.95 * defined);
  }
}

}  // namespace
}  // namespace turbid
