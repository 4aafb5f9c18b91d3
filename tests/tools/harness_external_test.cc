// External methods in sweeps (a user's program run once per batch or once per image, or a folder
// of precomputed results) and `turbid score --results`, end to end through the CLI with small
// Python scripts (standard library only) written by the tests on tiny built-in scenes.
//
// The independent reference: a method that copies its float (PFM) input unchanged must score
// exactly like the `none` row (the degraded image scored as it is), bit for bit; a results folder
// holding the dataset's ground truth must score SSIM 1 and PSNR inf.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "tests/support/test_support.h"
#include "tools/harness/experiment.h"
#include "tools/harness/external_method.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

std::string WriteFile(const std::string& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir + "/" + name, std::ios::binary) << text;
  return dir + "/" + name;
}

// copy.py SRC DST: copies a file, or every file of a folder (batch); counts batch runs in
// batch_runs.txt (in its working directory) and needs EXT_TOKEN=abc in its environment.
const char* kCopyScript = R"(import os, shutil, sys
if os.environ.get("EXT_TOKEN") != "abc":
    sys.exit("EXT_TOKEN is not abc")
src, dst = sys.argv[1], sys.argv[2]
if os.path.isdir(src):
    names = sorted(os.listdir(src))
    for name in names:
        shutil.copy(os.path.join(src, name), os.path.join(dst, name))
    with open("batch_runs.txt", "a") as f:
        f.write("%d\n" % len(names))
    keep = os.environ.get("EXT_KEEP")
    if keep:
        os.makedirs(keep, exist_ok=True)
        for name in names:
            shutil.copy(os.path.join(src, name), os.path.join(keep, name))
else:
    if os.path.exists("fail_flag"):
        sys.exit("fail_flag is set")
    shutil.copy(src, dst)
)";

// bad.py MODE IN OUT: the failure modes.
const char* kBadScript = R"(import os, struct, subprocess, sys, time
mode, src, dst = sys.argv[1], sys.argv[2], sys.argv[3]
if mode == "exit":
    print("the model exploded", file=sys.stderr)
    sys.exit(3)
if mode == "sleep":
    child = subprocess.Popen(["sleep", "30"])
    with open("pids.txt", "a") as f:
        f.write("%d %d\n" % (os.getpid(), child.pid))
    time.sleep(30)
if mode == "nothing":
    sys.exit(0)
if mode == "small":
    with open(dst, "wb") as f:
        f.write(b"P6\n2 2\n255\n" + bytes(12))
if mode == "nan":
    with open(src, "rb") as f:
        kind = f.readline()
        width, height = (int(v) for v in f.readline().split())
    channels = 3 if kind.strip() == b"PF" else 1
    values = [0.5] * (width * height * channels)
    values[7] = float("nan")
    with open(dst, "wb") as f:
        f.write(kind + b"%d %d\n-1.0\n" % (width, height))
        f.write(struct.pack("<%df" % len(values), *values))
)";

// Two tiny hull items (two turbidity levels); `methods` is spliced into the file.
std::string TinyExperiment(const std::string& methods) {
  return R"({
  "name": "ext",
  "seed": 3,
  "scale": 0.1,
  "scenes": ["builtin:hull"],
  "grid": {"@turbidity": [
    {"label": "0.3", "x": 0.3, "water.beta_gray_per_m": 0.3, "water.beta_rgb_per_m": [0.4, 0.3, 0.25]},
    {"label": "1.2", "x": 1.2, "water.beta_gray_per_m": 1.2, "water.beta_rgb_per_m": [1.5, 1.2, 1.0]}]},
  "methods": [)" + methods + R"(],
  "metrics": ["ssim", "psnr", "hautiere_e"],
  "thumbnails": 32
})";
}

const char* kCopyBatch =
    R"({"name": "copy_batch", "command": ["python3", "copy.py", "{input_dir}", "{output_dir}"],
        "batch": true, "input": {"format": "pfm"}, "env": {"EXT_TOKEN": "abc"}, "timeout_s": 60})";
const char* kCopyOne =
    R"({"name": "copy_one", "command": ["python3", "copy.py", "{input}", "{output}"],
        "input": {"format": "pfm"}, "env": {"EXT_TOKEN": "abc"}, "timeout_s": 60})";

// items.csv as (id + " " + method) -> column -> text.
std::map<std::string, std::map<std::string, std::string>> ReadItems(const std::string& path) {
  std::istringstream in(ReadFileText(path));
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = SplitCsvLine(line);
  std::map<std::string, std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    const std::vector<std::string> fields = SplitCsvLine(line);
    std::map<std::string, std::string> row;
    for (size_t i = 0; i < header.size() && i < fields.size(); ++i) row[header[i]] = fields[i];
    rows[row["id"] + " " + row["method"]] = row;
  }
  return rows;
}

const std::vector<std::string> kIds = {"hull-c0000", "hull-c0001"};
const std::vector<std::string> kMetrics = {"ssim", "psnr", "hautiere_e"};

void ExpectSameMetrics(const std::map<std::string, std::map<std::string, std::string>>& rows,
                       const std::string& method) {
  for (const std::string& id : kIds) {
    ASSERT_TRUE(rows.count(id + " " + method)) << id << " " << method;
    const auto& row = rows.at(id + " " + method);
    EXPECT_EQ(row.at("error"), "") << id << " " << method;
    for (const std::string& metric : kMetrics) {
      // Tolerance 0: the PFM round trip is exact, so the scores are the identity row's.
      EXPECT_EQ(row.at(metric), rows.at(id + " none").at(metric)) << id << " " << method << " "
                                                                   << metric;
    }
  }
}

TEST(HarnessExternal, BatchAndPerImageCopiesScoreLikeTheDegradedInput) {
  TempDir dir;
  WriteFile(dir.path(), "copy.py", kCopyScript);
  const std::string exp = WriteFile(
      dir.path(), "exp.json",
      TinyExperiment(std::string("\"clahe\", ") + kCopyBatch + ", " + kCopyOne));
  const CliRun run =
      RunTurbid({"sweep", exp, "--out", dir.File("out"), "--threads", "2", "--allow-commands"});
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const auto rows = ReadItems(dir.File("out/items.csv"));
  ExpectSameMetrics(rows, "copy_batch");
  ExpectSameMetrics(rows, "copy_one");
  // One process for the batch of both items.
  EXPECT_EQ(ReadFileText(dir.File("batch_runs.txt")), "2\n");
  // Times: the batch's are shares of one process, flagged as such.
  const std::string timings = ReadFileText(dir.File("out/timings.csv"));
  EXPECT_NE(timings.find("hull-c0000,copy_batch,"), std::string::npos) << timings;
  EXPECT_NE(timings.find(",batch_share\n"), std::string::npos) << timings;
  EXPECT_NE(ReadFileText(dir.File("out/timings.md")).find("copy_batch (batch)"),
            std::string::npos);
  // Thumbnails for the report's image grid, like built-in methods.
  EXPECT_TRUE(fs::exists(dir.File("out/thumbs/hull-c0001/copy_batch.png")));
  EXPECT_TRUE(fs::exists(dir.File("out/thumbs/hull-c0001/copy_one.png")));
  // experiment.json records the command line, working directory, environment and timeout.
  const json resolved = json::parse(ReadFileText(dir.File("out/experiment.json")));
  const json& method = resolved["methods"][3];
  ASSERT_EQ(method["label"], "copy_batch");
  EXPECT_EQ(method["privileged"], false);
  EXPECT_EQ(method["external"]["command"],
            json::parse(R"(["python3", "copy.py", "{input_dir}", "{output_dir}"])"));
  EXPECT_EQ(method["external"]["cwd"], ".");
  EXPECT_EQ(method["external"]["env"], json::parse(R"({"EXT_TOKEN": "abc"})"));
  EXPECT_EQ(method["external"]["timeout_s"], 60.0);
  EXPECT_EQ(method["external"]["input"], json::parse(R"({"format": "pfm", "bits": 32,
                                                          "encoding": "linear"})"));
  // No work folders or logs are left behind after successes.
  EXPECT_FALSE(fs::exists(dir.File("out/external/copy_batch/work-hull-c0000")));
  EXPECT_FALSE(fs::exists(dir.File("out/external/copy_one/hull-c0000.log")));
  // The report shows them like the built-in methods.
  const CliRun report = RunTurbid({"report", dir.File("out")});
  ASSERT_EQ(report.exit_code, 0) << report.err;
  const std::string html = ReadFileText(dir.File("out/report.html"));
  EXPECT_NE(html.find("hull-c0000 copy_batch"), std::string::npos);
  // Summary columns and the time-vs-metric plot's points, like the built-in clahe.
  const std::string md = ReadFileText(dir.File("out/summary.md"));
  for (const char* label : {"clahe", "copy_batch", "copy_one"}) {
    EXPECT_NE(md.find(std::string(" ") + label + " |"), std::string::npos) << label << "\n" << md;
  }
  const std::string plot = ReadFileText(dir.File("out/report/time_vs_metric.dat"));
  EXPECT_NE(plot.find("\"clahe\""), std::string::npos) << plot;
  EXPECT_NE(plot.find("\"copy_batch (batch)\""), std::string::npos) << plot;
  EXPECT_NE(plot.find("\"copy_one\""), std::string::npos) << plot;

  // Regression baselines hold the external methods' rows like the built-in ones: the sweep passes
  // against its own summary, and fails when copy_one's SSIM in the baseline is made better.
  const CliRun same = RunTurbid({"regress", "--baseline", dir.File("out/summary.csv"),
                                 dir.File("out")});
  EXPECT_EQ(same.exit_code, 0) << same.out << same.err;
  std::string baseline = ReadFileText(dir.File("out/summary.csv"));
  const size_t row = baseline.find("\nall,copy_one,ssim,");
  ASSERT_NE(row, std::string::npos) << baseline;
  // level,method,metric,domain,n,mean,...: replace the mean (6th field) with 2 (SSIM <= 1).
  size_t field = row + 1;
  for (int comma = 0; comma < 5; ++comma) field = baseline.find(',', field) + 1;
  baseline.replace(field, baseline.find(',', field) - field, "2");
  WriteFile(dir.path(), "baseline.csv", baseline);
  const CliRun worse = RunTurbid({"regress", "--baseline", dir.File("baseline.csv"),
                                  dir.File("out")});
  EXPECT_EQ(worse.exit_code, 1) << worse.out;
  EXPECT_NE(worse.out.find("copy_one"), std::string::npos) << worse.out;
  EXPECT_NE(worse.out.find("REGRESSED"), std::string::npos) << worse.out;
}

bool Alive(pid_t pid) { return ::kill(pid, 0) == 0 || errno != ESRCH; }

TEST(HarnessExternal, FailuresMarkOnlyTheirCellsAndTheSweepGoesOn) {
  TempDir dir;
  WriteFile(dir.path(), "bad.py", kBadScript);
  const std::string methods = R"("clahe",
    {"name": "crash", "command": ["python3", "bad.py", "exit", "{input_dir}", "{output_dir}"], "batch": true},
    {"name": "slow", "command": ["python3", "bad.py", "sleep", "{input}", "{output}"], "timeout_s": 3},
    {"name": "silent", "command": ["python3", "bad.py", "nothing", "{input_dir}", "{output_dir}"], "batch": true},
    {"name": "small", "command": ["python3", "bad.py", "small", "{input}", "{output}"]},
    {"name": "nan", "command": ["python3", "bad.py", "nan", "{input}", "{output}"], "input": {"format": "pfm"}})";
  const std::string exp = WriteFile(dir.path(), "exp.json", TinyExperiment(methods));
  const auto start = std::chrono::steady_clock::now();
  const CliRun run =
      RunTurbid({"sweep", exp, "--out", dir.File("out"), "--threads", "2", "--allow-commands"});
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  EXPECT_LT(seconds, 25.0);  // the sleepers were killed at their 3 s timeout, not after 30 s
  EXPECT_NE(run.out.find("10 method runs failed"), std::string::npos) << run.out;
  const auto rows = ReadItems(dir.File("out/items.csv"));
  const std::map<std::string, std::string> reasons = {
      {"crash", "exit status 3: the model exploded (log: external/crash/batch-hull-c0000.log)"},
      {"slow", "timed out after"},
      {"silent", "wrote no output for this item (expected hull-c000"},
      {"small", "wrong size: 2x2, the input is 136x102"},
      {"nan", "1 non-finite values (NaN or inf)"}};
  for (const std::string& id : kIds) {
    EXPECT_EQ(rows.at(id + " clahe").at("error"), "");
    EXPECT_NE(rows.at(id + " clahe").at("ssim"), "nan");
    for (const auto& [method, reason] : reasons) {
      const auto& row = rows.at(id + " " + method);
      EXPECT_NE(row.at("error").find(reason), std::string::npos) << method << ": " << row.at("error");
      EXPECT_EQ(row.at("ssim"), "nan") << method;
    }
  }
  // The log of the failed batch is kept; the reason is in the journal.
  EXPECT_NE(ReadFileText(dir.File("out/external/crash/batch-hull-c0000.log")).find("exploded"),
            std::string::npos);
  EXPECT_NE(ReadFileText(dir.File("out/journal.jsonl")).find("exit status 3"), std::string::npos);
  // The timeout killed the whole process group: the scripts' `sleep 30` children are gone.
  std::istringstream pids(ReadFileText(dir.File("pids.txt")));
  int count = 0;
  for (pid_t parent = 0, child = 0; pids >> parent >> child; ++count) {
    for (int wait = 0; wait < 100 && (Alive(parent) || Alive(child)); ++wait) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_FALSE(Alive(parent)) << parent;
    EXPECT_FALSE(Alive(child)) << child;
  }
  // Both sleepers normally record their pids within the 3 s; on a heavily loaded machine a
  // Python start-up may take longer, so at least one must have.
  EXPECT_GE(count, 1);
  // The tables count the failed items per method.
  const std::string md = ReadFileText(dir.File("out/summary.md"));
  EXPECT_NE(md.find("| failed (items) | 0 | 0 | 0 | 2 | 2 | 2 | 2 | 2 |"), std::string::npos)
      << md;
  const std::string csv = ReadFileText(dir.File("out/summary.csv"));
  EXPECT_NE(csv.find("level,method,metric,domain,n,mean,sd,ci_lo,ci_hi,min,max,failed\n"),
            std::string::npos);
  EXPECT_NE(csv.find("all,crash,ssim,encoded,0,nan,nan,nan,nan,nan,nan,2\n"), std::string::npos)
      << csv;
  EXPECT_NE(csv.find("0.3,clahe,ssim,encoded,1,"), std::string::npos) << csv;
}

TEST(HarnessExternal, ResumeKeepsFailedCellsUntilRetryFailed) {
  TempDir dir;
  WriteFile(dir.path(), "copy.py", kCopyScript);
  WriteFile(dir.path(), "fail_flag", "");
  const std::string exp = WriteFile(dir.path(), "exp.json",
                                    TinyExperiment(std::string(kCopyBatch) + ", " + kCopyOne));
  const std::string out = dir.File("out");
  const CliRun first =
      RunTurbid({"sweep", exp, "--out", out, "--threads", "1", "--allow-commands"});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  auto rows = ReadItems(out + "/items.csv");
  EXPECT_NE(rows.at("hull-c0000 copy_one").at("error").find("fail_flag is set"),
            std::string::npos);
  EXPECT_EQ(rows.at("hull-c0000 copy_batch").at("error"), "");
  fs::remove(dir.File("fail_flag"));
  // A plain rerun resumes: everything is journaled, so nothing runs and the failure stays.
  const CliRun again = RunTurbid({"sweep", exp, "--out", out, "--allow-commands"});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.out.find("nothing to do"), std::string::npos) << again.out;
  EXPECT_NE(ReadItems(out + "/items.csv").at("hull-c0001 copy_one").at("error"), "");
  // --retry-failed runs the failed cells only: the batch method does not run again.
  const std::string items_before = ReadFileText(out + "/items.csv");
  const CliRun retry =
      RunTurbid({"sweep", exp, "--out", out, "--retry-failed", "--allow-commands"});
  ASSERT_EQ(retry.exit_code, 0) << retry.err;
  EXPECT_NE(retry.out.find("2 items run (2 retried)"), std::string::npos) << retry.out;
  EXPECT_EQ(ReadFileText(dir.File("batch_runs.txt")), "2\n");
  rows = ReadItems(out + "/items.csv");
  ExpectSameMetrics(rows, "copy_one");
  ExpectSameMetrics(rows, "copy_batch");
  EXPECT_NE(ReadFileText(out + "/items.csv"), items_before);
  // Retrying again finds nothing failed.
  const CliRun done = RunTurbid({"sweep", exp, "--out", out, "--retry-failed", "--allow-commands"});
  EXPECT_NE(done.out.find("nothing to do"), std::string::npos) << done.out;
}

TEST(HarnessExternal, ResultsFolderIsScoredWithoutRunningAndMissingFilesFailPerItem) {
  TempDir dir;
  WriteFile(dir.path(), "copy.py", kCopyScript);
  // A first sweep keeps the degraded inputs as results/theirs/<id>.pfm.
  std::string keeper = kCopyBatch;
  keeper.replace(keeper.find("\"EXT_TOKEN\": \"abc\""), 18,
                 "\"EXT_TOKEN\": \"abc\", \"EXT_KEEP\": \"results/theirs\"");
  const std::string first = WriteFile(dir.path(), "first.json", TinyExperiment(keeper));
  ASSERT_EQ(RunTurbid({"sweep", first, "--out", dir.File("first"), "--allow-commands"}).exit_code,
            0);
  ASSERT_TRUE(fs::exists(dir.File("results/theirs/hull-c0001.pfm")));
  fs::remove(dir.File("results/theirs/hull-c0001.pfm"));
  const std::string exp = WriteFile(
      dir.path(), "theirs.json",
      TinyExperiment(R"("clahe", {"name": "theirs", "results": "results/theirs/{id}.pfm"})"));
  const CliRun run = RunTurbid({"sweep", exp, "--out", dir.File("out")});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto rows = ReadItems(dir.File("out/items.csv"));
  for (const std::string& metric : kMetrics) {
    EXPECT_EQ(rows.at("hull-c0000 theirs").at(metric), rows.at("hull-c0000 none").at(metric));
  }
  EXPECT_EQ(rows.at("hull-c0001 theirs").at("error"),
            "missing results file results/theirs/hull-c0001.pfm");
  // Nothing ran: the time is not a run time.
  EXPECT_NE(ReadFileText(dir.File("out/timings.csv")).find("hull-c0000,theirs,nan,none"),
            std::string::npos);
}

TEST(HarnessExternal, BadExternalMethodsAreRejectedBeforeAnyWork) {
  TempDir dir;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"name": "x", "command": ["python3", "a.py", "{input}"]})", "must contain {output}"},
      {R"({"name": "x", "command": ["a", "{input_dir}", "{output_dir}"]})",
       "needs \"batch\": true"},
      {R"({"name": "x", "command": [], "batch": true})", "non-empty array"},
      {R"({"name": "x", "command": ["a", "{input}", "{output}"], "timeout_s": 0})", "timeout_s"},
      {R"({"name": "x", "command": ["a", "{input}", "{output}"], "input": {"format": "jpg"}})",
       "'input.format'"},
      {R"({"name": "x", "command": ["a", "{input}", "{output}"], "input": {"bits": 12}})",
       "'input.bits'"},
      {R"({"name": "x", "command": ["a", "{input}", "{output}"], "env": {"A": 1}})", "'env'"},
      {R"({"name": "x", "command": ["a", "{input}", "{output}"], "params": {}})",
       "unknown key 'params'"},
      {R"({"name": "x", "results": "out/x.png"})", "{id}"},
      {R"({"name": "none", "results": "out/{id}.png"})", "reserved"},
      {R"({"name": "x", "python": "x", "results": "out/{id}.png"})", "give one of"},
      {R"({"name": "x", "python": ""})", "'python' must be the key"},
      {R"({"name": "x", "python": "x", "batch_size": 4})", "\"batch\": true methods only"},
      {R"({"name": "x", "python": "x", "encoding": "gamma"})", "'encoding'"},
      {R"({"name": "x", "python": "x", "timeout_s": 5})", "unknown key 'timeout_s'"},
      // Valid, but only turbid.sweep in Python can run it: refused before any work.
      {R"({"name": "x", "python": "x", "batch": true})", "is a Python callable"},
  };
  for (const auto& [method, message] : cases) {
    const std::string exp = WriteFile(dir.path(), "bad.json", TinyExperiment(method));
    const CliRun run = RunTurbid({"sweep", exp, "--out", dir.File("never")});
    EXPECT_EQ(run.exit_code, 1) << method;
    EXPECT_NE(run.err.find(message), std::string::npos) << method << " -> " << run.err;
    EXPECT_FALSE(fs::exists(dir.File("never"))) << method;
  }
}

TEST(HarnessExternal, ProcessStartFailureIsOneLine) {
  TempDir dir;
  ProcessOptions options;
  options.argv = {"/nonexistent/turbid-test-program", "x"};
  options.log_path = dir.File("log.txt");
  const ProcessResult result = RunProcess(options);
  EXPECT_FALSE(result.started);
  EXPECT_NE(result.Failure().find("cannot start"), std::string::npos) << result.Failure();
  std::string why;
  options.timeout_s = -1;
  EXPECT_FALSE(options.Check(&why));
}

// A tiny `turbid generate` dataset: 1 scene x 2 turbidity values.
std::string Generate(const TempDir& dir) {
  WriteFile(dir.path(), "gen.json", R"({"scenes": ["builtin:seafloor"], "scale": 0.1, "seed": 2,
    "grid": {"water.beta_gray_per_m": [0.3, 1.0]}})");
  const CliRun run = RunTurbid({"generate", dir.File("gen.json"), "--out", dir.File("data")});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  return dir.File("data");
}

TEST(HarnessExternal, ScoreResultsFolderAgainstDataset) {
  TempDir dir;
  const std::string data = Generate(dir);
  std::vector<std::string> ids;
  for (const auto& entry : fs::directory_iterator(data + "/images")) {
    ids.push_back(entry.path().stem().string());
  }
  std::sort(ids.begin(), ids.end());
  ASSERT_EQ(ids.size(), 2u);
  // Results = the ground truth itself (one item missing), and = the degraded inputs.
  fs::create_directories(dir.File("perfect"));
  fs::copy_file(data + "/ground_truth/" + ids[0] + ".png", dir.File("perfect/" + ids[0] + ".png"));
  fs::create_directories(dir.File("degraded"));
  for (const std::string& id : ids) {
    fs::copy_file(data + "/images/" + id + ".png", dir.File("degraded/" + id + ".png"));
  }
  const CliRun perfect = RunTurbid({"score", "--manifest", data + "/manifest.csv", "--results",
                                    dir.File("perfect"), "--out", dir.File("s1"), "--metrics",
                                    "ssim,psnr,hautiere_e"});
  ASSERT_EQ(perfect.exit_code, 0) << perfect.err;
  EXPECT_NE(perfect.out.find("1 scored, 1 failed or missing"), std::string::npos) << perfect.out;
  auto rows = ReadItems(dir.File("s1/items.csv"));
  EXPECT_EQ(rows.at(ids[0] + " perfect").at("ssim"), "1");
  EXPECT_EQ(rows.at(ids[0] + " perfect").at("psnr"), "inf");
  EXPECT_EQ(rows.at(ids[1] + " perfect").at("error"), "missing results file " + ids[1] + ".*");
  EXPECT_TRUE(fs::exists(dir.File("s1/summary.md")));
  const std::string summary = ReadFileText(dir.File("s1/summary.csv"));
  EXPECT_NE(summary.find("all,perfect,ssim,encoded,1,1,0,1,1,1,1,1\n"), std::string::npos)
      << summary;
  EXPECT_NE(summary.find("\n0.3,none,ssim,encoded,1,"), std::string::npos) << summary;

  // The degraded images as results score exactly like the `none` row; default name and --out.
  const CliRun same = RunTurbid(
      {"score", "--manifest", data + "/manifest.csv", "--results", dir.File("degraded"),
       "--metrics", "ssim,psnr,hautiere_e"});
  ASSERT_EQ(same.exit_code, 0) << same.err;
  rows = ReadItems(dir.File("degraded/turbid-score/items.csv"));
  for (const std::string& id : ids) {
    for (const std::string& metric : kMetrics) {
      EXPECT_EQ(rows.at(id + " degraded").at(metric), rows.at(id + " none").at(metric)) << metric;
    }
  }
  // Regression baselines work on these tables like on a sweep's.
  const CliRun regress = RunTurbid({"regress", "--baseline", dir.File("s1/summary.csv"),
                                    dir.File("degraded/turbid-score/summary.csv")});
  EXPECT_EQ(regress.exit_code, 1);  // "perfect" rows are absent from the other table
  EXPECT_NE(regress.out.find("MISSING"), std::string::npos) << regress.out;

  // Independent path: the same files scored one by one through a hand-written manifest
  // (`turbid score --manifest` with image / ground_truth / original columns) give the same values.
  // Tolerance: relative 1e-6: --results reads 8-bit files as float32 codes / 255, score --manifest
  // keeps integer codes with data range 255: the same formulas, rounded differently (measured 3e-8).
  std::string manual = "id,image,ground_truth,original\n";
  for (const std::string& id : ids) {
    manual += id + "," + dir.File("degraded/" + id + ".png") + "," + data + "/ground_truth/" + id +
              ".png," + data + "/images/" + id + ".png\n";
  }
  WriteFile(dir.path(), "manual.csv", manual);
  const CliRun by_hand = RunTurbid({"score", "--manifest", dir.File("manual.csv"), "--csv",
                                    "--metrics", "ssim,psnr,hautiere_e"});
  ASSERT_EQ(by_hand.exit_code, 0) << by_hand.err;
  std::istringstream lines(by_hand.out);
  std::string line;
  std::getline(lines, line);
  const std::vector<std::string> header = SplitCsvLine(line);
  int compared = 0;
  while (std::getline(lines, line)) {
    const std::vector<std::string> fields = SplitCsvLine(line);
    if (fields.size() != header.size()) continue;  // the mean line
    std::map<std::string, std::string> row;
    for (size_t i = 0; i < header.size(); ++i) row[header[i]] = fields[i];
    if (!rows.count(row["image"] + " degraded")) continue;
    for (const std::string& metric : kMetrics) {
      const double expected = std::stod(row.at(metric));
      const double got = std::stod(rows.at(row["image"] + " degraded").at(metric));
      EXPECT_NEAR(got, expected, 1e-6 * std::abs(expected)) << row["image"] << " " << metric;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 6) << by_hand.out;

  const CliRun no_manifest = RunTurbid({"score", "--results", dir.File("degraded")});
  EXPECT_NE(no_manifest.exit_code, 0);
  EXPECT_NE(no_manifest.err.find("--results needs --manifest"), std::string::npos);
}

// The shipped example experiment is valid (its script needs numpy; docs/experiments.md runs it).
TEST(HarnessExternal, ShippedExampleExperimentIsValid) {
  // CMake compiles with absolute paths: the repository root is three levels above this file.
  const std::string exp = (fs::path(__FILE__).parent_path().parent_path().parent_path() /
                           "scenes/experiments/examples/external.json")
                              .string();
  const CliRun run =
      RunTurbid({"sweep", exp, "--out", "/nonexistent/never", "--dry-run", "--allow-commands"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("4 items"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("method 'grayworld' (one process per batch of up to 16 items)"),
            std::string::npos)
      << run.out;
  // Its commands run only with --allow-commands: without it the dry run lists them and fails.
  const CliRun refused = RunTurbid({"sweep", exp, "--out", "/nonexistent/never", "--dry-run"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("method 'grayworld' runs an external command"), std::string::npos)
      << refused.err;
}

}  // namespace
}  // namespace turbid
