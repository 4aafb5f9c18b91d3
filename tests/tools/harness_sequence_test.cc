// Sequences in experiments (issue 34 items 1 and 3): built-in scenes along a trajectory and
// rgbd_sequence files are scenes whose frames are items; front-end metrics are scored per frame
// pair, for each method and for the clean frames, identically for any thread count, shard layout
// or resumption.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>

#include "core/error.h"
#include "tests/support/test_support.h"
#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/sweep.h"

namespace turbid {
namespace {

using nlohmann::json;
using testing::ReadFileText;
using testing::TempDir;

json SequenceExperiment() {
  return json::parse(R"({
    "name": "seq", "seed": 5,
    "scenes": [{"spec": "builtin:seafloor", "scale": 0.5, "name": "survey",
                "trajectory": {"kind": "pass", "frames": 4, "speed_m_per_s": 1.0}}],
    "grid": {"water.beta_gray_per_m": [0.3], "water.beta_rgb_per_m": [[0.39, 0.3, 0.24]]},
    "level": "water.beta_gray_per_m",
    "methods": ["clahe"], "reference_methods": false,
    "metrics": ["psnr", "rpe_trans_m", "sift_rpe_rot_deg", "inlier_ratio_k2", "flicker",
                "pose_failed"],
    "thumbnails": 0
  })");
}

TEST(HarnessSequence, FramesAreItemsWithTheirOwnSeedsAndTheExperimentRoundTrips) {
  json in = SequenceExperiment();
  in["scenes"].push_back("builtin:hull");
  in["metrics"] = {"psnr"};
  const Experiment e = ParseExperiment(in, "seq.json", RegistryCatalog());
  ASSERT_EQ(e.scenes[0].frames, 4);
  EXPECT_EQ(e.scenes[0].trajectory.at("kind"), "pass");
  EXPECT_EQ(e.scenes[0].trajectory.at("frame_rate_hz"), 10.0);  // defaults filled in
  EXPECT_FALSE(e.scenes[1].IsSequence());
  EXPECT_EQ(e.ItemCount(), 5);
  const std::vector<ItemSpec> items = ExpandItems(e);
  ASSERT_EQ(items.size(), 5u);
  std::set<uint64_t> seeds;
  for (int f = 0; f < 4; ++f) {
    EXPECT_EQ(items[f].id, "survey-c0000-f000" + std::to_string(f));
    EXPECT_EQ(items[f].frame, f);
    EXPECT_EQ(items[f].sequence_seed, items[0].sequence_seed);
    EXPECT_EQ(items[f].render_options.at("seed"), items[f].seed);
    seeds.insert(items[f].seed);
  }
  EXPECT_EQ(seeds.size(), 4u);  // sensor noise independent per frame
  EXPECT_EQ(items[4].id, "hull-c0000");
  EXPECT_EQ(items[4].frame, -1);
  // The resolved experiment reads back to the same JSON; a single-frame scene has no new keys.
  const json resolved = e.ToJson();
  EXPECT_EQ(ExperimentFromResolvedJson(resolved, "r.json").ToJson(), resolved);
  EXPECT_FALSE(resolved["scenes"][1].contains("frames"));
  EXPECT_EQ(resolved["scenes"][0]["frames"], 4);
}

TEST(HarnessSequence, BadSequenceScenesAndMetricsAreRefusedBeforeAnyWork) {
  const auto message = [](const json& in) {
    try {
      ParseExperiment(in, "seq.json", RegistryCatalog());
    } catch (const Error& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  json in = SequenceExperiment();
  in["scenes"][0]["trajectory"]["kindd"] = "pass";
  EXPECT_NE(message(in).find("kindd"), std::string::npos) << message(in);
  in = SequenceExperiment();
  in["scenes"][0]["trajectory"]["frames"] = 0;
  EXPECT_NE(message(in).find("frames"), std::string::npos) << message(in);
  in = SequenceExperiment();
  in["scenes"].push_back("builtin:hull");  // a single frame cannot have pairs
  EXPECT_NE(message(in).find("scores sequences, and scene 'hull' is a single frame"),
            std::string::npos)
      << message(in);
  in = SequenceExperiment();
  in["scenes"] = {{{"spec", "scene.json"}, {"trajectory", {{"kind", "pass"}}}}};
  EXPECT_NE(message(in).find("'trajectory' is for built-in scenes"), std::string::npos)
      << message(in);
  in = SequenceExperiment();
  in["metrics"] = {"rpe_rot_deg_k0"};
  EXPECT_NE(message(in).find("rpe_rot_deg_k0"), std::string::npos) << message(in);
}

std::string Sweep(const Experiment& e, const std::string& out, int threads, Shard shard = {}) {
  SweepOptions options;
  options.out_dir = out;
  options.threads = threads;
  options.shard = shard;
  HarnessRunner runner(e, out);
  RunSweep(e, options, runner.Hooks());
  return ReadFileText(out + "/items.csv");
}

TEST(HarnessSequence, FrontEndMetricsDoNotDependOnThreadsOrShardsAndCleanPnpIsExact) {
  TempDir dir;
  const Experiment e = ParseExperiment(SequenceExperiment(), "seq.json", RegistryCatalog());
  const std::string one = Sweep(e, dir.File("one"), 1);
  EXPECT_EQ(Sweep(e, dir.File("two"), 2), one);
  // Shards hold every other frame: each recomputes the frames its pairs need.
  Sweep(e, dir.File("s0"), 2, Shard{0, 2});
  Sweep(e, dir.File("s1"), 1, Shard{1, 2});
  MergeOptions merge;
  merge.out_dir = dir.File("merged");
  MergeSweeps({dir.File("s0"), dir.File("s1")}, merge);
  EXPECT_EQ(ReadFileText(dir.File("merged/items.csv")), one);
  EXPECT_EQ(ReadFileText(dir.File("merged/summary.csv")),
            ReadFileText(dir.File("one/summary.csv")));

  // The clean frames (the items' reference_metrics): exact depth and poses, so PnP is within a
  // few millimetres of the 0.1 m steps (half-size frames); frame 0 has no pair, frame 1 no k = 2
  // pair.
  const SweepDir loaded = LoadSweepDir(dir.File("one"));
  ASSERT_EQ(loaded.items.size(), 4u);
  EXPECT_TRUE(std::isnan(loaded.items[0].reference_metrics.at("rpe_trans_m")));
  EXPECT_TRUE(std::isnan(loaded.items[1].reference_metrics.at("inlier_ratio_k2")));
  EXPECT_TRUE(std::isnan(loaded.items[0].reference_metrics.at("flicker")));
  for (int f = 1; f < 4; ++f) {
    const ItemResult& item = loaded.items[f];
    // 320x240, ORB: measured 5.8-6.4 mm of the 0.1 m steps.
    EXPECT_LT(item.reference_metrics.at("rpe_trans_m"), 0.01) << f;
    EXPECT_EQ(item.reference_metrics.at("flicker"), 0.0) << f;  // clean against itself
    const MethodResult& clahe = item.methods.at(0);
    EXPECT_TRUE(clahe.error.empty()) << clahe.error;
    EXPECT_TRUE(std::isfinite(clahe.metrics.at("flicker"))) << f;
    EXPECT_TRUE(std::isfinite(clahe.metrics.at("rpe_trans_m"))) << f;
    if (f >= 2) {
      EXPECT_GT(item.methods[0].metrics.at("inlier_ratio_k2"), 0.3) << f;
    }
  }
}

}  // namespace
}  // namespace turbid
