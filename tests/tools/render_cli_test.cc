// End-to-end tests of `turbid render` and `turbid generate` through the built binary.
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

TEST(RenderCli, WritesImageSidecarAndMapsAndRefusesToOverwrite) {
  TempDir dir;
  const std::string out = dir.File("r.png");
  auto run =
      RunTurbid({"render", "--scene", "builtin:seafloor", "--scale", "0.1", "--out", out, "--seed",
                 "7", "--maps", "transmission,light,veil,psf,noise", "--water", "IB"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ASSERT_TRUE(fs::exists(out));
  for (const char* map : {"transmission", "light", "veil", "psf", "noise"})
    EXPECT_TRUE(fs::exists(dir.File(std::string("r_") + map + ".png"))) << map;
  const auto sidecar = nlohmann::json::parse(ReadFileText(dir.File("r.json")));
  EXPECT_EQ(sidecar["seed"], 7);
  EXPECT_EQ(sidecar["options"]["water"]["type"], "IB");
  EXPECT_EQ(sidecar["scene"]["spec"], "builtin:seafloor");
  const cv::Mat image = ReadImage(out);
  EXPECT_EQ(image.channels(), 3);
  EXPECT_EQ(image.cols, sidecar["scene"]["width"].get<int>());

  const std::string before = ReadFileText(dir.File("r.json"));
  run = RunTurbid(
      {"render", "--scene", "builtin:seafloor", "--scale", "0.1", "--out", out, "--seed", "8"});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("exists"), std::string::npos) << run.err;
  EXPECT_EQ(ReadFileText(dir.File("r.json")), before);
  run = RunTurbid({"render", "--scene", "builtin:seafloor", "--scale", "0.1", "--out", out,
                   "--seed", "8", "--force"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(ReadFileText(dir.File("r.json")), before);
}

TEST(RenderCli, ParamsFileSetAndErrors) {
  TempDir dir;
  std::ofstream(dir.File("p.json"))
      << R"({"psf": {"optical_thickness": 1.0}, "sensor": {"enabled": false}})";
  auto run =
      RunTurbid({"render", "--scene", "hull", "--scale", "0.1", "--params", dir.File("p.json"),
                 "--set", "psf.forward_scatter=0.5", "--out", dir.File("h.exr")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto sidecar = nlohmann::json::parse(ReadFileText(dir.File("h.json")));
  EXPECT_EQ(sidecar["options"]["psf"]["optical_thickness"], 1.0);
  EXPECT_EQ(sidecar["options"]["psf"]["forward_scatter"], 0.5);
  EXPECT_EQ(sidecar["options"]["camera"]["bit_depth"], 32);

  std::ofstream(dir.File("bad.json")) << R"({"psf": {"forward_scater": 0.9}})";
  run = RunTurbid({"render", "--scene", "hull", "--scale", "0.1", "--params", dir.File("bad.json"),
                   "--out", dir.File("x.png")});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("unknown key 'psf.forward_scater'"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir.File("x.png")));
  run = RunTurbid(
      {"render", "--scene", "hull", "--scale", "0.1", "--beta", "11", "--out", dir.File("x.png")});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("water.beta_rgb_per_m"), std::string::npos) << run.err;
  run = RunTurbid({"render", "--scene", "builtin:nowhere", "--out", dir.File("x.png")});
  EXPECT_EQ(run.exit_code, 1);
  run = RunTurbid({"render", "--scene", "hull", "--scale", "0.1", "--explain"});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("render plan"), std::string::npos);
  EXPECT_NE(run.out.find("skip:"), std::string::npos);
}

std::map<std::string, std::string> FolderBytes(const std::string& root) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(root))
    if (entry.is_regular_file())
      files[fs::relative(entry.path(), root).string()] = ReadFileText(entry.path().string());
  return files;
}

TEST(GenerateCli, IdenticalBytesForAnyThreadCountAndResumes) {
  TempDir dir;
  std::ofstream(dir.File("g.json"))
      << R"({"scenes": ["builtin:seafloor", "hull"], "scale": 0.08, "seed": 3,
    "grid": {"psf.optical_thickness": [1.0, 4.0]},
    "random": {"count": 2, "params": {"water.beta_gray_per_m": {"uniform": [0.1, 2.0]},
                                      "psf.forward_scatter": {"log_uniform": [0.1, 1.0]}}}})";
  auto run = RunTurbid({"generate", dir.File("g.json"), "--out", dir.File("a"), "--threads", "2"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = RunTurbid({"generate", dir.File("g.json"), "--out", dir.File("b"), "--threads", "1"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto a = FolderBytes(dir.File("a"));
  EXPECT_EQ(a, FolderBytes(dir.File("b")));
  EXPECT_EQ(a.count("manifest.csv"), 1u);
  EXPECT_EQ(a.count("manifest.jsonl"), 1u);
  // 2 scenes x 2 grid points x 2 samples = 8 items + header.
  const std::string csv = a.at("manifest.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 9);
  // An interrupted run (missing sidecar and image) resumes to the same bytes.
  fs::remove(dir.File("a/sidecars/hull_000005.json"));
  fs::remove(dir.File("a/images/seafloor_000001.png"));
  run = RunTurbid({"generate", dir.File("g.json"), "--out", dir.File("a"), "--threads", "2"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("6 already complete"), std::string::npos) << run.out;
  EXPECT_EQ(FolderBytes(dir.File("a")), a);

  std::ofstream(dir.File("bad.json"))
      << R"({"scenes": ["hull"], "grid": {"psf.forward_scatter": [2.0]}})";
  run = RunTurbid({"generate", dir.File("bad.json"), "--out", dir.File("c")});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("psf.forward_scatter"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace turbid
