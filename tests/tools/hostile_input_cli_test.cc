// Hostile inputs through the real CLI (issue 28, items 6, 7, 9, 10): PSF kernels wider than the
// image, JSON nested 10^5 deep, duplicate keys and 1e999, inputs that are FIFOs, devices or
// folders, and method sizes far past the image. Each either works or ends in one line naming the
// file or flag, quickly: every run goes through `timeout` and a memory cap, so that a regression
// fails instead of hanging the suite.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/support/asan.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::TempDir;

// Under AddressSanitizer (TURBID_TEST_ASAN) `ulimit -v` stops the process from starting, so the
// cap is ASan's own (malloc_limit_mb, hard_rss_limit_mb: a report, a failure).

#ifdef TURBID_TEST_ASAN
constexpr const char* kMemoryCap =
    "ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:malloc_limit_mb=4000:hard_rss_limit_mb=4000\"; "
    "export ASAN_OPTIONS\n";
#else
constexpr const char* kMemoryCap = "ulimit -v 4000000\n";
#endif

// RunTurbid through a wrapper: at most 60 s and 4 GB of memory.
CliRun RunBounded(const TempDir& dir, const std::vector<std::string>& args) {
  const char* bin = std::getenv("TURBID_BIN");
  if (bin == nullptr) {
    ADD_FAILURE() << "TURBID_BIN is not set";
    return {};
  }
  const std::string real = bin;
  const std::string wrapper =
      dir.Write("bounded.sh",
                std::string("#!/bin/sh\n") + kMemoryCap + "exec timeout -s KILL 60 '" + real +
                    "' \"$@\"\n");
  fs::permissions(wrapper, fs::perms::owner_all);
  setenv("TURBID_BIN", wrapper.c_str(), 1);
  const CliRun run = testing::RunTurbid(args);
  setenv("TURBID_BIN", real.c_str(), 1);
  return run;
}

void ExpectOneErrorLine(const CliRun& run, const std::string& start, const std::string& part) {
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_EQ(run.err.rfind("turbid: error: " + start, 0), 0u) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_NE(run.err.find(part), std::string::npos) << run.err;
  EXPECT_LT(run.err.size(), 400u) << "a short line, not the input echoed";
}

std::string Nested(int levels) {
  return std::string(static_cast<size_t>(levels), '[') + "1" +
         std::string(static_cast<size_t>(levels), ']');
}

const char* kExperiment = R"({
  "name": "hostile", "scale": 0.05, "scenes": ["builtin:room"],
  "methods": ["clahe"], "metrics": ["psnr"], "grid": {"water.type": ["I", "3C"]}
})";

TEST(HostileInputCli, PsfWiderThanTheImageRendersSweepsAndGenerates) {
  TempDir dir;
  // The issue's example: the room at 5 % is 32 x 24 pixels, the kernel 2 R + 1 = 41 wide.
  for (const char* q : {"0.01", "0.0001"}) {
    const std::string out = dir.File(std::string("r") + q + ".png");
    const CliRun run =
        RunBounded(dir, {"render", "--scene", "builtin:room", "--scale", "0.05", "--set",
                         std::string("psf.forward_scatter=") + q, "--out", out});
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_TRUE(fs::exists(out));
  }
  const CliRun tiny = RunBounded(dir, {"render", "--scene", "builtin:seafloor", "--scale", "0.002",
                                       "--set", "psf.forward_scatter=0.001", "--set",
                                       "psf.turbidity_dependent=true", "--out", dir.File("t.png")});
  EXPECT_EQ(tiny.exit_code, 0) << tiny.err;
  nlohmann::json experiment = nlohmann::json::parse(kExperiment);
  experiment["grid"] = {{"psf.forward_scatter", {0.9, 0.01, 1e-4}}};
  experiment["methods"] = {"clahe", "oracle", "oracle_exact", "full"};
  const std::string exp = dir.Write("wide.json", experiment.dump());
  const CliRun sweep = RunBounded(dir, {"sweep", exp, "--out", dir.File("sweep"), "--quiet"});
  EXPECT_EQ(sweep.exit_code, 0) << sweep.err;
  const std::string config = dir.Write("g.json", R"({"scenes": ["builtin:room"], "scale": 0.05,
                    "base": {"psf": {"forward_scatter": 0.005}},
                    "grid": {"psf.optical_thickness": [1, 4]}})");
  const CliRun generate = RunBounded(dir, {"generate", config, "--out", dir.File("gen")});
  EXPECT_EQ(generate.exit_code, 0) << generate.err;
}

TEST(HostileInputCli, DeepJsonIsOneLineNamingTheSource) {
  TempDir dir;
  const std::string deep = Nested(100000);
  // Render parameters: a file and a --set value.
  const std::string params = dir.Write("params.json", "{\"psf\": " + deep + "}");
  ExpectOneErrorLine(RunBounded(dir, {"render", "--scene", "builtin:room", "--scale", "0.05",
                                      "--params", params, "--out", dir.File("a.png")}),
                     params + ": invalid JSON: ", "nested deeper than 64 levels");
  ExpectOneErrorLine(
      RunBounded(dir, {"render", "--scene", "builtin:room", "--scale", "0.05", "--set",
                       "psf.forward_scatter=" + Nested(30000), "--out", dir.File("b.png")}),
      "--set 'psf.forward_scatter=[[[", "[[[...': invalid JSON: nested deeper than 64 levels");
  ExpectOneErrorLine(RunBounded(dir, {"enhance", params, dir.File("e.png"), "--method", "clahe",
                                      "--param", "clahe_bins=" + Nested(30000)}),
                     "--param 'clahe_bins=[[[", "nested deeper than 64 levels");
  // An experiment's grid value (the run and --dry-run alike) and a generate config's base.
  nlohmann::json experiment = nlohmann::json::parse(kExperiment);
  std::string text = experiment.dump();
  text.replace(text.find("[\"I\",\"3C\"]"), 10, "[\"I\", " + deep + "]");
  const std::string exp = dir.Write("deep.json", text);
  for (const bool dry : {false, true}) {
    std::vector<std::string> args = {"sweep", exp, "--out", dir.File("s")};
    if (dry) args.push_back("--dry-run");
    ExpectOneErrorLine(RunBounded(dir, args), exp + ": invalid JSON: ", "nested deeper");
  }
  const std::string config =
      dir.Write("g.json", "{\"scenes\": [\"builtin:room\"], \"base\": " + deep + "}");
  ExpectOneErrorLine(RunBounded(dir, {"generate", config, "--out", dir.File("g")}),
                     config + ": invalid JSON: ", "nested deeper");
  // A scene file and an enhance --param value.
  const std::string scene = dir.Write("scene.json", "{\"type\": \"builtin\", \"x\": " + deep + "}");
  ExpectOneErrorLine(RunBounded(dir, {"scene", scene, "--out", dir.File("sc")}),
                     scene + ": invalid JSON: ", "nested deeper");
}

TEST(HostileInputCli, DuplicateKeysAndHugeNumbersNameTheFile) {
  TempDir dir;
  const std::string dup = dir.Write(
      "dup.json", R"({"name": "d", "scale": 0.05, "scenes": ["builtin:room"], "methods": ["clahe"],
                      "metrics": ["psnr"], "grid": {"water.type": ["I"]}, "scale": 0.5})");
  ExpectOneErrorLine(RunBounded(dir, {"sweep", dup, "--out", dir.File("s"), "--dry-run"}),
                     dup + ": invalid JSON: ", "duplicate key 'scale'");
  const std::string params = dir.Write("p.json", R"({"psf": {"forward_scatter": 1e999}})");
  ExpectOneErrorLine(RunBounded(dir, {"render", "--scene", "builtin:room", "--scale", "0.05",
                                      "--params", params, "--out", dir.File("a.png")}),
                     params + ": invalid JSON: ", "number out of range '1e999'");
  const std::string scene = dir.Write("s.json", R"({"type": "builtin", "type": "rgbd"})");
  ExpectOneErrorLine(RunBounded(dir, {"scene", scene, "--out", dir.File("sc")}),
                     scene + ": invalid JSON: ", "duplicate key 'type'");
}

TEST(HostileInputCli, FifosDevicesAndFoldersAreRefusedBeforeReading) {
  TempDir dir;
  const std::string fifo = dir.File("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  fs::create_directory(dir.File("folder.json"));
  for (const std::string& path : {fifo, std::string("/dev/zero"), dir.File("folder.json")}) {
    ExpectOneErrorLine(RunBounded(dir, {"render", "--scene", "builtin:room", "--scale", "0.05",
                                        "--params", path, "--out", dir.File("a.png")}),
                       path + ": ", "not a regular file");
    ExpectOneErrorLine(RunBounded(dir, {"sweep", path, "--out", dir.File("s"), "--dry-run"}),
                       path + ": ", "not a regular file");
    ExpectOneErrorLine(RunBounded(dir, {"generate", path, "--out", dir.File("g")}), path + ": ",
                       "not a regular file");
    ExpectOneErrorLine(RunBounded(dir, {"score", path, "--metrics", "uciqe"}), path + ": ",
                       "not a");
    ExpectOneErrorLine(RunBounded(dir, {"score", "--manifest", path}), path + ": ",
                       "not a regular file");
  }
  // Through a scene file and a manifest.
  const std::string scene =
      dir.Write("s.json", R"({"type": "rgbd", "image": ")" + fifo + R"(", "depth": "/dev/zero"})");
  const CliRun via_scene =
      RunBounded(dir, {"render", "--scene", scene, "--out", dir.File("b.png")});
  ExpectOneErrorLine(via_scene, "", "not a regular file");
  const std::string manifest = dir.Write("m.csv", "image\n" + fifo + "\n");
  ExpectOneErrorLine(RunBounded(dir, {"score", "--manifest", manifest, "--metrics", "uciqe"}), "",
                     "not a regular file");
  // A link to a regular file still works.
  const std::string params = dir.Write("p.json", R"({"psf": {"enabled": false}})");
  fs::create_symlink(params, dir.File("link.json"));
  EXPECT_EQ(RunBounded(dir, {"render", "--scene", "builtin:room", "--scale", "0.05", "--params",
                             dir.File("link.json"), "--out", dir.File("c.png")})
                .exit_code,
            0);
}

TEST(HostileInputCli, HugeMethodSizesAreRefusedQuickly) {
  TempDir dir;
  const std::string image = dir.File("in.png");
  ASSERT_EQ(RunBounded(dir, {"render", "--scene", "builtin:room", "--scale", "0.2", "--out", image})
                .exit_code,
            0);
  ExpectOneErrorLine(RunBounded(dir, {"enhance", image, dir.File("o.png"), "--method", "dcp",
                                      "--param", "patch_size=10000001"}),
                     "dcp: parameter 'patch_size' = 10000001 exceeds ", "image (2 x its larger");
  ExpectOneErrorLine(RunBounded(dir, {"enhance", image, dir.File("o.png"), "--method", "tarel",
                                      "--param", "sv=99999"}),
                     "tarel: parameter 'sv' = 99999 exceeds ", "image");
}

}  // namespace
}  // namespace turbid
