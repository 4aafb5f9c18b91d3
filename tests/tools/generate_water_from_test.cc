// `"water_from"` in `turbid generate` configs (docs/cli/render.md): a fitted water (`turbid water
// fit --out FIT.json`) renders exactly as `turbid render --params FIT.json`, a list is sampled
// reproducibly, and bad files are named in the errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <sstream>

#include "core/error.h"
#include "scenes/image_io.h"
#include "tests/support/test_support.h"
#include "tools/harness/generate.h"

namespace turbid {
namespace {

using nlohmann::json;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

json ReadJson(const std::string& path) { return json::parse(ReadFileText(path)); }

std::vector<json> ManifestRows(const std::string& folder) {
  std::vector<json> rows;
  std::istringstream in(ReadFileText(folder + "/manifest.jsonl"));
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) rows.push_back(json::parse(line));
  return rows;
}

TEST(GenerateWaterFrom, RendersExactlyAsRenderWithTheFitAsParams) {
  TempDir dir;
  const std::string fit = dir.File("fit.json");
  auto run = RunTurbid({"water", "fit", "builtin:seafloor", "--out", fit});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  dir.Write("g.json", R"({"scenes": ["builtin:seafloor"], "scale": 0.2, "seed": 9,
    "water_from": ")" + fit +
                          R"("})");
  run = RunTurbid({"generate", dir.File("g.json"), "--out", dir.File("ds")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json sidecar = ReadJson(dir.File("ds/sidecars/seafloor_000000.json"));
  const uint64_t seed = sidecar["seed"].get<uint64_t>();
  run = RunTurbid({"render", "--scene", "builtin:seafloor", "--scale", "0.2", "--params", fit,
                   "--seed", std::to_string(seed), "--out", dir.File("r.png")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const cv::Mat generated = ReadImage(dir.File("ds/images/seafloor_000000.png"));
  const cv::Mat rendered = ReadImage(dir.File("r.png"));
  ASSERT_EQ(generated.size(), rendered.size());
  EXPECT_EQ(cv::norm(generated, rendered, cv::NORM_INF), 0.0);
  // The same options, the fitted water among them.
  const json fitted = ReadJson(fit);
  EXPECT_EQ(sidecar["options"], ReadJson(dir.File("r.json"))["options"]);
  EXPECT_EQ(sidecar["options"]["water"], fitted["water"]);
  EXPECT_EQ(sidecar["options"]["revised"], fitted["revised"]);
  EXPECT_EQ(sidecar["options"]["model"], "revised");
  const std::vector<json> rows = ManifestRows(dir.File("ds"));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0]["water_from"], fit);
}

TEST(GenerateWaterFrom, BaseUnderGridAndRandomOverTheFit) {
  TempDir dir;
  const std::string fit = dir.Write("w.json", R"({"model": "revised", "water": {"type": "custom",
        "beta_rgb_per_m": [0.5, 0.2, 0.1], "ambient_gray": 0.4}, "light": {"lights": []}})");
  GenerateConfig config = ParseGenerateConfig(
      {{"scenes", {"builtin:seafloor"}},
       {"base", {{"sensor", {{"enabled", false}}}, {"water", {{"type", "IB"}}}}},
       {"grid", {{"water.ambient_gray", {0.1, 0.2}}}},
       {"water_from", fit}},
      "<dict>");
  const std::vector<GenerateItem> items = ExpandGenerateItems(config, {"seafloor"});
  ASSERT_EQ(items.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const json& p = items[i].params;
    EXPECT_EQ(p["water"]["type"], "custom");  // the fit over the base
    EXPECT_EQ(p["water"]["beta_rgb_per_m"], json({0.5, 0.2, 0.1}));
    EXPECT_EQ(p["water"]["ambient_gray"], i == 0 ? 0.1 : 0.2);  // the grid over the fit
    EXPECT_EQ(p["sensor"]["enabled"], false);                   // the base where the fit is silent
    EXPECT_EQ(p["light"]["lights"], json::array());
    EXPECT_EQ(items[i].water_from, fit);
  }
}

// Three waters that differ in β; which one an item got is read back from its parameters.
std::vector<std::string> ThreeWaters(const TempDir& dir) {
  std::vector<std::string> paths;
  for (int i = 0; i < 3; ++i) {
    const double beta = 0.1 * (i + 1);
    paths.push_back(
        dir.Write("w" + std::to_string(i) + ".json", json({{"model", "revised"},
                                                           {"water",
                                                            {{"type", "custom"},
                                                             {"beta_rgb_per_m", {beta, beta, beta}},
                                                             {"beta_gray_per_m", beta}}}})
                                                         .dump()));
  }
  return paths;
}

TEST(GenerateWaterFrom, AListIsSampledReproduciblyPerItem) {
  TempDir dir;
  const std::vector<std::string> waters = ThreeWaters(dir);
  auto config_with = [&](uint64_t seed) {
    return ParseGenerateConfig({{"scenes", {"builtin:seafloor", "hull"}},
                                {"seed", seed},
                                {"random", {{"count", 300}}},
                                {"water_from", waters}},
                               "<dict>");
  };
  const GenerateConfig config = config_with(4);
  const std::vector<GenerateItem> items = ExpandGenerateItems(config, {"seafloor", "hull"});
  ASSERT_EQ(items.size(), 600u);
  std::map<std::string, int> counts;
  for (size_t i = 0; i < items.size(); ++i) {
    const GenerateItem& item = items[i];
    ++counts[item.water_from];
    // The item's water is the file it names.
    const int w =
        static_cast<int>(std::find(waters.begin(), waters.end(), item.water_from) - waters.begin());
    ASSERT_LT(w, 3);
    EXPECT_DOUBLE_EQ(item.params["water"]["beta_gray_per_m"].get<double>(), 0.1 * (w + 1));
    // Draws depend on (seed, sample), not on the scene, as every random draw of generate.
    if (i >= 300) EXPECT_EQ(item.water_from, items[i - 300].water_from);
  }
  // Uniform: each of the three within 5 standard deviations of 100 of 300 draws (sd 8.2).
  ASSERT_EQ(counts.size(), 3u);
  for (const auto& [path, n] : counts) EXPECT_NEAR(n / 2, 100, 41) << path;
  // The same config gives the same choices; another seed other choices.
  const std::vector<GenerateItem> again = ExpandGenerateItems(config_with(4), {"seafloor", "hull"});
  const std::vector<GenerateItem> other = ExpandGenerateItems(config_with(5), {"seafloor", "hull"});
  int same = 0, differ = 0;
  for (size_t i = 0; i < items.size(); ++i) {
    same += items[i].water_from == again[i].water_from;
    differ += items[i].water_from != other[i].water_from;
  }
  EXPECT_EQ(same, 600);
  EXPECT_GT(differ, 300);  // two independent choices among 3 differ 2/3 of the time
  // WaterFromIndex is DrawItemParams' choice.
  for (uint64_t d = 0; d < 20; ++d)
    EXPECT_EQ(DrawItemParams(config, 0, d)["water"]["beta_gray_per_m"].get<double>(),
              0.1 * (WaterFromIndex(config, d) + 1));
}

TEST(GenerateWaterFrom, AListThroughTheCliWritesWhichFitEachItemUsed) {
  TempDir dir;
  const std::vector<std::string> waters = ThreeWaters(dir);
  dir.Write("g.json", json({{"scenes", {"builtin:seafloor"}},
                            {"scale", 0.05},
                            {"random", {{"count", 6}, {"seed", 2}}},
                            {"water_from", waters}})
                          .dump());
  auto run = RunTurbid({"generate", dir.File("g.json"), "--out", dir.File("a")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = RunTurbid({"generate", dir.File("g.json"), "--out", dir.File("b"), "--threads", "2"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(ReadFileText(dir.File("a/manifest.jsonl")), ReadFileText(dir.File("b/manifest.jsonl")));
  const GenerateConfig config = ParseGenerateConfig(ReadJson(dir.File("g.json")), "g.json");
  const std::vector<json> rows = ManifestRows(dir.File("a"));
  ASSERT_EQ(rows.size(), 6u);
  for (size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i]["water_from"], waters.at(WaterFromIndex(config, i)));
    const json sidecar = ReadJson(dir.File("a/" + rows[i]["sidecar"].get<std::string>()));
    EXPECT_EQ(sidecar["options"]["water"]["beta_gray_per_m"],
              ReadJson(rows[i]["water_from"])["water"]["beta_gray_per_m"]);
  }
}

TEST(GenerateWaterFrom, ErrorsNameTheFile) {
  TempDir dir;
  auto expect_error = [&](const json& water_from, const std::vector<std::string>& parts) {
    dir.Write("g.json",
              json({{"scenes", {"builtin:seafloor"}}, {"water_from", water_from}}).dump());
    const auto run = RunTurbid({"generate", dir.File("g.json"), "--out", dir.File("out")});
    EXPECT_EQ(run.exit_code, 1) << water_from.dump();
    for (const std::string& part : parts)
      EXPECT_NE(run.err.find(part), std::string::npos) << part << " not in: " << run.err;
  };
  const std::string missing = dir.File("no_such_fit.json");
  expect_error(missing, {missing});
  const std::string good = dir.Write("good.json", R"({"model": "revised"})");
  expect_error(json({good, missing}), {missing});
  const std::string extra =
      dir.Write("extra.json", R"({"model": "revised", "psf": {"enabled": false}})");
  expect_error(extra, {extra, "'psf'", "not part of a water"});
  const std::string typo = dir.Write("typo.json", R"({"water": {"beta_rgb_per_n": [1, 1, 1]}})");
  expect_error(typo, {typo, "beta_rgb_per_n"});
  const std::string not_json = dir.Write("broken.json", "{\"model\": ");
  expect_error(not_json, {not_json});
  const std::string null = dir.Write("null.json", R"({"water": null})");
  expect_error(null, {null, "water", "null"});
  const std::string array = dir.Write("array.json", "[1, 2]");
  expect_error(array, {array, "JSON object"});
  expect_error(json::array(), {"g.json", "water_from"});
  expect_error(5, {"g.json", "water_from"});
  expect_error(json({good, 3}), {"g.json", "water_from"});
  EXPECT_THROW(ReadWaterSource(""), Error);
}

}  // namespace
}  // namespace turbid
