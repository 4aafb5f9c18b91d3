// Loaders on the real frames in $TURBID_DATA (skipped when unset). Expected values come from each
// folder's SOURCE.md / MANIFEST.txt (depth checks and sha256), computed independently of turbid.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "scenes/scene_loader.h"
#include "scenes/scene_summary.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
using testing::TempDir;

Scene LoadWithJson(const TempDir& dir, const std::string& json) {
  std::ofstream(dir.File("scene.json")) << json;
  return LoadScene(dir.File("scene.json"));
}

TEST(RealData, IclNuimLivingRoomFrame) {
  TURBID_REQUIRE_DATA(data);
  TempDir dir;
  const std::string base = data + "/icl_nuim_lr_kt1/";
  const Scene s = LoadWithJson(dir, R"({"type": "rgbd", "image": ")" + base + R"(rgb/0.png", "depth": ")" +
                                        base + R"(depth/0.png", "camera": "icl_nuim"})");
  EXPECT_EQ(s.width(), 640);
  EXPECT_EQ(s.channels(), 3);
  const DepthStats d = ComputeDepthStats(s.depth_m);
  EXPECT_NEAR(d.min_m, 1.1280, 1e-4);  // SOURCE.md depth check
  EXPECT_NEAR(d.max_m, 2.0600, 1e-4);
  EXPECT_EQ(d.valid_fraction, 1.0);
  EXPECT_EQ(s.input_hashes.at(base + "depth/0.png"),
            "420b77488efac5cfe4bade3b8f292d402ade5ed3aa99779da0bf17508830c45a");  // MANIFEST.txt
}

TEST(RealData, TumFrameWithHoles) {
  TURBID_REQUIRE_DATA(data);
  TempDir dir;
  const std::string base = data + "/tum_rgbd/";
  const Scene s = LoadWithJson(dir, R"({"type": "rgbd", "image": ")" + base + R"(1.png", "depth": ")" + base +
                                        R"(1_depth.png", "camera": "tum_fr2"})");
  const DepthStats d = ComputeDepthStats(s.depth_m);
  EXPECT_NEAR(d.min_m, 0.9694, 1e-4);
  EXPECT_NEAR(d.max_m, 8.5638, 1e-4);
  EXPECT_NEAR(1.0 - d.valid_fraction, 102341.0 / (640 * 480), 1e-9);  // 33.31 % zeros
  int defined = 0;
  for (int y = 0; y < s.height(); ++y)
    for (int x = 0; x < s.width(); ++x) {
      const bool has_normal = std::isfinite(s.normals.at<cv::Vec3f>(y, x)[0]);
      if (std::isnan(s.depth_m.at<float>(y, x))) {
        ASSERT_FALSE(has_normal);
      }
      defined += has_normal;
    }
  EXPECT_GT(defined, 0.95 * d.valid_pixels);
}

TEST(RealData, MiddleburyMotorcyclePfmWithCalibration) {
  TURBID_REQUIRE_DATA(data);
  TempDir dir;
  const std::string base = data + "/middlebury-motorcycle/";
  // calib.json "calibration_this_resolution".
  const Scene s = LoadWithJson(dir, R"({"type": "stereo", "image": ")" + base + R"(left.png", "disparity": ")" +
                                        base + R"(disp0.pfm", "baseline_m": 0.193001, "doffs_px": 31.08575,
      "camera": {"fx": 994.97775, "fy": 994.97775, "cx": 311.193, "cy": 254.87675}})");
  EXPECT_EQ(s.width(), 741);
  EXPECT_EQ(s.height(), 500);
  const DepthStats d = ComputeDepthStats(s.depth_m);
  EXPECT_GT(d.valid_fraction, 0.8);
  EXPECT_LT(d.valid_fraction, 1.0) << "inf = unknown must become invalid";
  // Closed form at the first pixel of the file's first (bottom) row: the header bytes show
  // d = 0x426be562 little-endian = 58.974 px.
  const float d0 = 58.97400665283203f;
  EXPECT_NEAR(s.depth_m.at<float>(499, 0), 0.193001 * 994.97775 / (d0 + 31.08575), 1e-5);
}

TEST(RealData, MiddleburyTeddyPgmDisparity) {
  TURBID_REQUIRE_DATA(data);
  TempDir dir;
  const std::string base = data + "/middlebury2003_teddy/";
  // No metric calibration exists: assume f*B = 450 px * 0.1 m (stated here, not from the data).
  const Scene s = LoadWithJson(dir, R"({"type": "stereo", "image": ")" + base + R"(im2.png", "disparity": ")" +
                                        base + R"(disp2.pgm", "disparity_scale": 4, "baseline_m": 0.1,
      "camera": {"fx": 450, "fy": 450, "cx": 224.5, "cy": 187.0}})");
  const DepthStats d = ComputeDepthStats(s.depth_m);
  EXPECT_NEAR(d.valid_fraction, 1.0 - 3406.0 / (450 * 375), 1e-9);  // 2.02 % zeros
  EXPECT_NEAR(d.min_m, 45.0 / 52.75, 1e-5);  // max disparity 52.75 px
  EXPECT_NEAR(d.max_m, 45.0 / 12.50, 1e-5);  // min disparity 12.50 px
}

TEST(RealData, DeepSeaRendererExrDepth) {
  TURBID_REQUIRE_DATA(data);
  TempDir dir;
  const std::string base = data + "/deepsea_renderer_synthetic/";
  const Scene s = LoadWithJson(dir, R"({"type": "depth", "image": ")" + base + R"(bomb_0001.png", "depth": ")" +
                                        base + R"(bomb_0001.exr", "camera": {"fx": 600, "fy": 600, "cx": 400, "cy": 400}})");
  const DepthStats d = ComputeDepthStats(s.depth_m);
  EXPECT_NEAR(d.min_m, 2.8808, 1e-4);
  EXPECT_NEAR(d.median_m, 3.0133, 1e-3);
  EXPECT_NEAR(d.max_m, 3.0713, 1e-4);
  EXPECT_EQ(d.valid_fraction, 1.0);
}

}  // namespace
}  // namespace turbid
