// Camera encoding end to end (issue 16, item 4): every integer image a command writes is coded the
// same way, so an identity render scores SSIM 1 / PSNR inf against `turbid scene`'s image.png (the
// README's example), and differently coded inputs draw a warning from score and enhance.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "scenes/image_io.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

// The README's identity parameters (scenes/params/identity.json): beta 0, E_A = 1, no light, no
// PSF, snow or noise -> I = rho. CMake compiles with absolute paths: the repository root is three
// levels above this file.
const std::string kIdentityFile =
    (fs::path(__FILE__).parent_path().parent_path().parent_path() / "scenes/params/identity.json")
        .string();

TEST(EncodingCli, IdentityRenderScoresPerfectlyAgainstSceneImage) {
  TempDir dir;
  auto run = RunTurbid({"scene", "seafloor", "--scale", "0.1", "--out", dir.File("scenes")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = RunTurbid({"render", "--scene", "builtin:seafloor", "--scale", "0.1", "--params",
                   kIdentityFile, "--out", dir.File("r.png")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto sidecar = nlohmann::json::parse(ReadFileText(dir.File("r.json")));
  EXPECT_EQ(sidecar["encoding"], "srgb");
  EXPECT_EQ(sidecar["options"]["camera"]["encoding"], "srgb");
  const std::string ref = dir.File("scenes/seafloor/image.png");
  run = RunTurbid({"score", "--ref", ref, dir.File("r.png"), "--metrics", "ssim,psnr", "--json"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto scores = nlohmann::json::parse(run.out)["results"][0];
  EXPECT_EQ(scores["ssim"], 1.0);
  EXPECT_EQ(scores["psnr"], "inf");
  EXPECT_EQ(run.err.find("warning"), std::string::npos) << run.err;

  // The same render coded linearly: the stored values differ, and score says why.
  run = RunTurbid({"render", "--scene", "builtin:seafloor", "--scale", "0.1", "--params",
                   kIdentityFile, "--set", "camera.encoding=linear", "--out",
                   dir.File("lin.png")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = RunTurbid({"score", "--ref", ref, dir.File("lin.png"), "--json"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("warning"), std::string::npos);
  EXPECT_NE(run.err.find("linear-coded"), std::string::npos) << run.err;
  EXPECT_LT(nlohmann::json::parse(run.out)["results"][0]["psnr"].get<double>(), 30.0);

  // Read back with its sidecar's encoding, each file gives the same linear values.
  ReadImageOptions srgb, linear;
  srgb.transfer = Transfer::kSrgb;
  const cv::Mat a = ReadImage(dir.File("r.png"), srgb), b = ReadImage(dir.File("lin.png"), linear);
  // Each file is within half a code of the same values: half a linear step (1/255) plus half the
  // largest sRGB step, decode'(1)/255 = (2.4/1.055)/255.
  EXPECT_LT(cv::norm(a, b, cv::NORM_INF), 0.5 / 255.0 * (1.0 + 2.4 / 1.055) + 1e-6);
}

TEST(EncodingCli, EnhanceDecodesPerSidecarAndWarnsOnMismatch) {
  TempDir dir;
  auto run = RunTurbid({"render", "--scene", "builtin:hull", "--scale", "0.1", "--params",
                        kIdentityFile, "--out", dir.File("r.png")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // With the sidecar the input is decoded as sRGB (and the output coded so): no warning. Forcing
  // --transfer linear contradicts the sidecar and warns.
  run = RunTurbid({"enhance", "-m", "clahe", dir.File("r.png"), dir.File("auto.png"), "--sidecar",
                   dir.File("r.json")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err.find("warning"), std::string::npos) << run.err;
  run = RunTurbid({"enhance", "-m", "clahe", dir.File("r.png"), dir.File("forced.png"),
                   "--sidecar", dir.File("r.json"), "--transfer", "linear"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("warning"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("srgb-coded"), std::string::npos) << run.err;
  // Without --sidecar the render's OUT.json beside the input is found.
  run = RunTurbid({"enhance", "-m", "clahe", dir.File("r.png"), dir.File("beside.png")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(ReadFileText(dir.File("beside.png")), ReadFileText(dir.File("auto.png")));
}

TEST(EncodingCli, GenerateCodesImageAndGroundTruthAlike) {
  TempDir dir;
  nlohmann::json config = {{"scenes", {"builtin:room"}},
                           {"scale", 0.1},
                           {"base", nlohmann::json::parse(ReadFileText(kIdentityFile))},
                           {"grid", {{"camera.encoding", {"srgb", "linear"}}}}};
  std::ofstream(dir.File("g.json")) << config.dump();
  auto run = RunTurbid({"generate", dir.File("g.json"), "--out", dir.File("data"), "--threads",
                        "1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string manifest = ReadFileText(dir.File("data/manifest.csv"));
  EXPECT_NE(manifest.find(",encoding\n"), std::string::npos) << manifest;
  EXPECT_NE(manifest.find(",srgb\n"), std::string::npos) << manifest;
  EXPECT_NE(manifest.find(",linear\n"), std::string::npos) << manifest;
  run = RunTurbid({"score", "--manifest", dir.File("data/manifest.csv"), "--metrics", "psnr",
                   "--json"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto doc = nlohmann::json::parse(run.out);
  ASSERT_EQ(doc["results"].size(), 2u);
  for (const auto& row : doc["results"]) EXPECT_EQ(row["psnr"], "inf") << row.dump();
  EXPECT_EQ(run.err.find("warning"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace turbid
