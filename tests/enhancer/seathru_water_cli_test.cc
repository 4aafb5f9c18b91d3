// `turbid water fit` end to end: a seafloor render in known revised water, written as a real RGB-D
// frame would be (linear EXR image, float depth EXR, a scene file), fitted by the CLI; the FIT.json
// holds the truth's backscatter and is accepted by `turbid render --params` as it is.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/json_io.h"
#include "scenes/builtin.h"
#include "scenes/image_io.h"
#include "simulator/render.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {
using testing::RunTurbid;
using testing::TempDir;

// Seafloor at half size with every 37th pixel black (Sea-thru's dark pixels), rendered in water
// with B∞ = (0.06, 0.28, 0.30), β^B = (0.55, 0.40, 0.45), β^D = (0.60, 0.25, 0.30).
std::string WriteFrame(const TempDir& dir) {
  BuiltinSceneOptions options;
  options.scale = 0.5;
  Scene scene = MakeBuiltinScene("seafloor", options);
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x)
      if ((y * scene.width() + x) % 37 == 0) scene.image.at<cv::Vec3f>(y, x) = {0, 0, 0};
  RenderOptions o;
  o.model = ImageModel::kRevised;
  o.water.beta_rgb_per_m = {0.60, 0.25, 0.30};
  o.water.ambient_rgb = {1, 1, 1};
  o.water.backscatter = true;
  o.water.backscatter_rgb = {0.06, 0.28, 0.30};
  o.revised.beta_b_rgb_per_m = {0.55, 0.40, 0.45};
  o.light.lights.clear();
  o.psf.enabled = false;
  o.snow.enabled = false;
  o.sensor.enabled = false;
  o.camera.bit_depth = 32;
  const RenderResult result = Renderer(scene).Render(o);
  WriteImage(dir.File("image.exr"), result.image);
  WriteImage(dir.File("depth.exr"), scene.depth_m);
  const CameraIntrinsics& c = scene.camera;
  std::ofstream(dir.File("frame.json"))
      << R"({"type": "depth", "image": "image.exr", "depth": "depth.exr", "camera": {"fx": )"
      << c.fx << R"(, "fy": )" << c.fy << R"(, "cx": )" << c.cx << R"(, "cy": )" << c.cy << "}}";
  return dir.File("frame.json");
}

TEST(WaterCli, FitWritesRenderParamsDiagnosticsAndPlot) {
  TempDir dir;
  const std::string frame = WriteFrame(dir);
  const std::string fit = dir.File("fit.json");
  auto run = RunTurbid({"water", "fit", frame, "--out", fit});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("B_inf (R, G, B)"), std::string::npos) << run.out;
  const nlohmann::json params = ReadJsonFile(fit);
  EXPECT_EQ(params.at("model"), "revised");
  const double truth[3] = {0.06, 0.28, 0.30}, beta_b[3] = {0.55, 0.40, 0.45};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(params["water"]["backscatter_rgb"][c].get<double>(), truth[c], 0.05 * truth[c]);
    EXPECT_NEAR(params["revised"]["beta_b_rgb_per_m"][c].get<double>(), beta_b[c], 0.1 * beta_b[c]);
  }
  const nlohmann::json diagnostics = ReadJsonFile(dir.File("fit.diagnostics.json"));
  EXPECT_EQ(diagnostics.at("frames"), 1);
  EXPECT_EQ(diagnostics["backscatter"]["bins"].size(), 10u);
  EXPECT_LT(diagnostics["backscatter"]["residual_rms_rgb"][1].get<double>(), 1e-3);
  EXPECT_EQ(ReadImage(dir.File("fit.plot.png")).size(), cv::Size(1000, 420));
  // The fit renders as it is.
  run = RunTurbid({"render", "--scene", "builtin:room", "--scale", "0.1", "--params", fit, "--out",
                   dir.File("room.png")});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  // Outputs are not replaced without --force; options are strict.
  run = RunTurbid({"water", "fit", frame, "--out", fit});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("exists (use --force"), std::string::npos) << run.err;
  std::ofstream(dir.File("opts.json")) << R"({"range_bin": 12})";
  run = RunTurbid(
      {"water", "fit", frame, "--out", dir.File("f2.json"), "--options", dir.File("opts.json")});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("unknown key 'range_bin'"), std::string::npos) << run.err;
  // Two frames of the same water at once.
  run = RunTurbid({"water", "fit", frame, frame, "--out", dir.File("f3.json")});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(ReadJsonFile(dir.File("f3.diagnostics.json")).at("frames"), 2);
}

}  // namespace
}  // namespace turbid
