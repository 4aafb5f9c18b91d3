// The lamps' spot cut-off (light.lights[k].cutoff_angle_deg): E_L, the point form and the
// single-scatter veil all stop at the cut-off angle; 90 degrees is the plain cos^m profile.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "simulator/light.h"
#include "simulator/render.h"
#include "simulator/veil.h"
#include "tests/simulator/reference_veil.h"
#include "tests/simulator/test_scenes.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(SpotCutoff, IrradianceIsZeroBeyondTheCutoffAndUnchangedWithin) {
  const Scene plane = testing::MakePlaneScene(64, 48, 2.0, 1, 40.0);
  IrradianceOptions open, spot;
  open.lights[0].position_in_camera_m = spot.lights[0].position_in_camera_m = {0, 0, 0};
  spot.lights[0].cutoff_angle_deg = 25.0;
  const cv::Mat e_open = IrradianceMap(open, plane.camera, plane.depth_m, plane.normals, {0.5});
  const cv::Mat e_spot = IrradianceMap(spot, plane.camera, plane.depth_m, plane.normals, {0.5});
  int inside = 0, outside = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) {
      const cv::Vec3d ray = plane.camera.Ray(x, y);
      const double angle = std::acos(ray[2] / cv::norm(ray)) * 180.0 / kPi;  // lamp at the camera
      if (std::abs(angle - 25.0) < 0.01) continue;  // float rounding at the edge
      if (angle > 25.0) {
        EXPECT_EQ(e_spot.at<float>(y, x), 0.0f) << x << "," << y;
        ++outside;
      } else {
        EXPECT_EQ(e_spot.at<float>(y, x), e_open.at<float>(y, x));
        ++inside;
      }
    }
  EXPECT_GT(inside, 100);
  EXPECT_GT(outside, 100);
  // The point form agrees.
  const std::vector<double> beyond =
      IrradianceAtPoint(spot, {1.5, 0, 2}, cv::Vec3d(0, 0, -1), {0.5});
  const std::vector<double> within =
      IrradianceAtPoint(spot, {0.3, 0, 2}, cv::Vec3d(0, 0, -1), {0.5});
  EXPECT_EQ(beyond[0], 0.0);
  EXPECT_GT(within[0], 0.0);
  // Checked and read from the options.
  spot.lights[0].cutoff_angle_deg = 0.0;
  EXPECT_THROW(ThrowIfInvalid(spot, "light"), Error);
  const RenderOptions o = RenderOptionsFromJson(
      nlohmann::json::parse(R"({"light": {"lights": [{"cutoff_angle_deg": 30}]}})"));
  EXPECT_EQ(o.light.lights[0].cutoff_angle_deg, 30.0);
  EXPECT_EQ(LightOptions{}.cutoff_angle_deg, 90.0);
}

TEST(SpotCutoff, VeilHonoursTheCutoffAgainstTheReference) {
  VeilWater w;
  w.c_per_m = {0.7};
  w.b_per_m = {0.56};
  IrradianceOptions open, spot;
  spot.lights[0].cutoff_angle_deg = 20.0;
  for (const cv::Vec3d& ray : {cv::Vec3d(0, 0, 1), cv::Vec3d(0.3, 0.2, 1), cv::Vec3d(0, -0.6, 1)})
    for (double range : {1.0, 4.0, std::numeric_limits<double>::infinity()}) {
      const double fast = SingleScatterVeilAlongRay(spot, w, ray, range)[0];
      const double slow = testing::ReferenceVeil(spot, w, ray, range)[0];
      const double full = SingleScatterVeilAlongRay(open, w, ray, range)[0];
      EXPECT_LE(fast, full);  // part of every view ray lies outside a 20-degree beam
      if (slow == 0.0) {      // a ray that never enters the beam
        EXPECT_EQ(fast, 0.0) << ray;
        EXPECT_GT(full, 0.0) << ray;
        continue;
      }
      EXPECT_LT(fast, full);
      // The hard edge of the beam is a jump inside a quadrature segment: measured up to 3.6 %
      // (0.2 % without a cut-off).
      EXPECT_NEAR(fast / slow, 1.0, 0.04) << ray << " range " << range;
    }
}

}  // namespace
}  // namespace turbid
