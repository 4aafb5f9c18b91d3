// Crash safety of the real CLI (docs/reliability.md): `generate` and `sweep` under a file-size
// limit (ulimit -f, set with setrlimit in the child) fail with one line and leave no half-written
// output, and a rerun completes the same bytes as an unlimited run; temporaries left by killed
// writes are removed by the next sweep, merge or generate into the folder.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "tests/support/test_support.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

const char* kExperiment = R"({
  "name": "crash",
  "seed": 5,
  "scale": 0.1,
  "scenes": ["builtin:hull", "builtin:seafloor"],
  "grid": {"water.type": ["I", "II", "3C"]},
  "methods": ["clahe"],
  "metrics": ["ssim", "psnr"],
  "thumbnails": 48
})";

const char* kGenerate = R"({
  "scenes": ["builtin:hull", "builtin:seafloor"],
  "scale": 0.1,
  "seed": 3,
  "grid": {"water.type": ["I", "III"]}
})";

// Runs turbid with `args` under RLIMIT_FSIZE = limit_bytes (SIGXFSZ left at its default action, so
// that a turbid that did not ignore it would die of it). Returns the exit code, or 128 + signal.
int RunWithFileSizeLimit(rlim_t limit_bytes, const std::vector<std::string>& args,
                         std::string* err) {
  const char* bin = std::getenv("TURBID_BIN");
  if (bin == nullptr) return -1;
  TempDir io;
  const std::string err_path = io.File("err");
  const pid_t child = fork();
  if (child == 0) {
    signal(SIGXFSZ, SIG_DFL);
    const int null_fd = ::open("/dev/null", O_WRONLY);
    const int err_fd = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(null_fd, 1);
    dup2(err_fd, 2);
    const struct rlimit limit = {limit_bytes, limit_bytes};
    setrlimit(RLIMIT_FSIZE, &limit);
    std::vector<char*> argv = {const_cast<char*>(bin)};
    for (const std::string& arg : args) argv.push_back(const_cast<char*>(arg.c_str()));
    argv.push_back(nullptr);
    execv(bin, argv.data());
    _exit(127);
  }
  int status = 0;
  waitpid(child, &status, 0);
  *err = ReadFileText(err_path);
  return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : WEXITSTATUS(status);
}

// Relative path -> bytes of every file under `root` (the lock file aside).
std::map<std::string, std::string> Files(const std::string& root) {
  std::map<std::string, std::string> out;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file()) continue;
    const std::string rel = fs::relative(entry.path(), root).string();
    if (rel != ".turbid.lock") out[rel] = ReadFileText(entry.path().string());
  }
  return out;
}

void ExpectOneErrorLine(const std::string& err, const std::string& part) {
  EXPECT_EQ(err.rfind("turbid: error: ", 0), 0u) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find(part), std::string::npos) << err;
}

TEST(CrashSafetyCli, GenerateUnderAFileSizeLimitLeavesNoHalfWrittenFile) {
  TempDir dir;
  const std::string config = dir.Write("gen.json", kGenerate);
  ASSERT_EQ(RunTurbid({"generate", config, "--out", dir.File("ref")}).exit_code, 0);
  const auto reference = Files(dir.File("ref"));
  // A limit the sidecars fit in and some image files do not.
  size_t sidecar = 0, largest = 0;
  for (const auto& [rel, bytes] : reference) {
    if (rel.rfind("sidecars/", 0) == 0) sidecar = std::max(sidecar, bytes.size());
    largest = std::max(largest, bytes.size());
  }
  ASSERT_GT(largest, sidecar + 100);
  std::string err;
  const int code =
      RunWithFileSizeLimit(sidecar + 100, {"generate", config, "--out", dir.File("out")}, &err);
  EXPECT_EQ(code, 1) << "128 + 25 is death by SIGXFSZ; " << err;
  ExpectOneErrorLine(err, "File too large");
  for (const auto& [rel, bytes] : Files(dir.File("out"))) {
    EXPECT_FALSE(IsTemporaryName(fs::path(rel).filename().string())) << rel;
    ASSERT_TRUE(reference.count(rel)) << rel;
    EXPECT_TRUE(reference.at(rel) == bytes) << rel << " is not the complete file";
  }
  const CliRun rerun = RunTurbid({"generate", config, "--out", dir.File("out")});
  ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
  EXPECT_TRUE(Files(dir.File("out")) == reference);
}

TEST(CrashSafetyCli, SweepUnderAFileSizeLimitKeepsTheJournalWhole) {
  TempDir dir;
  // 16 items: a journal several times longer than experiment.json.
  std::string text = kExperiment;
  text.replace(text.find("[\"I\", \"II\", \"3C\"]"), 17,
               "[\"I\", \"IA\", \"IB\", \"II\", \"III\", \"1C\", \"3C\", \"5C\"]");
  const std::string exp = dir.Write("exp.json", text);
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", dir.File("ref"), "--quiet"}).exit_code, 0);
  // A limit experiment.json and the thumbnails fit in and the journal does not: a few lines are
  // appended, then an append fails in the middle of a line.
  size_t limit = 0;
  for (const auto& [rel, bytes] : Files(dir.File("ref")))
    if (rel == "experiment.json" || rel.rfind("thumbs/", 0) == 0)
      limit = std::max(limit, bytes.size() + 100);
  ASSERT_GT(ReadFileText(dir.File("ref/journal.jsonl")).size(), limit + 1000);
  std::string err;
  const int code = RunWithFileSizeLimit(
      limit, {"sweep", exp, "--out", dir.File("out"), "--quiet", "--threads", "1"}, &err);
  EXPECT_EQ(code, 1) << err;
  ExpectOneErrorLine(err, "File too large");
  const std::string journal = ReadFileText(dir.File("out/journal.jsonl"));
  EXPECT_TRUE(journal.empty() || journal.back() == '\n') << "a partial line was left behind";
  for (const auto& [rel, bytes] : Files(dir.File("out")))
    EXPECT_FALSE(IsTemporaryName(fs::path(rel).filename().string())) << rel;
  const CliRun rerun = RunTurbid({"sweep", exp, "--out", dir.File("out"), "--quiet"});
  ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
  for (const std::string& name : DeterministicOutputs())
    EXPECT_TRUE(ReadFileText(dir.File("ref/" + name)) == ReadFileText(dir.File("out/" + name)))
        << name;
}

TEST(CrashSafetyCli, TheNextRunRemovesTemporariesOfKilledWrites) {
  TempDir dir;
  const std::string exp = dir.Write("exp.json", kExperiment);
  const std::string config = dir.Write("gen.json", kGenerate);
  for (int shard = 0; shard < 2; ++shard) {
    const std::string out = dir.File("s" + std::to_string(shard));
    ASSERT_EQ(
        RunTurbid({"sweep", exp, "--out", out, "--shard", std::to_string(shard) + "/2", "--quiet"})
            .exit_code,
        0);
  }
  ASSERT_EQ(RunTurbid({"merge", dir.File("s0"), dir.File("s1"), "--out", dir.File("m")}).exit_code,
            0);
  ASSERT_EQ(RunTurbid({"generate", config, "--out", dir.File("g")}).exit_code, 0);
  // What SIGKILL leaves: hidden temporaries beside their destinations, an external method's
  // work folder; and a live `turbid report`'s temporary, which is not the sweep's to remove.
  const std::vector<std::string> stale = {"s0/.journal.jsonl.tmp5eed.jsonl",
                                          "s0/thumbs/hull-c0000/.clahe.png.tmp1f2e.png",
                                          "s0/external/mine/work-hull-c0000/in/hull-c0000.png",
                                          "m/.items.csv.tmpc0ffee.csv",
                                          "m/thumbs/seafloor-c0001/.degraded.png.tmp42.png",
                                          "g/images/.hull_000000.png.tmpab.png",
                                          "g/sidecars/.hull_000000.json.tmp99.json",
                                          "g/.manifest.csv.tmp7.csv"};
  const std::vector<std::string> kept = {"s0/.report.html.tmpdead.html",
                                         "s0/report/.plot.png.tmpbeef.png"};
  for (const std::string& name : stale) {
    fs::create_directories(fs::path(dir.File(name)).parent_path());
    std::ofstream(dir.File(name)) << "partial";
  }
  for (const std::string& name : kept) {
    fs::create_directories(fs::path(dir.File(name)).parent_path());
    std::ofstream(dir.File(name)) << "being written";
  }
  ASSERT_EQ(
      RunTurbid({"sweep", exp, "--out", dir.File("s0"), "--shard", "0/2", "--quiet"}).exit_code, 0);
  ASSERT_EQ(RunTurbid({"merge", dir.File("s0"), dir.File("s1"), "--out", dir.File("m")}).exit_code,
            0);
  ASSERT_EQ(RunTurbid({"generate", config, "--out", dir.File("g")}).exit_code, 0);
  for (const std::string& name : stale) EXPECT_FALSE(fs::exists(dir.File(name))) << name;
  EXPECT_FALSE(fs::exists(dir.File("s0/external/mine/work-hull-c0000")));
  for (const std::string& name : kept) EXPECT_TRUE(fs::exists(dir.File(name))) << name;
}

}  // namespace
}  // namespace turbid
