// Procedural scenes against closed forms: plane depth, normals, back-projection, DVL hits.
#include "scenes/builtin.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace turbid {
namespace {

double PlaneResidual(const Plane& plane, const cv::Vec3d& point) {
  return plane.normal.dot(point) + plane.offset_m;
}

TEST(BuiltinScene, DefaultOptionsPassCheck) {
  std::string why;
  EXPECT_TRUE(BuiltinSceneOptions{}.Check(&why)) << why;
  BuiltinSceneOptions bad;
  bad.scale = 0.0;
  EXPECT_FALSE(bad.Check(&why));
  bad.scale = 1.5;
  EXPECT_FALSE(bad.Check(&why));
  bad.scale = std::nan("");
  EXPECT_FALSE(bad.Check(&why));
  bad = {};
  bad.supersampling = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(MakeBuiltinScene("hull", bad), Error);
}

TEST(BuiltinScene, UnknownNameThrowsWithTheName) {
  try {
    MakeBuiltinScene("reef");
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("reef"), std::string::npos) << e.what();
  }
}

TEST(BuiltinScene, NativeSizesAndIntrinsics) {
  EXPECT_EQ(BuiltinSceneNames(), (std::vector<std::string>{"hull", "seafloor", "room"}));
  const CameraIntrinsics hull = BuiltinSceneCamera("hull");
  EXPECT_EQ(hull.width, 1360);
  EXPECT_EQ(hull.height, 1024);
  const CameraIntrinsics room = BuiltinSceneCamera("room");
  EXPECT_EQ(room.width, 640);
  EXPECT_EQ(room.height, 480);
  EXPECT_DOUBLE_EQ(room.fx, 481.20);
  EXPECT_DOUBLE_EQ(room.fy, -480.00);
  EXPECT_DOUBLE_EQ(room.cx, 319.5);
  EXPECT_DOUBLE_EQ(room.cy, 239.5);
  const CameraIntrinsics half = ScaleIntrinsics(room, 0.5);
  EXPECT_EQ(half.width, 320);
  EXPECT_EQ(half.height, 240);
  EXPECT_DOUBLE_EQ(half.fx, 240.6);
  EXPECT_DOUBLE_EQ(half.fy, -240.0);
  EXPECT_DOUBLE_EQ(half.cx, 159.5);  // pixel centres: (319.5 + 0.5) / 2 - 0.5
  EXPECT_DOUBLE_EQ(half.cy, 119.5);
}

// Every scene at test scale: valid, typed, albedo not saturated, unit normals facing the camera.
TEST(BuiltinScene, AllScenesAreConsistent) {
  for (const std::string& name : BuiltinSceneNames()) {
    SCOPED_TRACE(name);
    const Scene scene = MakeBuiltinScene(name, {.scale = 0.25});
    EXPECT_NO_THROW(scene.Validate());
    EXPECT_EQ(scene.name, name);
    EXPECT_EQ(scene.channels(), name == "hull" ? 1 : 3);
    EXPECT_EQ(scene.width(), scene.camera.width);
    EXPECT_EQ(scene.height(), scene.camera.height);
    double lo, hi;
    cv::minMaxLoc(scene.image.reshape(1), &lo, &hi);
    EXPECT_GE(lo, 0.05 - 1e-6);
    EXPECT_LE(hi, 0.95 + 1e-6);
    EXPECT_GT(hi - lo, 0.5) << "texture contrast too low";
    int valid = 0;
    for (int y = 0; y < scene.height(); ++y) {
      for (int x = 0; x < scene.width(); ++x) {
        const float z = scene.depth_m.at<float>(y, x);
        if (std::isnan(z)) continue;
        ++valid;
        const cv::Vec3d n(scene.normals.at<cv::Vec3f>(y, x));
        ASSERT_NEAR(cv::norm(n), 1.0, 1e-5);
        ASSERT_LT(n.dot(scene.camera.Ray(x, y)), 0.0) << "normal faces away at " << x << "," << y;
      }
    }
    EXPECT_EQ(valid, scene.width() * scene.height()) << "built-in scenes have no holes";
    ASSERT_TRUE(scene.dominant_plane.has_value());
    EXPECT_NEAR(cv::norm(scene.dominant_plane->normal), 1.0, 1e-12);
    EXPECT_GT(scene.dominant_plane->offset_m, 0.0);
    EXPECT_TRUE(scene.input_hashes.empty());
  }
}

// Hull: one plane, so depth, normal and back-projection have closed forms at every pixel.
TEST(BuiltinScene, HullDepthIsTheClosedFormPlaneDepth) {
  const Scene scene = MakeBuiltinScene("hull", {.scale = 0.2});
  ASSERT_TRUE(scene.dominant_plane);
  const Plane& plane = *scene.dominant_plane;
  // The plate: 2.2 m ahead on the optical axis, normal = Rx(-12 deg) Ry(35 deg) (0, 0, -1).
  const double a = 35.0 * M_PI / 180, b = -12.0 * M_PI / 180;
  const cv::Vec3d ry(-std::sin(a), 0.0, -std::cos(a));
  const cv::Vec3d expected_normal(ry[0], std::cos(b) * ry[1] - std::sin(b) * ry[2],
                                  std::sin(b) * ry[1] + std::cos(b) * ry[2]);
  EXPECT_NEAR(cv::norm(plane.normal - expected_normal), 0.0, 1e-12);
  EXPECT_NEAR(plane.offset_m, -expected_normal[2] * 2.2, 1e-12);
  float z_min = 1e9f, z_max = 0.0f;
  for (int y = 0; y < scene.height(); ++y) {
    for (int x = 0; x < scene.width(); ++x) {
      const cv::Vec3d ray = scene.camera.Ray(x, y);
      const double z_closed = -plane.offset_m / plane.normal.dot(ray);
      const float z = scene.depth_m.at<float>(y, x);
      ASSERT_NEAR(z, z_closed, 1e-6 * z_closed);
      const cv::Vec3d point = scene.camera.BackProject(x, y, z);
      ASSERT_NEAR(PlaneResidual(plane, point), 0.0, 1e-6);
      const cv::Vec3d n(scene.normals.at<cv::Vec3f>(y, x));
      ASSERT_NEAR(cv::norm(n - plane.normal), 0.0, 1e-6);
      z_min = std::min(z_min, z);
      z_max = std::max(z_max, z);
    }
  }
  EXPECT_GT(z_min, 1.4f);
  EXPECT_LT(z_max, 3.5f);
  EXPECT_GT(z_max - z_min, 1.0f) << "the plate must be oblique";
}

// Room: fy < 0 (ICL-NUIM). The floor lies below the camera, so in the camera frame (y up) the
// bottom image rows back-project to points with y < 0, and every floor/wall pixel's
// back-projection lies on its plane.
TEST(BuiltinScene, RoomBackProjectionHonoursNegativeFy) {
  const Scene scene = MakeBuiltinScene("room", {.scale = 0.25});
  ASSERT_LT(scene.camera.fy, 0.0);
  const cv::Vec3d bottom = scene.camera.BackProject(scene.width() / 2, scene.height() - 1,
                                                    scene.depth_m.at<float>(scene.height() - 1, scene.width() / 2));
  const cv::Vec3d top = scene.camera.BackProject(scene.width() / 2, 0, scene.depth_m.at<float>(0, scene.width() / 2));
  EXPECT_LT(bottom[1], 0.0);
  EXPECT_GT(top[1], 0.0);
  // Pixels whose normal equals the dominant plane's normal (and which lie on it) must be many,
  // and their depth must match the closed form.
  const Plane& plane = *scene.dominant_plane;
  int on_plane = 0;
  for (int y = 0; y < scene.height(); ++y) {
    for (int x = 0; x < scene.width(); ++x) {
      const cv::Vec3d n(scene.normals.at<cv::Vec3f>(y, x));
      const cv::Vec3d point = scene.camera.BackProject(x, y, scene.depth_m.at<float>(y, x));
      if (cv::norm(n - plane.normal) > 1e-5 || std::abs(PlaneResidual(plane, point)) > 1e-4) continue;
      ++on_plane;
      const double z_closed = -plane.offset_m / plane.normal.dot(scene.camera.Ray(x, y));
      ASSERT_NEAR(scene.depth_m.at<float>(y, x), z_closed, 1e-6 * z_closed);
    }
  }
  EXPECT_GT(on_plane, scene.width() * scene.height() / 5);
}

// Every seafloor pixel lies on the seabed plane or on a rock (whose normal then differs).
TEST(BuiltinScene, SeafloorHasRocksAboveTheSeabed) {
  const Scene scene = MakeBuiltinScene("seafloor", {.scale = 0.25});
  const Plane& plane = *scene.dominant_plane;
  int seabed = 0, rock = 0;
  for (int y = 0; y < scene.height(); ++y) {
    for (int x = 0; x < scene.width(); ++x) {
      const cv::Vec3d point = scene.camera.BackProject(x, y, scene.depth_m.at<float>(y, x));
      const double residual = PlaneResidual(plane, point);
      if (std::abs(residual) < 1e-4) {
        ++seabed;
      } else {
        ++rock;
        // A rock occludes the seabed: it is between the camera and the plane (residual > 0 means
        // on the camera's side).
        ASSERT_GT(residual, 0.0) << x << "," << y;
      }
    }
  }
  EXPECT_GT(rock, scene.width() * scene.height() / 50);
  EXPECT_GT(seabed, scene.width() * scene.height() / 2);
}

TEST(BuiltinScene, DvlBeamsHitTheDominantPlaneAtThirtyDegrees) {
  for (const std::string& name : BuiltinSceneNames()) {
    SCOPED_TRACE(name);
    const Scene scene = MakeBuiltinScene(name, {.scale = 0.1});
    ASSERT_EQ(scene.dvl_points_in_camera.size(), 4u);
    for (const cv::Vec3d& p : scene.dvl_points_in_camera) {
      EXPECT_NEAR(PlaneResidual(*scene.dominant_plane, p), 0.0, 1e-9);
      EXPECT_NEAR(std::acos(p[2] / cv::norm(p)), kBuiltinDvlBeamHalfAngleRad, 1e-9);
      EXPECT_GT(p[2], 0.0);
    }
  }
  // Closed form: a fronto-parallel plane at 2 m gives hits at z = 2, radius 2 tan 30.
  const std::vector<cv::Vec3d> hits = DvlBeamHits(Plane{{0, 0, -1}, 2.0});
  ASSERT_EQ(hits.size(), 4u);
  for (const cv::Vec3d& p : hits) {
    EXPECT_NEAR(p[2], 2.0, 1e-12);
    EXPECT_NEAR(std::hypot(p[0], p[1]), 2.0 * std::tan(M_PI / 6), 1e-12);
  }
}

TEST(BuiltinScene, RangeFromDepthIsTheBackProjectedDistance) {
  const Scene scene = MakeBuiltinScene("room", {.scale = 0.1});
  const cv::Mat range = RangeFromDepth(scene.camera, scene.depth_m);
  for (int y = 0; y < scene.height(); ++y) {
    for (int x = 0; x < scene.width(); ++x) {
      const double z = scene.depth_m.at<float>(y, x);
      EXPECT_NEAR(range.at<float>(y, x), cv::norm(scene.camera.BackProject(x, y, z)), 1e-5 * z);
    }
  }
}

// The vectorised rows (AVX2, four pixels at a time, odd widths leave a scalar tail) give the
// values of the pre-optimisation loop of commit 6722196 bit for bit: correctly rounded square
// roots and the same double operations. NaN depth stays NaN.
TEST(BuiltinScene, RangeFromDepthEqualsThePreOptimisationLoop) {
  for (const double scale : {0.1, 0.137, 0.251}) {
    Scene scene = MakeBuiltinScene("hull", {.scale = scale});
    scene.depth_m.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
    const cv::Mat range = RangeFromDepth(scene.camera, scene.depth_m);
    const CameraIntrinsics& camera = scene.camera;
    int different = 0;
    for (int y = 0; y < scene.height(); ++y) {
      const double dy = (y - camera.cy) / camera.fy;
      for (int x = 0; x < scene.width(); ++x) {
        const double dx = (x - camera.cx) / camera.fx;
        const float expected =
            static_cast<float>(scene.depth_m.at<float>(y, x) * std::sqrt(dx * dx + dy * dy + 1.0));
        const float got = range.at<float>(y, x);
        different += (got == expected || (std::isnan(got) && std::isnan(expected))) ? 0 : 1;
      }
    }
    EXPECT_EQ(different, 0) << scene.width() << "x" << scene.height();
  }
}

TEST(BuiltinScene, DeterministicWhateverTheThreadCount) {
  const int threads = cv::getNumThreads();
  const Scene a = MakeBuiltinScene("seafloor", {.scale = 0.15});
  cv::setNumThreads(1);
  const Scene b = MakeBuiltinScene("seafloor", {.scale = 0.15});
  cv::setNumThreads(threads);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth_m, b.depth_m, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.normals, b.normals, cv::NORM_INF), 0.0);
}

// Regression (issue 17): SeafloorModel kept a reference to the seabed plane across push_backs that
// reallocated the object vector, so placing the rocks read freed memory. Release builds happened to
// read the old values; the AddressSanitizer build (scripts/test.sh, build-asan) fails this test with
// heap-use-after-free without the fix. Building the model twice, with allocations between, must also
// give the same scene bit for bit.
TEST(BuiltinScene, SeafloorModelBuildsWithoutDanglingReferences) {
  const Scene a = MakeBuiltinScene("seafloor", {.scale = 0.05});
  std::vector<std::vector<double>> churn(64, std::vector<double>(97, 1.0));  // reuse freed blocks
  const Scene b = MakeBuiltinScene("seafloor", {.scale = 0.05});
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth_m, b.depth_m, cv::NORM_INF), 0.0);
  EXPECT_GT(churn.size(), 0u);
}

// Textures must carry enough corners for feature-based tests (ORB at the default 500 features).
TEST(BuiltinScene, TexturesAreRichEnoughForOrb) {
  for (const std::string& name : BuiltinSceneNames()) {
    SCOPED_TRACE(name);
    const Scene scene = MakeBuiltinScene(name, {.scale = name == "hull" ? 0.5 : 1.0});
    cv::Mat gray = scene.image;
    if (gray.channels() == 3) cv::cvtColor(gray, gray, cv::COLOR_BGR2GRAY);
    cv::Mat gray8;
    gray.convertTo(gray8, CV_8U, 255.0);
    std::vector<cv::KeyPoint> keypoints;
    cv::ORB::create(500)->detect(gray8, keypoints);
    EXPECT_GE(keypoints.size(), 400u);
  }
}

}  // namespace
}  // namespace turbid
