// Experiment parsing, validation (everything rejected before work starts), item expansion,
// seeded sampling and shards.
#include <gtest/gtest.h>

#include <functional>
#include <set>

#include "core/error.h"
#include "tests/support/test_support.h"
#include "tests/tools/harness_fakes.h"
#include "tools/harness/experiment.h"

namespace turbid {
namespace {

using nlohmann::json;
using testing::FakeCatalog;
using testing::FakeExperimentJson;

// The first line of the error thrown by parsing `experiment`, or "" when it parses.
std::string ParseError(const json& experiment) {
  try {
    ParseExperiment(experiment, "exp.json", FakeCatalog());
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

TEST(HarnessExperiment, ParsesAndAddsReferenceRows) {
  const Experiment e = ParseExperiment(FakeExperimentJson(), "exp.json", FakeCatalog());
  EXPECT_EQ(e.name, "fake");
  ASSERT_EQ(e.methods.size(), 5u);
  EXPECT_EQ(e.methods[0].label, "none");  // the degraded input, always first
  EXPECT_EQ(e.methods[1].label,
            "oracle");  // the oracle-parameter LMMSE reference, added because it exists
  EXPECT_EQ(e.methods[2].label, "fake_a");
  EXPECT_EQ(e.methods[3].label, "fake_a2");
  EXPECT_EQ(e.methods[3].params, json({{"gain", 2}}));
  EXPECT_EQ(e.best_excludes, (std::vector<std::string>{"none", "oracle"}));
  EXPECT_EQ(e.ConditionCount(), 12);
  EXPECT_EQ(e.ItemCount(), 24);
  EXPECT_EQ(e.level_path, "water.beta");
  EXPECT_EQ(e.seed_path, "seed");
  EXPECT_EQ(e.render_resolved["water"]["beta"], 0.7);
}

TEST(HarnessExperiment, ItemsAreDeterministicOrderedAndSeeded) {
  const Experiment e = ParseExperiment(FakeExperimentJson(), "exp.json", FakeCatalog());
  const std::vector<ItemSpec> items = ExpandItems(e);
  ASSERT_EQ(items.size(), 24u);
  EXPECT_EQ(items[0].id, "a-c0000");
  EXPECT_EQ(items[12].id, "b-c0000");
  std::set<std::string> ids;
  std::set<uint64_t> seeds;
  for (size_t i = 0; i < items.size(); ++i) {
    EXPECT_EQ(items[i].index, static_cast<int>(i));
    if (i > 0 && items[i].scene_index == items[i - 1].scene_index) {
      EXPECT_LT(items[i - 1].id, items[i].id);  // ids sort like the global order within a scene
    }
    ids.insert(items[i].id);
    seeds.insert(items[i].seed);
    EXPECT_EQ(items[i].render_options["seed"], items[i].seed);
    EXPECT_EQ(items[i].render_options["water"]["beta"], items[i].params["water.beta"]);
    const std::string type = items[i].params["water.type"].get<std::string>();
    EXPECT_TRUE(type == "x" || type == "y");
  }
  EXPECT_EQ(ids.size(), 24u);
  EXPECT_EQ(seeds.size(), 24u);
  // Grid point g holds conditions 3g..3g+2 (3 samples per point).
  EXPECT_EQ(items[4].params["water.beta"], 0.5);
  EXPECT_EQ(items[4].level, "0.5");
  EXPECT_EQ(LevelLabels(e), (std::vector<std::string>{"0.1", "0.5", "1", "2"}));
  // Same experiment, same items; a different sample seed changes the draws.
  const std::vector<ItemSpec> again = ExpandItems(e);
  for (size_t i = 0; i < items.size(); ++i) EXPECT_EQ(items[i].params, again[i].params);
  json other = FakeExperimentJson();
  other["samples"]["seed"] = 12;
  const std::vector<ItemSpec> changed =
      ExpandItems(ParseExperiment(other, "exp.json", FakeCatalog()));
  int differ = 0;
  for (size_t i = 0; i < items.size(); ++i) differ += items[i].params != changed[i].params;
  EXPECT_GT(differ, 0);
}

TEST(HarnessExperiment, RandomSamplesStayInRangeAndBinLevels) {
  json in = FakeExperimentJson();
  in.erase("grid");
  in["samples"] = {
      {"count", 200}, {"seed", 3}, {"params", {{"water.beta", {{"log_uniform", {0.05, 5.0}}}}}}};
  in["level_bins"] = 3;
  const Experiment e = ParseExperiment(in, "exp.json", FakeCatalog());
  const std::vector<ItemSpec> items = ExpandItems(e);
  ASSERT_EQ(items.size(), 400u);
  double low = 1e9, high = -1e9;
  std::set<std::string> levels;
  for (const ItemSpec& item : items) {
    const double beta = item.params["water.beta"].get<double>();
    low = std::min(low, beta);
    high = std::max(high, beta);
    levels.insert(item.level);
  }
  EXPECT_GE(low, 0.05);
  EXPECT_LE(high, 5.0);
  EXPECT_LT(low, 0.1);  // 200 log-uniform draws reach both ends of two decades
  EXPECT_GT(high, 2.5);
  EXPECT_EQ(levels.size(), 3u);
  EXPECT_EQ(LevelLabels(e).size(), 3u);
  EXPECT_EQ(LevelLabels(e).front(), "0.05-0.232079");
}

TEST(HarnessExperiment, NamedAxisSetsSeveralPathsTogether) {
  json in = FakeExperimentJson();
  in.erase("samples");
  in["grid"] = json::parse(R"({"@turbidity": [
      {"label": "clear", "water.beta": 0.1, "water.type": "x"},
      {"label": "murky", "water.beta": 2.0, "water.type": "y", "x": 2}]})");
  const Experiment e = ParseExperiment(in, "exp.json", FakeCatalog());
  const std::vector<ItemSpec> items = ExpandItems(e);
  ASSERT_EQ(items.size(), 4u);
  EXPECT_EQ(items[1].level, "murky");
  EXPECT_EQ(items[1].level_value, 2.0);
  EXPECT_EQ(items[1].render_options["water"], json({{"beta", 2.0}, {"type", "y"}}));
}

TEST(HarnessExperiment, BadFilesAreRejectedWithOneLineErrors) {
  const auto expect_error = [](const json& in, const std::string& fragment) {
    const std::string message = ParseError(in);
    EXPECT_NE(message.find(fragment), std::string::npos) << "got: '" << message << "'";
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_EQ(message.rfind("exp.json: ", 0), 0u) << message;
  };
  json in = FakeExperimentJson();
  in["methods"] = {"fake_a", "nosuch"};
  expect_error(in, "unknown method 'nosuch'");
  in = FakeExperimentJson();
  // json::array: a braced list holding one json is a copy of it under clang, an array under GCC.
  in["methods"] = json::array({json{{"name", "fake_b"}, {"params", {{"gain", 1}}}}});
  expect_error(in, "has no parameter 'gain'");
  in = FakeExperimentJson();
  in["metrics"] = {"up", "nosuch"};
  expect_error(in, "unknown metric 'nosuch'");
  in = FakeExperimentJson();
  in["grid"] = json::object();
  expect_error(in, "'grid' is empty");
  in = FakeExperimentJson();
  in["grid"] = {{"water.beta", json::array()}};
  expect_error(in, "empty grid");
  in = FakeExperimentJson();
  in.erase("grid");
  in.erase("samples");
  expect_error(in, "empty grid");
  in = FakeExperimentJson();
  in["grid"] = {{"water.beta", {{"linspace", {2.0, 1.0, 3}}}}};
  expect_error(in, "range is empty");
  in = FakeExperimentJson();
  in.erase("grid");
  in["samples"]["params"] = {{"water.beta", {{"uniform", {3.0, 1.0}}}}};
  expect_error(in, "range is empty");
  in = FakeExperimentJson();
  in["grid"] = {{"water.beta", {0.1, 20.0}}};  // outside the simulator's accepted range
  expect_error(in, "water.beta must be in [0, 10]");
  in = FakeExperimentJson();
  in["grid"] = {{"water.nosuch", {1, 2}}};
  expect_error(in, "unknown key 'water.nosuch'");
  in = FakeExperimentJson();
  in["gird"] = in["grid"];
  expect_error(in, "unknown key 'gird'");
  in = FakeExperimentJson();
  in["scenes"] = {"builtin:zzz"};
  expect_error(in, "unknown scene");
  in = FakeExperimentJson();
  in["scenes"] = json::array();
  expect_error(in, "'scenes' must be a non-empty array");
  in = FakeExperimentJson();
  in["ground_truth"] = "dirty";
  expect_error(in, "'ground_truth'");
  in = FakeExperimentJson();
  in["methods"] = {"fake_a", "fake_a"};
  expect_error(in, "used twice");
  in = FakeExperimentJson();
  in["level"] = "water.other";
  expect_error(in, "is not a parameter");
  in = FakeExperimentJson();
  in["samples"]["count"] = 0;
  expect_error(in, "'samples.count'");
  in = FakeExperimentJson();
  in["scale"] = 1.5;
  expect_error(in, "'scale': must be in (0, 1]");
}

// Every object of an experiment file is read through its field table: unknown keys and wrong
// types anywhere are one line naming the key's whole path (issue 29 item 1).
TEST(HarnessExperiment, EveryObjectNamesTheKeyPath) {
  const auto error_of = [](const json& in) -> std::string {
    try {
      ParseExperiment(in, "exp.json", FakeCatalog());
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  json in = FakeExperimentJson();
  in["scenes"] = json::array({"builtin:a", {{"spec", "builtin:b"}, {"name", "b"}, {"scale", 2}}});
  EXPECT_EQ(error_of(in), "exp.json: 'scenes[1].scale': must be in (0, 1], got 2");
  in["scenes"][1] = {{"spec", "builtin:b"}, {"nmae", "b"}};
  EXPECT_EQ(error_of(in),
            "exp.json: unknown key 'scenes[1].nmae' (known: spec, name, scale, trajectory)");
  in["scenes"][1] = {{"spec", "builtin:b"}, {"name", 7}};  // was silently the default name
  EXPECT_EQ(error_of(in), "exp.json: 'scenes[1].name': expected a string, got 7");
  in = FakeExperimentJson();
  in["samples"]["cout"] = 3;
  EXPECT_EQ(error_of(in), "exp.json: unknown key 'samples.cout' (known: count, seed, params)");
  in = FakeExperimentJson();
  in["methods"] = json::array({{{"name", "fake_a"}, {"label", false}}});  // was silently the name
  EXPECT_EQ(error_of(in), "exp.json: 'methods[0].label': expected a string, got false");
  in["methods"] = json::array({{{"name", "fake_a"}, {"parms", json::object()}}});
  EXPECT_EQ(error_of(in), "exp.json: unknown key 'methods[0].parms' (known: name, label, params)");
  in = FakeExperimentJson();
  in["metrics"] = json::array({"ssim", 3});
  EXPECT_EQ(error_of(in), "exp.json: 'metrics': [1]: expected a string, got 3");
  in = FakeExperimentJson();
  in["thumbnails"] = 5000;
  EXPECT_EQ(error_of(in),
            "exp.json: 'thumbnails': expected true, false or a width in pixels in [0, 4096], got "
            "5000");
  in["thumbnails"] = false;
  EXPECT_EQ(ParseExperiment(in, "exp.json", FakeCatalog()).thumbnail_width, 0);
  in = FakeExperimentJson();
  in["split"] = "train";
  EXPECT_EQ(error_of(in), "exp.json: 'split': expected one of tuning, evaluation, got \"train\"");
  in = FakeExperimentJson();
  in["level_bins"] = 2.5;
  EXPECT_EQ(error_of(in), "exp.json: 'level_bins': expected an integer, got 2.5");
}

// An edited resolved experiment.json: integers that are floats out of range, strings or
// fractions are one line naming the key (never a float-to-int cast, which is undefined).
TEST(HarnessExperiment, ResolvedJsonIntegersAreReadStrictly) {
  const json good = ParseExperiment(FakeExperimentJson(), "exp.json", FakeCatalog()).ToJson();
  const auto error_of = [&](const std::function<void(json&)>& edit) {
    json in = good;
    edit(in);
    try {
      ExperimentFromResolvedJson(in, "experiment.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error_of([](json& j) { j["seed"] = 1e300; }).find("experiment.json: 'seed' must be"),
            std::string::npos);
  EXPECT_NE(error_of([](json& j) { j["seed"] = -1; }).find("'seed' must be"), std::string::npos);
  EXPECT_NE(error_of([](json& j) { j["samples"]["count"] = -1e300; }).find("'samples.count'"),
            std::string::npos);
  EXPECT_NE(error_of([](json& j) { j["level"]["bins"] = 2.5; }).find("'level.bins'"),
            std::string::npos);
  EXPECT_NE(error_of([](json& j) { j["thumbnail_width"] = "96"; }).find("'thumbnail_width'"),
            std::string::npos);
  EXPECT_EQ(error_of([](json& j) { j["seed"] = 7.0; }), "");  // 7.0 is the integer 7
}

TEST(HarnessExperiment, ResolvedJsonRoundTrips) {
  const Experiment e = ParseExperiment(FakeExperimentJson(), "exp.json", FakeCatalog());
  const Experiment back = ExperimentFromResolvedJson(e.ToJson(), "x");
  EXPECT_EQ(back.ToJson(), e.ToJson());
  const std::vector<ItemSpec> a = ExpandItems(e), b = ExpandItems(back);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].id, b[i].id);
    EXPECT_EQ(a[i].render_options, b[i].render_options);
  }
}

TEST(HarnessExperiment, ShardsPartitionTheItems) {
  EXPECT_EQ(ParseShard("2/5").index, 2);
  EXPECT_EQ(ParseShard("2/5").count, 5);
  EXPECT_THROW(ParseShard("5/5"), Error);
  EXPECT_THROW(ParseShard("-1/5"), Error);
  EXPECT_THROW(ParseShard("1"), Error);
  EXPECT_THROW(ParseShard("1/x"), Error);
  int covered = 0;
  for (int i = 0; i < 3; ++i) {
    for (int item = 0; item < 10; ++item) covered += Shard{i, 3}.Contains(item);
  }
  EXPECT_EQ(covered, 10);
}

TEST(HarnessExperiment, JsonPaths) {
  json root = json::object();
  SetJsonPath(root, "a.b.c", 3);
  EXPECT_EQ(root, json::parse(R"({"a": {"b": {"c": 3}}})"));
  ASSERT_NE(FindJsonPath(root, "a.b"), nullptr);
  EXPECT_EQ(FindJsonPath(root, "a.x"), nullptr);
  root["v"] = 1;
  EXPECT_THROW(SetJsonPath(root, "v.w", 2), Error);
  EXPECT_THROW(SetJsonPath(root, "a..b", 2), Error);
}

}  // namespace
}  // namespace turbid
