// Regression tests of what the fuzzers of fuzz/ found (docs/reliability.md, "Fuzzing"): each input
// that once escaped as a non-turbid::Error exception or a sanitizer report is now a one-line Error
// naming the file and the key. The crash inputs themselves replay in fuzz/<name>.replay
// (build-san).
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"
#include "simulator/render.h"
#include "tests/support/test_support.h"
#include "tools/harness/generate.h"
#include "tools/harness/manifest.h"
#include "tools/harness/sweep.h"

namespace turbid {
namespace {

using nlohmann::json;

// The message `body` throws ("" when it throws nothing; marked when it is not a turbid::Error).
std::string ErrorOf(const std::function<void()>& body) {
  try {
    body();
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not a turbid::Error: ") + e.what();
  }
  return "";
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

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
      {"scale", json::object(), "gen.json: 'scale': expected a number, got {}"},
      {"seed", -1, "gen.json: 'seed': must be an integer in [0, 18446744073709551615], got -1"},
      {"seed", 1.5, "gen.json: 'seed': must be an integer in [0, 18446744073709551615], got 1.5"},
      {"format", 3, "gen.json: 'format': expected one of png, exr, got 3"},
      {"base", json::array(), "gen.json: 'base': expected an object, got []"},
      {"random", {{"count", 1e300}}, "gen.json: 'random.count': expected an integer, got 1e+300"},
      {"random", {{"count", "2"}}, "gen.json: 'random.count': expected an integer, got \"2\""},
      {"random", {{"count", 0}}, "gen.json: 'random.count': must be in [1, 1000000], got 0"},
      {"random",
       {{"seed", "x"}},
       "gen.json: 'random.seed': must be an integer in [0, 18446744073709551615], got \"x\""},
      {"random",
       {{"params", json::array({1, 2})}},
       "gen.json: 'random.params': expected an object, got [1,2]"},
      {"random", json::array(), "gen.json: 'random': expected an object, got []"},
  };
  for (const auto& c : cases) {
    json config = base;
    config[c.key] = c.value;
    EXPECT_EQ(GenerateError(config), c.expected) << config.dump();
  }
  EXPECT_EQ(GenerateError(base), "");
}

// generate's "random" and a sweep's "samples" read one sampler language (experiment_grid.h): the
// same distributions (int_uniform too), the same checks, and unknown keys are errors in both.
TEST(FuzzFindings, GenerateRandomSharesTheSweepSamplers) {
  const json base = {{"scenes", {"builtin:seafloor"}}, {"scale", 0.05}};
  json config = base;
  config["random"] = {{"count", 2}, {"parms", json::object()}};
  EXPECT_EQ(GenerateError(config),
            "gen.json: unknown key 'random.parms' (known: count, seed, params)");
  for (uint64_t i = 0; i < 200; ++i) {
    const json v = SampleValue(json{{"int_uniform", {2, 5}}}, 7, i, "sensor.bit_depth");
    ASSERT_TRUE(v.is_number_integer()) << v.dump();
    EXPECT_GE(v.get<int64_t>(), 2);
    EXPECT_LE(v.get<int64_t>(), 5);
  }
  const auto error_of = [](const json& spec) {
    try {
      SampleValue(spec, 1, 0, "water.beta");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error_of(json{{"uniform", {3, 1}}}),
            "generate: random.params.water.beta range is empty: lo 3 > hi 1");
  EXPECT_EQ(error_of(json{{"int_uniform", {1.5, 3}}}),
            "generate: random.params.water.beta int_uniform bounds must be integers");
  EXPECT_NE(error_of(json{{"normal", {0, 1}}}).find("unknown distribution 'normal'"),
            std::string::npos);
  config = base;
  config["random"] = {{"count", 2}, {"params", {{"sensor.bit_depth", {{"int_uniform", {8, 12}}}}}}};
  EXPECT_EQ(GenerateError(config), "");
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

TEST(FuzzFindings, ALightIndexFarPastTheListIsAnError) {
  // render_params_fuzzer: `--set light.lights.9999999999999.power=4` (and -1, read as the largest
  // index) appended default lights until memory ran out. An index may be the list's size (append
  // one) at most.
  for (const char* bad : {"light.lights.9999999999999.power=4", "light.lights.-1.power=4",
                          "light.lights.2.power=4", "light.lights.x.power=4"}) {
    json params = json::object();
    try {
      ApplyRenderSet(params, bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
      EXPECT_TRUE(message.find("past the end") != std::string::npos ||
                  message.find("not an array index") != std::string::npos)
          << message;
    }
  }
  json params = json::object();
  ApplyRenderSet(params, "light.lights.1.power=4");  // the default list has one light: append
  ASSERT_EQ(params["light"]["lights"].size(), 2u);
  EXPECT_EQ(params["light"]["lights"][1]["power"], 4);
  EXPECT_NO_THROW(RenderOptionsFromJson(params));
}

TEST(FuzzFindings, JournalLinesThatAreNotEntriesAreCorruptOrHaveNoId) {
  // journal_fuzzer: a number too large for a double and an id that is not a string escaped as
  // JSON library exceptions from Journal::Load (a resume, merge or report would print them).
  testing::TempDir dir;
  const std::string path = dir.path() + "/journal.jsonl";
  const struct {
    const char* text;
    const char* problem;
  } cases[] = {
      {"{\"id\": \"a\", \"x\": 2.3e1964}\n", "line 1 is corrupt"},
      {"{\"id\": 7}\n", "line 1 has no id"},
      {"[1, 2]\n", "line 1 has no id"},
      {"\"text\"\n", "line 1 has no id"},
      {"{\"id\": \"\"}\n", "line 1 has no id"},
  };
  for (const auto& c : cases) {
    WriteText(path, c.text);
    const std::string message = ErrorOf([&] { Journal(path).Load(false); });
    EXPECT_EQ(message.rfind(path + ": " + c.problem, 0), 0u) << c.text << " -> " << message;
  }
  WriteText(path, "{\"id\": \"a\"}\n{\"id\": \"b\", \"n\": 1}\n");
  EXPECT_EQ(Journal(path).Load(false).size(), 2u);
}

TEST(FuzzFindings, ManifestJsonLinesMustBeObjects) {
  // manifest_fuzzer: a .jsonl line holding an array escaped as nlohmann's invalid_iterator.
  testing::TempDir dir;
  const std::string path = dir.path() + "/manifest.jsonl";
  WriteText(path, "{\"image\": \"a.png\"}\n[1, 2]\n");
  EXPECT_EQ(ErrorOf([&] { ReadManifest(path); }), path + ": line 2 is not a JSON object");
  WriteText(path, "{\"image\": \"a.png\", \"n\": 3}\n\n");
  const std::vector<ManifestRecord> rows = ReadManifest(path);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].at("n"), "3");
}

}  // namespace
}  // namespace turbid
