// `turbid scene` end to end through the built binary.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "scenes/builtin.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
namespace fs = std::filesystem;
using testing::RunTurbid;
using testing::TempDir;

int CountFiles(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return 0;
  int n = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) n += entry.is_regular_file();
  return n;
}

TEST(SceneCli, WritesLoadableOutputsAndRefusesToOverwrite) {
  TempDir dir;
  const std::string out = dir.File("out");
  auto run = RunTurbid({"scene", "--builtin", "room", "--scale", "0.1", "--out", out,
                        "--normals-format", "both", "--image-exr"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("room: 64x48, color"), std::string::npos) << run.out;
  for (const char* f : {"image.png", "image.exr", "depth.exr", "normals.png", "normals.exr",
                        "scene.json", "summary.json"})
    EXPECT_TRUE(fs::exists(out + "/room/" + f)) << f;
  // The written scene file reloads to the same scene (EXR image and depth are lossless).
  const Scene original = MakeBuiltinScene("room", {.scale = 0.1});
  const Scene back = LoadScene(out + "/room/scene.json");
  EXPECT_EQ(cv::norm(back.image, original.image, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back.depth_m, original.depth_m, cv::NORM_INF), 0.0);
  ASSERT_TRUE(back.dominant_plane);
  EXPECT_LT(cv::norm(back.dominant_plane->normal - original.dominant_plane->normal), 1e-12);
  EXPECT_EQ(back.dvl_points_in_camera.size(), 4u);
  // Normals EXR holds x, y, z as R, G, B.
  const cv::Mat normals = ReadImage(out + "/room/normals.exr");  // BGR in memory = (z, y, x)
  const cv::Vec3f n = normals.at<cv::Vec3f>(10, 10), expected = original.normals.at<cv::Vec3f>(10, 10);
  EXPECT_EQ(n, cv::Vec3f(expected[2], expected[1], expected[0]));
  const nlohmann::json summary = nlohmann::json::parse(testing::ReadFileText(out + "/room/summary.json"));
  EXPECT_EQ(summary["width"], 64);
  EXPECT_EQ(summary["depth"]["valid_fraction"], 1.0);
  // Second run without --force: refused before writing anything, files unchanged.
  const std::string before = testing::ReadFileText(out + "/room/depth.exr");
  run = RunTurbid({"scene", "--builtin", "room", "--scale", "0.1", "--out", out});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("turbid: error: "), std::string::npos);
  EXPECT_NE(run.err.find("already exists"), std::string::npos) << run.err;
  EXPECT_EQ(testing::ReadFileText(out + "/room/depth.exr"), before);
  run = RunTurbid({"scene", "--builtin", "room", "--scale", "0.1", "--out", out, "--force"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
}

TEST(SceneCli, Png16DepthIsTumEncoded) {
  TempDir dir;
  auto run = RunTurbid({"scene", "builtin:hull", "--scale", "0.1", "--out", dir.path(),
                        "--depth-format", "png16"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ReadImageOptions raw;
  raw.keep_raw = true;
  const cv::Mat codes = ReadImage(dir.File("hull/depth.png"), raw);
  const Scene hull = MakeBuiltinScene("hull", {.scale = 0.1});
  EXPECT_EQ(codes.at<float>(5, 7), std::round(hull.depth_m.at<float>(5, 7) * 5000.0f));
  const Scene back = LoadScene(dir.File("hull/scene.json"));
  EXPECT_EQ(back.channels(), 1);
  EXPECT_LT(cv::norm(back.depth_m, hull.depth_m, cv::NORM_INF), 0.5 / 5000 + 1e-6);
}

TEST(SceneCli, BadInputIsOneLineAndWritesNothing) {
  TempDir dir;
  const std::string out = dir.File("out");
  std::ofstream(dir.File("bad.json")) << R"({"type": "rgbd", "image": "x.png", "depth": "y.png", "oops": 1})";
  // A good scene first, then a bad one: nothing at all is written.
  auto run = RunTurbid({"scene", "builtin:room", dir.File("bad.json"), "--scale", "0.1", "--out", out});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err, "turbid: error: " + dir.File("bad.json") + ": unknown key 'oops' (known: type, name, image, color, " +
                         "camera, depth, depth_scale, depth_kind, depth_resize, depth_erode_px, " +
                         "plane, dvl)\n");
  EXPECT_EQ(CountFiles(out), 0);
  run = RunTurbid({"scene", dir.File("missing.json"), "--out", out});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err, "turbid: error: " + dir.File("missing.json") + ": file not found\n");
  run = RunTurbid({"scene", "--builtin", "reef", "--out", out});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("unknown built-in scene"), std::string::npos) << run.err;
  run = RunTurbid({"scene", "--builtin", "room", "--depth-format", "tiff", "--out", out});
  EXPECT_NE(run.exit_code, 0) << "usage error";
  // Depth beyond 13.107 m cannot be a 5000/m 16-bit PNG.
  WriteImage(dir.File("far.exr"), cv::Mat(4, 6, CV_32FC1, cv::Scalar(20.0)));
  WriteImage(dir.File("gray.png"), cv::Mat(4, 6, CV_32FC1, cv::Scalar(0.5)));
  std::ofstream(dir.File("far.json"))
      << R"({"type": "depth", "image": "gray.png", "depth": "far.exr", "camera": "tum_fr2"})";
  run = RunTurbid({"scene", dir.File("far.json"), "--depth-format", "png16", "--out", out});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("beyond the 16-bit PNG range"), std::string::npos) << run.err;
  run = RunTurbid({"scene"});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(CountFiles(out), 0);
}

TEST(SceneCli, WithoutOutOnlyPrintsTheSummary) {
  auto run = RunTurbid({"scene", "hull", "seafloor", "--scale", "0.1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("hull: 136x102, gray"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("seafloor: 64x48, color"), std::string::npos) << run.out;
  EXPECT_EQ(run.out.find("wrote"), std::string::npos);
}

}  // namespace
}  // namespace turbid
