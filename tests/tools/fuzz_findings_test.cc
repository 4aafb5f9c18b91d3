// Regression tests of what the fuzzers of fuzz/ found (docs/reliability.md, "Fuzzing"): each input
// that once escaped as a non-turbid::Error exception or a sanitizer report is now a one-line Error
// naming the file and the key. The crash inputs themselves replay in fuzz/<name>.replay (build-san).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <string>

#include "scenes/error.h"
#include "tools/generate.h"

namespace turbid {
namespace {

using nlohmann::json;

// The message ParseGenerateConfig throws for `config` ("" when it throws nothing or another type).
std::string GenerateError(const json& config) {
  try {
    ParseGenerateConfig(config, "gen.json");
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not a turbid::Error: ") + e.what();
  }
  return "";
}

TEST(FuzzFindings, GenerateConfigWrongTypesAreErrorsNamingTheKey) {
  const json base = {{"scenes", {"builtin:seafloor"}}, {"scale", 0.05}};
  const struct {
    const char* key;
    json value;
    const char* expected;
  } cases[] = {
      // generate_fuzzer: {"scenes": [...], "scale": {"count": 2, ...}} escaped as a JSON
      // library type_error without the file or the key.
      {"scale", json::object(), "gen.json: scale: must be a number"},
      {"seed", -1, "gen.json: seed: must be an integer >= 0"},
      {"seed", 1.5, "gen.json: seed: must be an integer >= 0"},
      {"format", 3, "gen.json: format: png or exr"},
      {"base", json::array(), "gen.json: base: must be an object"},
      {"random", {{"count", 1e300}}, "gen.json: random.count: must be in [1, 1e6]"},
      {"random", {{"count", "2"}}, "gen.json: random.count: must be in [1, 1e6]"},
      {"random", {{"seed", "x"}}, "gen.json: random.seed: must be an integer >= 0"},
      {"random", {{"params", json::array({1, 2})}}, "gen.json: random.params: must be an object"},
  };
  for (const auto& c : cases) {
    json config = base;
    config[c.key] = c.value;
    EXPECT_EQ(GenerateError(config), c.expected) << config.dump();
  }
  EXPECT_EQ(GenerateError(base), "");
}

TEST(FuzzFindings, SetALightAfterSettingLightToANumber) {
  // render_params_fuzzer: `--set light=7 --set light.lights.0.power=2` escaped as a JSON library
  // type_error. As for any other path, the non-object on the way is replaced.
  json params = json::object();
  ApplyRenderSet(params, "light=7");
  ApplyRenderSet(params, "light.lights.0.power=2");
  ASSERT_TRUE(params["light"].is_object());
  ASSERT_TRUE(params["light"]["lights"].is_array());
  EXPECT_EQ(params["light"]["lights"][0]["power"], 2);
  json replaced = {{"light", 7}};
  ApplyRenderSet(replaced, "light.min_distance_m=0.5");
  EXPECT_EQ(replaced["light"], json({{"min_distance_m", 0.5}}));
}

}  // namespace
}  // namespace turbid
