// scenes/experiments/fig8.json (issue 34 item 4: the paper's Fig. 8 through the harness): the
// shipped file parses and dry-runs, and the same experiment at a small scale runs and gives the
// paper's figures (active sets, correspondences, homography inliers) with the ordering the paper
// reports: clean frames above CLAHE above the unenhanced input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "tests/support/test_support.h"
#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/sweep.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;
using testing::RunTurbid;
using testing::TempDir;

// CMake compiles with absolute paths: the repository root is three levels above this file.
fs::path Fig8Path() {
  return fs::path(__FILE__).parent_path().parent_path().parent_path() /
         "scenes/experiments/fig8.json";
}

TEST(Fig8Experiment, ShippedFileParsesAndDryRuns) {
  const Experiment e = LoadExperimentFile(Fig8Path().string(), RegistryCatalog());
  ASSERT_EQ(e.scenes.size(), 1u);
  EXPECT_EQ(e.scenes[0].frames, 10);
  const CliRun run =
      RunTurbid({"sweep", Fig8Path().string(), "--out", "/nonexistent/never", "--dry-run"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("30 items"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("6 methods, 14 metrics"), std::string::npos) << run.out;
}

// The speed cases of docs/performance-harness.md (turbid bench --sweep FILE) are valid.
TEST(Fig8Experiment, SequenceSpeedCasesDryRun) {
  for (const char* name : {"sequence_speed.json", "sequence_speed_orb.json"}) {
    const fs::path path = Fig8Path().parent_path() / "examples" / name;
    const CliRun run = RunTurbid({"sweep", path.string(), "--out", "/nonexistent/never",
                                  "--dry-run"});
    ASSERT_EQ(run.exit_code, 0) << name << ": " << run.err;
    EXPECT_NE(run.out.find("100 items"), std::string::npos) << run.out;
  }
}

TEST(Fig8Experiment, SmallRunGivesThePapersFigures) {
  std::ifstream in(Fig8Path());
  json j = json::parse(in);
  // A quarter of the size, 4 frames, beta 0.4 only, the input and CLAHE, ORB.
  j["scenes"][0]["scale"] = 0.25;
  j["scenes"][0]["trajectory"]["frames"] = 4;
  j["grid"]["@turbidity"] = json::array({j["grid"]["@turbidity"][0]});
  j["methods"] = {"none", "clahe"};
  j["metrics"] = {"keypoints", "active", "correspondences", "homography_inliers",
                  "homography_inliers_k2"};
  j["thumbnails"] = 0;
  const Experiment e = ParseExperiment(j, Fig8Path().string(), RegistryCatalog());
  TempDir dir;
  SweepOptions options;
  options.out_dir = dir.File("o");
  options.threads = 1;
  HarnessRunner runner(e, options.out_dir);
  RunSweep(e, options, runner.Hooks());
  const SweepDir loaded = LoadSweepDir(dir.File("o"));
  ASSERT_EQ(loaded.items.size(), 4u);
  EXPECT_TRUE(std::isnan(loaded.items[0].reference_metrics.at("active")));  // no pair
  EXPECT_TRUE(std::isnan(loaded.items[1].reference_metrics.at("homography_inliers_k2")));
  for (int f = 1; f < 4; ++f) {
    const ItemResult& item = loaded.items[static_cast<size_t>(f)];
    const auto& clean = item.reference_metrics;
    const auto& none = item.methods.at(0).metrics;
    const auto& clahe = item.methods.at(1).metrics;
    std::printf("frame %d: inliers clean %.0f clahe %.0f none %.0f; keypoints %.0f %.0f %.0f\n", f,
                clean.at("homography_inliers"), clahe.at("homography_inliers"),
                none.at("homography_inliers"), clean.at("keypoints"), clahe.at("keypoints"),
                none.at("keypoints"));
    // Clean frames 3 cm apart: every pair active, most correspondences homography inliers.
    EXPECT_EQ(clean.at("active"), 1.0) << f;
    EXPECT_GT(clean.at("homography_inliers"), 0.8 * clean.at("correspondences")) << f;
    EXPECT_EQ(clahe.at("active"), 1.0) << f;
    EXPECT_GT(clean.at("homography_inliers"), clahe.at("homography_inliers")) << f;
    // The input is active or not; when it is, CLAHE has more inliers.
    if (none.at("active") == 1.0) {
      EXPECT_GT(clahe.at("homography_inliers"), none.at("homography_inliers")) << f;
    } else {
      EXPECT_TRUE(std::isnan(none.at("homography_inliers"))) << f;
    }
  }
}

}  // namespace
}  // namespace turbid
