// `turbid bench` end to end: the timing harness runs its cases on small inputs, reports ours, the
// peer, the ratio and the goal, and writes the same as JSON. No timing is asserted (the machine
// is noisy): the test checks what is measured and that the outputs of ours and the peer agree.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/support/test_support.h"

namespace turbid {
namespace {

using testing::RunTurbid;
using testing::TempDir;

TEST(BenchCli, ListNamesEveryGoal) {
  const auto run = RunTurbid({"bench", "--list"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* name :
       {"ssim/gray/8bit", "ssim/color/8bit", "guided_filter/gray/r2", "clahe/rayleigh",
        "render/color/full", "render/gray/full", "enhance/full", "enhance/simplified"}) {
    EXPECT_NE(run.out.find(name), std::string::npos) << name;
  }
}

TEST(BenchCli, RunsSelectedCasesAndWritesJson) {
  TempDir dir;
  const std::string json_path = dir.File("bench.json");
  const auto run =
      RunTurbid({"bench", "--scale", "0.1", "--min-time", "0.01", "--filter",
                 "^(ssim/gray/8bit|psnr|guided_filter/gray/r2|render/gray/full)", "--json", json_path});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("| ssim/gray/8bit |"), std::string::npos) << run.out;
  const nlohmann::json report = nlohmann::json::parse(testing::ReadFileText(json_path));
  EXPECT_EQ(report.at("width"), 136);
  EXPECT_EQ(report.at("threads"), 1);
  EXPECT_EQ(report.at("warm_allocator"), false);
  ASSERT_EQ(report.at("cases").size(), 4u);
  for (const auto& c : report.at("cases")) {
    EXPECT_GT(c.at("ours_ms").get<double>(), 0.0) << c.dump();
    const std::string name = c.at("name");
    if (name == "render/gray/full") {
      EXPECT_TRUE(c.at("peer_ms").is_null());
      EXPECT_EQ(c.at("goal"), "<= 15 ms");
      EXPECT_NE(c.at("status").get<std::string>().find("goal is at scale 1"), std::string::npos);
    } else {
      EXPECT_GT(c.at("peer_ms").get<double>(), 0.0) << c.dump();
      EXPECT_NEAR(c.at("ratio").get<double>(),
                  c.at("peer_ms").get<double>() / c.at("ours_ms").get<double>(), 1e-9);
    }
    if (name == "psnr/color/8bit") {
      // "PSNR a vs b dB": ours and cv::PSNR on the same pair.
      double a = 0, b = 0;
      ASSERT_EQ(
          std::sscanf(c.at("agreement").get<std::string>().c_str(), "PSNR %lf vs %lf", &a, &b), 2);
      EXPECT_NEAR(a, b, 1e-6);
    }
    if (name == "guided_filter/gray/r2") {
      double diff = 1;
      ASSERT_EQ(std::sscanf(c.at("agreement").get<std::string>().c_str(), "max |diff| %lf", &diff),
                1);
      EXPECT_LE(diff, 1e-4);
    }
  }
  // Never overwrite without --force.
  const auto again = RunTurbid(
      {"bench", "--scale", "0.1", "--min-time", "0.01", "--filter", "psnr", "--json", json_path});
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.err.find("exists"), std::string::npos) << again.err;
  // --warm-allocator is recorded in the table footer and the JSON.
  const auto warm = RunTurbid({"bench", "--scale", "0.1", "--min-time", "0.01", "--filter", "psnr",
                               "--warm-allocator", "--json", json_path, "--force"});
  ASSERT_EQ(warm.exit_code, 0) << warm.err;
  EXPECT_NE(warm.out.find("--warm-allocator"), std::string::npos) << warm.out;
  EXPECT_EQ(nlohmann::json::parse(testing::ReadFileText(json_path)).at("warm_allocator"), true);
}

// --sweep: a small sweep run from scratch and timed by stage. The stages are the ones the sweep
// runs (render, each method, each metric, I/O, tables), each called as often as it runs.
TEST(BenchCli, SweepIsTimedByStage) {
  TempDir dir;
  dir.Write("exp.json", R"({"name": "tiny", "seed": 1, "scale": 0.1,
    "scenes": ["builtin:seafloor", "builtin:hull"],
    "grid": {"water.beta_gray_per_m": [0.3, 0.8], "water.beta_rgb_per_m": [[0.4, 0.3, 0.2]]},
    "methods": ["clahe", "dcp"], "metrics": ["ssim", "psnr", "hautiere_e"],
    "ground_truth": "clean", "thumbnails": 32})");
  const std::string json_path = dir.File("sweep.json");
  const std::string out = dir.File("out");
  const auto run = RunTurbid({"bench", "--sweep", dir.File("exp.json"), "--threads", "2", "--out",
                              out, "--json", json_path});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("| method dcp |"), std::string::npos) << run.out;
  const nlohmann::json report = nlohmann::json::parse(testing::ReadFileText(json_path));
  EXPECT_EQ(report.at("experiment"), "tiny");
  EXPECT_EQ(report.at("items"), 4);
  EXPECT_EQ(report.at("threads"), 2);
  std::map<std::string, int64_t> calls;
  for (const auto& stage : report.at("stages")) {
    EXPECT_GE(stage.at("ms").get<double>(), 0.0) << stage.dump();
    calls[stage.at("stage")] = stage.at("calls");
  }
  EXPECT_EQ(calls["render"], 4);
  EXPECT_EQ(calls["method clahe"], 4);
  EXPECT_EQ(calls["method dcp"], 4);
  EXPECT_EQ(calls["method oracle"], 4);  // the oracle-parameter LMMSE reference every sweep adds
  EXPECT_EQ(calls["metric ssim"], 16);    // none, clahe, dcp, oracle on each item
  EXPECT_EQ(calls["metric hautiere_e"], 16);
  EXPECT_EQ(calls["I/O: journal"], 4);
  EXPECT_EQ(calls["tables"], 1);
  EXPECT_EQ(calls["scene: load, clean scores, thumbnail"], 2);
  EXPECT_GE(calls["I/O: thumbnails"], 4);
  // --out keeps the sweep's folder (tables included); a second run needs --force.
  EXPECT_TRUE(std::filesystem::exists(out + "/summary.md"));
  const auto again = RunTurbid({"bench", "--sweep", dir.File("exp.json"), "--out", out});
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.err.find("--force"), std::string::npos) << again.err;
  const auto bad = RunTurbid({"bench", "--out", out});
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("--out needs --sweep"), std::string::npos) << bad.err;
}

TEST(BenchCli, BadOptionsAreOneLineErrors) {
  auto run = RunTurbid({"bench", "--filter", "no-such-case"});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("matches no case"), std::string::npos) << run.err;
  run = RunTurbid({"bench", "--scale", "2"});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("--scale"), std::string::npos) << run.err;
  run = RunTurbid({"bench", "--no-such-flag"});
  EXPECT_EQ(run.exit_code, 2);
}

}  // namespace
}  // namespace turbid
