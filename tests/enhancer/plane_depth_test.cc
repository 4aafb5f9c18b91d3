// DepthFromPlane against an independent geometry: the ray-cast z-depth of the built-in hull (a
// plane object intersected ray by ray in scenes/builtin.cc), not a depth made by DepthFromPlane.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "enhancer/blocks/plane_fit.h"
#include "scenes/builtin.h"

namespace turbid {
namespace {

TEST(DepthFromPlane, MatchesTheRayCastDepthOfTheBuiltinHull) {
  BuiltinSceneOptions so;
  so.scale = 0.25;
  const Scene hull = MakeBuiltinScene("hull", so);
  ASSERT_TRUE(hull.dominant_plane.has_value());
  // The scene's own plane, and the plane fitted to its depth.
  const Plane fitted = FitPlaneToDepth(PlaneFitOptions{}, hull.camera, hull.depth_m).plane;
  for (const Plane& plane : {*hull.dominant_plane, fitted}) {
    const cv::Mat depth = DepthFromPlane(plane, hull.camera);
    ASSERT_EQ(depth.size(), hull.depth_m.size());
    double worst = 0;
    for (int y = 0; y < depth.rows; ++y)
      for (int x = 0; x < depth.cols; ++x) {
        const float truth = hull.depth_m.at<float>(y, x);
        ASSERT_TRUE(std::isfinite(truth));
        worst = std::max<double>(worst, std::abs(depth.at<float>(y, x) - truth) / truth);
      }
    EXPECT_LE(worst, 1e-4) << "worst relative depth error";
  }
}

}  // namespace
}  // namespace turbid
