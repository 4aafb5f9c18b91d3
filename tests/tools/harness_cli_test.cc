// End-to-end tests of `turbid sweep | merge | regress | report` with the real simulator, methods
// and metrics on tiny built-in scenes (scale 0.1): identical bytes for 1 and 2 threads, kill -9
// of the running CLI then resume, shards + merge, bad experiment files rejected before any work,
// and regression detection (also against the committed demo baseline). The HTML report in
// headless Chromium: tests/tools/report_browser_test.cc.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "tests/support/test_support.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

const char* kTinyExperiment = R"({
  "name": "tiny",
  "description": "harness CLI test: two tiny built-in scenes, two turbidity levels",
  "seed": 5,
  "scale": 0.1,
  "scenes": ["builtin:hull", "builtin:seafloor"],
  "grid": {"@turbidity": [
    {"label": "0.3", "x": 0.3, "water.beta_gray_per_m": 0.3, "water.beta_rgb_per_m": [0.4, 0.3, 0.25]},
    {"label": "1.2", "x": 1.2, "water.beta_gray_per_m": 1.2, "water.beta_rgb_per_m": [1.5, 1.2, 1.0]}]},
  "methods": ["clahe", "dcp"],
  "metrics": ["ssim", "psnr", "hautiere_e"],
  "thumbnails": 48
})";

void ExpectSameTables(const std::string& a, const std::string& b) {
  for (const std::string& name : DeterministicOutputs()) {
    const std::string left = ReadFileText(a + "/" + name);
    EXPECT_FALSE(left.empty()) << a << "/" << name;
    EXPECT_TRUE(left == ReadFileText(b + "/" + name)) << name << " differs: " << a << " vs " << b;
  }
}

// Lines of items.csv that belong to `method`.
int RowsOf(const std::string& csv, const std::string& method) {
  int rows = 0;
  std::istringstream in(csv);
  std::string line;
  while (std::getline(in, line)) {
    const std::vector<std::string> fields = SplitCsvLine(line);
    rows += fields.size() > 5 && fields[5] == method;
  }
  return rows;
}

TEST(HarnessCli, OneAndTwoThreadsGiveIdenticalBytes) {
  TempDir dir;
  const std::string exp = dir.Write("tiny.json", kTinyExperiment);
  const CliRun one = RunTurbid({"sweep", exp, "--out", dir.File("t1"), "--threads", "1"});
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const CliRun two = RunTurbid({"sweep", exp, "--out", dir.File("t2"), "--threads", "2"});
  ASSERT_EQ(two.exit_code, 0) << two.err;
  EXPECT_NE(one.out.find("4 items run"), std::string::npos) << one.out;
  EXPECT_TRUE(one.err.empty()) << one.err;  // no progress bar when stderr is not a terminal
  ExpectSameTables(dir.File("t1"), dir.File("t2"));
  const std::string csv = ReadFileText(dir.File("t1/items.csv"));
  // none and oracle rows are always there; every method on every item.
  EXPECT_EQ(RowsOf(csv, "none"), 4);
  EXPECT_EQ(RowsOf(csv, "oracle"), 4);
  EXPECT_EQ(RowsOf(csv, "clahe"), 4);
  EXPECT_EQ(RowsOf(csv, "dcp"), 4);
  EXPECT_TRUE(fs::exists(dir.File("t1/thumbs/hull-c0001/dcp.png")));
  EXPECT_TRUE(fs::exists(dir.File("t1/thumbs/seafloor/clean.png")));
  // Rerunning a finished sweep does nothing.
  const CliRun again = RunTurbid({"sweep", exp, "--out", dir.File("t1")});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.out.find("nothing to do"), std::string::npos) << again.out;
}

TEST(HarnessCli, BadExperimentsAreRejectedBeforeAnyWork) {
  TempDir dir;
  const struct {
    std::string patch_from, patch_to, message;
  } cases[] = {
      {"\"dcp\"]", "\"dcp\", \"nosuch\"]", "unknown method 'nosuch'"},
      {"\"hautiere_e\"]", "\"hautiere_e\", \"nosuch\"]", "unknown metric 'nosuch'"},
      {"\"water.beta_gray_per_m\": 1.2,", "\"water.beta_gray_per_m\": -1.2,", "beta"},
      {"\"grid\": {", "\"grid\": {}, \"unused\": {", "unknown key 'unused'"},
      {"\"scale\": 0.1", "\"scale\": 0", "'scale': must be in (0, 1]"},
      {"\"builtin:hull\"", "\"builtin:nosuch\"", "nosuch"},
  };
  for (const auto& c : cases) {
    std::string text = kTinyExperiment;
    const size_t at = text.find(c.patch_from);
    ASSERT_NE(at, std::string::npos) << c.patch_from;
    text.replace(at, c.patch_from.size(), c.patch_to);
    const std::string exp = dir.Write("bad.json", text);
    const CliRun run = RunTurbid({"sweep", exp, "--out", dir.File("never")});
    EXPECT_EQ(run.exit_code, 1) << c.message;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << run.err;
    EXPECT_EQ(run.err.rfind("turbid: error: ", 0), 0u) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_FALSE(fs::exists(dir.File("never"))) << "work started for: " << c.message;
  }
  // An empty grid.
  std::string text = kTinyExperiment;
  text.replace(text.find("\"grid\""), 6, "\"unused_grid\"");
  text.replace(text.find("\"unused_grid\""), 13, "\"comment\"");
  const CliRun run =
      RunTurbid({"sweep", dir.Write("empty.json", text), "--out", dir.File("never")});
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("empty grid"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir.File("never")));
}

// kill -9 the real CLI while it works, then rerun the same command.
TEST(HarnessCli, KillNineThenRerunCompletesTheSweep) {
  const char* bin = std::getenv("TURBID_BIN");
  ASSERT_NE(bin, nullptr);
  TempDir dir;
  std::string text = kTinyExperiment;
  // More items so that the kill lands mid-run: 2 scenes x 8 levels.
  text.replace(text.find("\"grid\""), 6, "\"unused\"");
  text.replace(text.find("\"unused\""), 8, "\"comment\"");
  text.replace(text.rfind('}'), 1,
               ", \"grid\": {\"water.type\": [\"I\", \"IA\", \"IB\", \"II\", \"III\", \"1C\", "
               "\"3C\", \"5C\"]}}");
  const std::string exp = dir.Write("kill.json", text);
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", dir.File("reference")}).exit_code, 0);
  for (int kill_after_ms : {150, 300}) {
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      const int null_fd = ::open("/dev/null", O_WRONLY);
      dup2(null_fd, 1);
      dup2(null_fd, 2);
      execl(bin, bin, "sweep", exp.c_str(), "--out", dir.File("killed").c_str(), "--threads", "2",
            static_cast<char*>(nullptr));
      _exit(127);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(kill_after_ms));
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
  }
  const CliRun rerun = RunTurbid({"sweep", exp, "--out", dir.File("killed")});
  ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
  ExpectSameTables(dir.File("reference"), dir.File("killed"));
  // Exactly one journal line per item.
  const std::string journal = ReadFileText(dir.File("killed/journal.jsonl"));
  EXPECT_EQ(std::count(journal.begin(), journal.end(), '\n'), 16);
  std::set<std::string> ids;
  std::istringstream in(journal);
  std::string line;
  while (std::getline(in, line)) ids.insert(nlohmann::json::parse(line)["id"].get<std::string>());
  EXPECT_EQ(ids.size(), 16u);
}

TEST(HarnessCli, ShardsMergeToTheUnshardedResult) {
  TempDir dir;
  const std::string exp = dir.Write("tiny.json", kTinyExperiment);
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", dir.File("whole"), "--quiet"}).exit_code, 0);
  for (int i = 0; i < 3; ++i) {
    const CliRun shard = RunTurbid({"sweep", exp, "--out", dir.File("s" + std::to_string(i)),
                                    "--shard", std::to_string(i) + "/3", "--quiet"});
    ASSERT_EQ(shard.exit_code, 0) << shard.err;
  }
  const CliRun partial =
      RunTurbid({"merge", dir.File("s0"), dir.File("s1"), "--out", dir.File("partial")});
  EXPECT_EQ(partial.exit_code, 1);
  EXPECT_NE(partial.err.find("missing"), std::string::npos) << partial.err;
  const CliRun merge = RunTurbid(
      {"merge", dir.File("s2"), dir.File("s0"), dir.File("s1"), "--out", dir.File("merged")});
  ASSERT_EQ(merge.exit_code, 0) << merge.err;
  ExpectSameTables(dir.File("whole"), dir.File("merged"));
  EXPECT_TRUE(fs::exists(dir.File("merged/thumbs/hull-c0001/degraded.png")));
  const CliRun bad_shard = RunTurbid({"sweep", exp, "--out", dir.File("x"), "--shard", "3/3"});
  EXPECT_EQ(bad_shard.exit_code, 1);
  EXPECT_NE(bad_shard.err.find("--shard"), std::string::npos) << bad_shard.err;
}

TEST(HarnessCli, RegressCatchesAPerturbedMethod) {
  TempDir dir;
  const std::string exp = dir.Write("tiny.json", kTinyExperiment);
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", dir.File("base"), "--quiet"}).exit_code, 0);
  // The same experiment with dcp perturbed: a much weaker haze removal under the same label.
  std::string text = kTinyExperiment;
  text.replace(text.find("\"dcp\"]"), 6,
               "{\"name\": \"dcp\", \"label\": \"dcp\", \"params\": {\"omega\": 0.2}}]");
  const std::string perturbed_exp = dir.Write("perturbed.json", text);
  ASSERT_EQ(
      RunTurbid({"sweep", perturbed_exp, "--out", dir.File("perturbed"), "--quiet"}).exit_code, 0);
  const std::string baseline = dir.File("base/items.csv");
  const CliRun same = RunTurbid({"regress", "--baseline", baseline, dir.File("base")});
  EXPECT_EQ(same.exit_code, 0) << same.out << same.err;
  EXPECT_NE(same.out.find("regress: OK"), std::string::npos) << same.out;
  // Strict: any move beyond tolerance fails, and only dcp rows moved.
  const CliRun strict =
      RunTurbid({"regress", "--strict", "--baseline", baseline, dir.File("perturbed")});
  EXPECT_EQ(strict.exit_code, 1) << strict.out;
  std::istringstream lines(strict.out);
  std::string line;
  int moved = 0;
  while (std::getline(lines, line)) {
    if (line.rfind("REGRESSED", 0) != 0 && line.rfind("improved", 0) != 0) continue;
    ++moved;
    EXPECT_NE(line.find(" dcp "), std::string::npos) << line;
  }
  EXPECT_GT(moved, 0) << strict.out;
  // A generous tolerance on every metric lets the perturbation pass.
  const CliRun loose = RunTurbid({"regress", "--baseline", baseline, dir.File("perturbed"), "--tol",
                                  "ssim=10", "--tol", "psnr=100", "--tol", "hautiere_e=100"});
  EXPECT_EQ(loose.exit_code, 0) << loose.out;
}

// The committed demo baseline: a copy with one method made worse must fail, an exact copy pass.
TEST(HarnessCli, CommittedDemoBaselineCatchesAWorseMethod) {
  // CMake compiles with absolute paths: the repository root is three levels above this file.
  const std::string source = (fs::path(__FILE__).parent_path().parent_path().parent_path() /
                              "scenes/experiments/baselines")
                                 .string();
  const std::string baseline = source + "/demo.items.csv";
  ASSERT_TRUE(fs::exists(baseline)) << baseline;
  TempDir dir;
  fs::copy_file(baseline, dir.File("same.csv"));
  const CliRun same = RunTurbid({"regress", "--baseline", baseline, dir.File("same.csv")});
  EXPECT_EQ(same.exit_code, 0) << same.out << same.err;
  // Lower every psnr of "simplified" by 1 dB (psnr: higher is better).
  std::istringstream in(ReadFileText(baseline));
  std::ostringstream out;
  std::string line;
  std::vector<std::string> header;
  int changed = 0;
  while (std::getline(in, line)) {
    std::vector<std::string> fields = SplitCsvLine(line);
    if (header.empty()) {
      header = fields;
    } else {
      const int method =
          static_cast<int>(std::find(header.begin(), header.end(), "method") - header.begin());
      const int psnr =
          static_cast<int>(std::find(header.begin(), header.end(), "psnr") - header.begin());
      if (fields[method] == "simplified") {
        fields[psnr] = FormatValue(ParseValue(fields[psnr]) - 1.0);
        ++changed;
      }
    }
    for (size_t i = 0; i < fields.size(); ++i) out << (i ? "," : "") << CsvEscape(fields[i]);
    out << "\n";
  }
  ASSERT_GT(changed, 0);
  dir.Write("worse.csv", out.str());
  const CliRun worse = RunTurbid({"regress", "--baseline", baseline, dir.File("worse.csv")});
  EXPECT_EQ(worse.exit_code, 1) << worse.out;
  EXPECT_NE(worse.out.find("REGRESSED"), std::string::npos) << worse.out;
  EXPECT_NE(worse.out.find("simplified"), std::string::npos);
  EXPECT_NE(worse.err.find("regressed"), std::string::npos) << worse.err;
}

TEST(HarnessCli, DryRunCountsItems) {
  TempDir dir;
  const std::string exp = dir.Write("tiny.json", kTinyExperiment);
  const CliRun run =
      RunTurbid({"sweep", exp, "--out", dir.File("o"), "--dry-run", "--shard", "1/2"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("4 items (2 in shard 1/2)"), std::string::npos) << run.out;
  EXPECT_FALSE(fs::exists(dir.File("o")));
}

}  // namespace
}  // namespace turbid
