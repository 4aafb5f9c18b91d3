// Resource limits of the real CLI (docs/reliability.md, "Limits"): inputs that would exhaust
// memory (10^9-item sweeps and datasets, huge image headers) are refused up front with one line
// naming the limit and how to raise it; the environment variable moves the limit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/test_support.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::RunTurbid;
using testing::TempDir;

const char* kExperiment = R"({
  "name": "limits",
  "seed": 5,
  "scale": 0.1,
  "scenes": ["builtin:hull", "builtin:seafloor"],
  "grid": {"water.type": ["I", "II", "3C"]},
  "methods": ["clahe"],
  "metrics": ["ssim", "psnr"],
  "thumbnails": 48
})";

void ExpectOneErrorLine(const std::string& err, const std::string& part) {
  EXPECT_EQ(err.rfind("turbid: error: ", 0), 0u) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find(part), std::string::npos) << err;
}

// A grid of `axes` parameters with `values` values each, as JSON.
std::string BigGrid(int axes, int values) {
  const char* paths[] = {"water.beta_gray_per_m", "psf.forward_scatter", "psf.optical_thickness"};
  std::string grid = "{";
  for (int a = 0; a < axes; ++a) {
    grid += std::string(a ? ", " : "") + "\"" + paths[a] + "\": [";
    for (int v = 0; v < values; ++v)
      grid += (v ? ", " : "") + std::to_string(0.1 + 0.5 * v / values);
    grid += "]";
  }
  return grid + "}";
}

TEST(LimitsCli, HugeSweepsAndDatasetsAreRefusedUpFront) {
  TempDir dir;
  unsetenv("TURBID_MAX_ITEMS");
  const std::string huge_grid = BigGrid(3, 1000);  // 10^9 grid points
  const std::string exp = dir.Write("huge.json",
                                    R"({"name": "huge", "scale": 0.1,
      "scenes": ["builtin:hull"], "methods": ["clahe"], "metrics": ["ssim"], "grid": )" +
                                        huge_grid + "}");
  const CliRun sweep = RunTurbid({"sweep", exp, "--out", dir.File("never"), "--dry-run"});
  EXPECT_EQ(sweep.exit_code, 1);
  ExpectOneErrorLine(sweep.err,
                     "the sweep (scenes x grid points x samples) has 1000000000 items, more than "
                     "the limit of 1000000 (raise it with the environment variable "
                     "TURBID_MAX_ITEMS)");
  const std::string gen =
      dir.Write("huge_gen.json",
                R"({"scenes": ["builtin:hull"], "scale": 0.1, "grid": )" + huge_grid + "}");
  const CliRun generate = RunTurbid({"generate", gen, "--out", dir.File("never")});
  EXPECT_EQ(generate.exit_code, 1);
  ExpectOneErrorLine(generate.err, "has 1000000000 items, more than the limit of 1000000");
  const std::string sampled = dir.Write(
      "sampled_gen.json",
      R"({"scenes": ["builtin:hull", "builtin:seafloor"], "scale": 0.1, "grid": )" +
          BigGrid(1, 1000) +
          R"(, "random": {"count": 1000000, "params": {"psf.forward_scatter": {"uniform": [0.5, 0.9]}}}})");
  const CliRun generate_sampled = RunTurbid({"generate", sampled, "--out", dir.File("never")});
  EXPECT_EQ(generate_sampled.exit_code, 1);
  ExpectOneErrorLine(generate_sampled.err, "TURBID_MAX_ITEMS");
  EXPECT_FALSE(fs::exists(dir.File("never")));
  // Scenes cannot be scaled up (built-in scenes render at most at their native size).
  std::string scaled = kExperiment;
  scaled.replace(scaled.find("\"scale\": 0.1"), 12, "\"scale\": 100000");
  const CliRun big_scale =
      RunTurbid({"sweep", dir.Write("scaled.json", scaled), "--out", dir.File("never")});
  EXPECT_EQ(big_scale.exit_code, 1);
  ExpectOneErrorLine(big_scale.err, "'scale': must be in (0, 1]");

  // The variable moves the limit: 6 items pass at 6 and are refused at 5.
  const std::string small = dir.Write("small.json", kExperiment);
  setenv("TURBID_MAX_ITEMS", "5", 1);
  const CliRun refused = RunTurbid({"sweep", small, "--out", dir.File("never"), "--dry-run"});
  setenv("TURBID_MAX_ITEMS", "6", 1);
  const CliRun allowed = RunTurbid({"sweep", small, "--out", dir.File("never"), "--dry-run"});
  unsetenv("TURBID_MAX_ITEMS");
  EXPECT_EQ(refused.exit_code, 1);
  ExpectOneErrorLine(refused.err, "has 6 items, more than the limit of 5");
  EXPECT_EQ(allowed.exit_code, 0) << allowed.err;
}

TEST(LimitsCli, AHugeImageHeaderIsOneLine) {
  TempDir dir;
  unsetenv("TURBID_MAX_PIXELS");
  dir.Write("huge.pgm", "P5\n100000 100000\n255\n" + std::string(16, '\0'));
  const CliRun run = RunTurbid({"enhance", "-m", "clahe", dir.File("huge.pgm"), dir.File("o.png")});
  EXPECT_EQ(run.exit_code, 1);
  ExpectOneErrorLine(run.err,
                     "huge.pgm: image size 100000x100000 exceeds the limit of 100000000 "
                     "pixels per image (raise it with the environment variable "
                     "TURBID_MAX_PIXELS)");
  EXPECT_FALSE(fs::exists(dir.File("o.png")));
}

}  // namespace
}  // namespace turbid
