// One configuration language (issue 33 item 3): dotted paths and nested objects are the same
// parameters in generate's "base" and "random.params", a sweep's "render" and "samples.params",
// and `--set`; unknown keys and malformed samplers are errors in each.
#include "tools/harness/param_tree.h"

#include <gtest/gtest.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "core/error.h"
#include "simulator/render_options.h"
#include "tests/tools/harness_fakes.h"
#include "tools/harness/experiment.h"
#include "tools/harness/generate.h"

namespace turbid {
namespace {

using nlohmann::json;

std::string ErrorOf(const std::function<void()>& body) {
  try {
    body();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

const json kChoice = {{"choice", {"I", "3C", "5C"}}};
const json kUniform = {{"uniform", {0.2, 0.8}}};
const json kLog = {{"log_uniform", {0.5, 20.0}}};

TEST(ParamTree, FlattensNestedSamplersInDottedOrder) {
  const json nested = {{"water", {{"type", kChoice}}},
                       {"psf", {{"forward_scatter", kUniform}}},
                       {"snow.density_per_m3", kLog}};
  const json flat = FlattenSamplers(nested, "f.json", "random.params");
  EXPECT_EQ(flat, json({{"water.type", kChoice},
                        {"psf.forward_scatter", kUniform},
                        {"snow.density_per_m3", kLog}}));
  std::vector<std::string> order;
  for (auto it = flat.begin(); it != flat.end(); ++it) order.push_back(it.key());
  EXPECT_EQ(order,
            (std::vector<std::string>{"psf.forward_scatter", "snow.density_per_m3", "water.type"}));
  // Deeper trees, and a dotted key inside a nested object.
  EXPECT_EQ(FlattenSamplers(json{{"light", {{"lights.0", {{"power", kLog}}}}}}, "f", "r"),
            json({{"light.lights.0.power", kLog}}));
}

TEST(ParamTree, RejectsConstantsDuplicatesAndEmptyObjects) {
  const auto error = [](const json& tree) {
    return ErrorOf([&] { FlattenSamplers(tree, "f.json", "random.params"); });
  };
  EXPECT_EQ(error(json{{"water", {{"type", "3C"}}}}),
            "f.json: random.params.water.type must be a distribution {\"uniform\"|\"log_uniform\"|"
            "\"int_uniform\": [lo, hi]} or {\"choice\": [values...]}, or an object of them");
  EXPECT_EQ(error(json{{"water", {{"type", kChoice}}}, {"water.type", kChoice}}),
            "f.json: random.params.water.type is given twice (as a dotted path and nested)");
  EXPECT_EQ(error(json{{"water", json::object()}}),
            "f.json: random.params.water: an empty object (a distribution or parameters under "
            "it)");
  EXPECT_EQ(error(json::array()),
            "f.json: random.params must be an object {path: distribution} (paths dotted or "
            "nested)");
  // A misspelt distribution stays a distribution, so that its name is reported.
  EXPECT_TRUE(IsDistributionSpec(json{{"choise", {1, 2}}}));
  EXPECT_FALSE(IsDistributionSpec(json{{"type", kChoice}}));
}

json GenerateBase() { return {{"scenes", {"builtin:seafloor"}}, {"scale", 0.05}, {"seed", 4}}; }

std::vector<json> ItemParams(const json& config) {
  const GenerateConfig c = ParseGenerateConfig(config, "gen.json");
  std::vector<json> out;
  for (const GenerateItem& item : ExpandGenerateItems(c, {"seafloor"})) out.push_back(item.params);
  return out;
}

TEST(ParamTree, GenerateRandomAndBaseTakeBothSpellings) {
  json dotted = GenerateBase(), nested = GenerateBase();
  dotted["base"] = {{"sensor.read_noise", 0.004}, {"snow.enabled", true}};
  nested["base"] = {{"sensor", {{"read_noise", 0.004}}}, {"snow", {{"enabled", true}}}};
  dotted["random"] = {{"count", 6},
                      {"params",
                       {{"water.type", kChoice},
                        {"psf.forward_scatter", kUniform},
                        {"snow.density_per_m3", kLog}}}};
  nested["random"] = {{"count", 6},
                      {"params",
                       {{"water", {{"type", kChoice}}},
                        {"psf", {{"forward_scatter", kUniform}}},
                        {"snow", {{"density_per_m3", kLog}}}}}};
  const std::vector<json> a = ItemParams(dotted), b = ItemParams(nested);
  ASSERT_EQ(a.size(), 6u);
  EXPECT_EQ(a, b);
  std::vector<std::string> types;
  for (const json& p : a) {
    EXPECT_EQ(p["sensor"]["read_noise"], 0.004);
    EXPECT_EQ(p["snow"]["enabled"], true);
    const double g = p["psf"]["forward_scatter"].get<double>();
    EXPECT_GE(g, 0.2);
    EXPECT_LE(g, 0.8);
    types.push_back(p["water"]["type"].get<std::string>());
  }
  EXPECT_GT(std::set<std::string>(types.begin(), types.end()).size(), 1u);
  // Unknown parameter paths are errors in either spelling.
  json bad = GenerateBase();
  bad["random"] = {{"params", {{"water", {{"tpye", kChoice}}}}}};
  EXPECT_NE(ErrorOf([&] { ItemParams(bad); }).find("tpye"), std::string::npos);
  bad["random"] = {{"params", {{"water", {{"type", "3C"}}}}}};
  EXPECT_EQ(
      ErrorOf([&] { ItemParams(bad); }).rfind("gen.json: random.params.water.type must be", 0), 0u);
  bad = GenerateBase();
  bad["base"] = {{"water.tpye", "3C"}};
  EXPECT_NE(ErrorOf([&] { ItemParams(bad); }).find("tpye"), std::string::npos);
}

TEST(ParamTree, SweepSamplesAndRenderTakeBothSpellings) {
  // (The fake catalog's render options are water.beta and water.type.)
  json dotted = testing::FakeExperimentJson();
  dotted.erase("grid");
  dotted["level"] = "water.beta";
  json nested = dotted;
  const json log = {{"log_uniform", {0.05, 5.0}}}, types = {{"choice", {"x", "y"}}};
  dotted["samples"] = {
      {"count", 5}, {"seed", 3}, {"params", {{"water.beta", log}, {"water.type", types}}}};
  nested["samples"] = {
      {"count", 5}, {"seed", 3}, {"params", {{"water", {{"beta", log}, {"type", types}}}}}};
  dotted["render"] = {{"water.beta", 0.3}};
  nested["render"] = {{"water", {{"beta", 0.3}}}};
  const Experiment a = ParseExperiment(dotted, "exp.json", testing::FakeCatalog());
  const Experiment b = ParseExperiment(nested, "exp.json", testing::FakeCatalog());
  EXPECT_EQ(a.render, b.render);
  EXPECT_EQ(a.render, json({{"water", {{"beta", 0.3}}}}));
  const std::vector<ItemSpec> ia = ExpandItems(a), ib = ExpandItems(b);
  ASSERT_EQ(ia.size(), ib.size());
  ASSERT_GT(ia.size(), 0u);
  std::set<std::string> seen;
  for (size_t i = 0; i < ia.size(); ++i) {
    EXPECT_EQ(ia[i].params, ib[i].params);
    EXPECT_EQ(ia[i].render_options, ib[i].render_options);
    seen.insert(ia[i].params["water.type"].get<std::string>());
  }
  EXPECT_EQ(seen.size(), 2u);
  json bad = nested;
  bad["samples"]["params"] = {{"water", {{"beta", 0.3}}}};
  EXPECT_EQ(ErrorOf([&] {
              ParseExperiment(bad, "exp.json", testing::FakeCatalog());
            }).rfind("exp.json: 'samples.params'.water.beta must be a distribution", 0),
            0u);
  bad["samples"]["params"] = {{"water", {{"bta", log}}}};
  bad["level"] = "water.bta";
  EXPECT_NE(ErrorOf([&] { ParseExperiment(bad, "exp.json", testing::FakeCatalog()); }).find("bta"),
            std::string::npos);
}

TEST(ParamTree, SetMergesAnObjectAndTakesDottedPaths) {
  json params = {{"water", {{"type", "3C"}, {"beta", 0.2}}}};
  ApplyRenderSet(params, R"(water={"beta": 0.5, "phase": {"g": 0.9}})");
  EXPECT_EQ(params["water"], json({{"type", "3C"}, {"beta", 0.5}, {"phase", {{"g", 0.9}}}}));
  ApplyRenderSet(params, "water.type=II");
  EXPECT_EQ(params["water"]["type"], "II");
  // Both spellings give the same options.
  json a = json::object(), b = json::object();
  ApplyRenderSet(a, R"(psf={"forward_scatter": 0.3})");
  ApplyRenderSet(b, "psf.forward_scatter=0.3");
  EXPECT_EQ(a, b);
  EXPECT_EQ(RenderOptionsToJson(RenderOptionsFromJson(a)),
            RenderOptionsToJson(RenderOptionsFromJson(b)));
  // Unknown keys under a nested value are still the options reader's errors.
  json c = json::object();
  ApplyRenderSet(c, R"(water={"tpye": "3C"})");
  EXPECT_NE(ErrorOf([&] { RenderOptionsFromJson(c); }).find("tpye"), std::string::npos);
  // Dotted keys expand into the objects they name, merged with nested ones.
  EXPECT_EQ(ExpandDottedKeys(json{{"water", {{"type", "3C"}}}, {"water.beta", 0.5}}, "p"),
            json({{"water", {{"type", "3C"}, {"beta", 0.5}}}}));
}

}  // namespace
}  // namespace turbid
