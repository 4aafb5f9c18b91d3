// `turbid enhance` end to end: --list, oracle and full on a render, --dump-steps, errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "tests/support/test_support.h"

namespace turbid {
namespace {

using testing::RunTurbid;
using testing::TempDir;

TEST(EnhanceCli, ListShowsMethodsAndDefaults) {
  const auto r = RunTurbid({"enhance", "--list"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* s : {"full", "simplified", "oracle", "denoise_radius = 4", "alpha = 5.0"}) {
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
  }
}

TEST(EnhanceCli, OracleFullDumpStepsAndErrors) {
  TempDir dir;
  auto r = RunTurbid({"render", "--scene", "hull", "--scale", "0.2", "--bit-depth", "16", "--out",
                      dir.File("h.png")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunTurbid({"enhance", "--method", "oracle", dir.File("h.png"), dir.File("o.png"), "--sidecar",
                 dir.File("h.json")});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.File("o.png")));
  r = RunTurbid({"enhance", "--method", "full", dir.File("h.png"), dir.File("f.png"), "--sidecar",
                 dir.File("h.json"), "--dump-steps", dir.File("steps"), "--param",
                 "clahe_distribution=uniform"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"01_denoised.exr", "02_light.exr", "04_dehazed.exr", "steps.json"}) {
    EXPECT_TRUE(std::filesystem::exists(dir.File(std::string("steps/") + f))) << f;
  }
  // --scene naming the sidecar's scene takes the render's scale (0.2) from the sidecar; the
  // privileged full_matched names the water the sidecar gives (default render water, gray), the
  // blind default the paper's fixed beta; both report e per step and the light scale.
  r = RunTurbid({"enhance", "--method", "full_matched", dir.File("h.png"), dir.File("g.png"),
                 "--sidecar", dir.File("h.json"), "--scene", "hull", "--dump-steps",
                 dir.File("steps2")});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("99_output: e = "), std::string::npos) << r.out;
  {
    std::ifstream in(dir.File("steps2/steps.json"));
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_NE(text.str().find("(sidecar water)"), std::string::npos) << text.str();
    EXPECT_NE(text.str().find("\"visible_edges\""), std::string::npos) << text.str();
  }
  {
    std::ifstream in(dir.File("steps/steps.json"));
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_NE(text.str().find("(beta_per_m)"), std::string::npos) << text.str();
    EXPECT_NE(text.str().find("blind scaling"), std::string::npos) << text.str();
  }
  r = RunTurbid({"enhance", "--list"});
  EXPECT_NE(r.out.find("full_physical [privileged]"), std::string::npos) << r.out;
  r = RunTurbid(
      {"enhance", "--method", "full", dir.File("h.png"), dir.File("g2.png"), "--scene", "hull"});
  EXPECT_NE(r.exit_code, 0);  // no sidecar: the scene at scale 1 does not fit the image
  EXPECT_NE(r.err.find("camera"), std::string::npos) << r.err;
  // Existing output without --force, unknown method, bad parameter, oracle without sidecar.
  r = RunTurbid({"enhance", "--method", "full", dir.File("h.png"), dir.File("f.png")});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--force"), std::string::npos);
  r = RunTurbid({"enhance", "--method", "nope", dir.File("h.png"), dir.File("x.png")});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("unknown method"), std::string::npos);
  r = RunTurbid({"enhance", "--method", "simplified", dir.File("h.png"), dir.File("x.png"),
                 "--param", "alfa=2"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("alfa"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.File("x.png")));
  r = RunTurbid({"enhance", "--method", "oracle", dir.File("h.png"), dir.File("x.png")});
  EXPECT_NE(r.exit_code, 0);
  // Each -p takes one value, so the positionals may follow repeated parameters.
  r = RunTurbid({"enhance", "-m", "clahe", "-p", "clip_limit=0.02", "-p", "tiles_x=4",
                 dir.File("h.png"), dir.File("c.png")});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.File("c.png")));
  // Usage errors exit 2 (docs/cli.md), bad values 1.
  r = RunTurbid({"enhance", "--no-such-flag"});
  EXPECT_EQ(r.exit_code, 2);
}

// --dump-steps works for every registered method through EnhanceInput::steps (no special case in
// the CLI): the input, the output, steps.json and, for every method that reports them, at least
// one named intermediate. The oracles (enhancer/oracle.cc) report none yet.
TEST(EnhanceCli, DumpStepsForEveryMethod) {
  TempDir dir;
  auto r = RunTurbid({"render", "--scene", "hull", "--scale", "0.1", "--bit-depth", "16", "--out",
                      dir.File("h.png")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunTurbid({"enhance", "--list", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json methods = nlohmann::json::parse(r.out);
  ASSERT_GE(methods.size(), 10u);
  const std::set<std::string> no_intermediates = {"oracle", "oracle_exact"};
  for (const nlohmann::json& m : methods) {
    const std::string name = m["name"], steps = dir.File("steps_" + name);
    r = RunTurbid({"enhance", "--method", name, dir.File("h.png"), dir.File(name + ".png"),
                   "--sidecar", dir.File("h.json"), "--dump-steps", steps});
    ASSERT_EQ(r.exit_code, 0) << name << ": " << r.err;
    EXPECT_NE(r.out.find("99_output: e = "), std::string::npos) << name << ": " << r.out;
    int intermediates = 0;
    for (const auto& entry : std::filesystem::directory_iterator(steps)) {
      const std::string file = entry.path().filename().string();
      if (file != "00_input.exr" && file != "99_output.exr" && file != "steps.json") {
        ++intermediates;
      }
    }
    for (const char* f : {"00_input.exr", "99_output.exr", "steps.json"}) {
      EXPECT_TRUE(std::filesystem::exists(steps + "/" + f)) << name << ": " << f;
    }
    if (!no_intermediates.count(name)) {
      EXPECT_GE(intermediates, 1) << name;
    }
  }
}

}  // namespace
}  // namespace turbid
