// The built-in scenes' ray-casting tests each image row's rays only against the objects that row
// can reach (scenes/builtin.cc RowObjects, issue 34 item 6): the depth of every pixel must be
// the same float as the nearest hit over all the model's objects (Object::Intersect), here
// recomputed independently, for each built-in scene at its own pose and at poses moved and turned
// so that the rocks, boxes and sphere sit at the edges of rows.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <string>

#include "scenes/builtin.h"
#include "scenes/builtin_model.h"

namespace turbid {
namespace {

using builtin_model::kNoHit;
using builtin_model::Model;
using builtin_model::SurfacePoint;

Model ModelOf(const std::string& name) {
  if (name == "hull") return builtin_model::HullModel();
  if (name == "seafloor") return builtin_model::SeafloorModel();
  return builtin_model::RoomModel();
}

// Pixels whose depth differs (bits) from the nearest hit over all objects at the pixel centre.
int DifferingDepths(const std::string& name, const Pose& pose, double scale) {
  BuiltinSceneOptions options;
  options.scale = scale;
  options.pose = pose;
  const Scene scene = MakeBuiltinScene(name, options);
  const Model model = ModelOf(name);
  const CameraIntrinsics cam = ScaleIntrinsics(model.camera, scale);
  int differing = 0;
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      const cv::Vec3d dir = pose.rotation * cam.Ray(x, y);
      double best = kNoHit;
      SurfacePoint hit;
      for (const builtin_model::Object& o : model.objects)
        best = std::min(best, o.Intersect(pose.position_m, dir, 1e-6, &hit));
      const float want = best == kNoHit ? std::nanf("") : static_cast<float>(best);
      const float got = scene.depth_m.at<float>(y, x);
      const bool same = std::isnan(want) ? std::isnan(got) : std::memcmp(&want, &got, 4) == 0;
      differing += !same;
    }
  }
  return differing;
}

TEST(BuiltinRowObjects, DepthIsTheNearestHitOverAllObjects) {
  cv::RNG rng(346);
  for (const std::string& name : BuiltinSceneNames()) {
    const Pose own = BuiltinScenePose(name);
    for (int trial = 0; trial < 4; ++trial) {
      Pose pose = own;
      if (trial > 0) {
        const cv::Vec3d turn(rng.uniform(-0.25, 0.25), rng.uniform(-0.25, 0.25),
                             rng.uniform(-0.4, 0.4));
        cv::Matx33d r;
        cv::Rodrigues(turn, r);
        pose.rotation = own.rotation * r;
        pose.position_m +=
            cv::Vec3d(rng.uniform(-0.5, 0.5), rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.5));
      }
      SCOPED_TRACE(name + ", trial " + std::to_string(trial));
      EXPECT_EQ(DifferingDepths(name, pose, name == "hull" ? 0.1 : 0.25), 0);
    }
  }
}

}  // namespace
}  // namespace turbid
