// Nothing lost on a full disk (docs/reliability.md): a failure of turbid's own output writes
// (ENOSPC, EFBIG, an I/O error, a file that cannot be renamed into place) is an OutputError,
// which the sweep does not record as a method failure: it stops with one line naming the file,
// journals nothing for the item being written, and a plain rerun completes the same bytes as an
// uninterrupted run. And journal entries are validated against the experiment: an incomplete
// entry is run again on resume, and `merge` and `report` refuse it with one line.
// The tmpfs trials (a disk that really fills) are scripts/disk_full_trials.py (ctest
// tools/disk_full_trials).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "tests/support/test_support.h"
#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

const char* kExperiment = R"({
  "name": "disk",
  "seed": 5,
  "scale": 0.1,
  "scenes": ["builtin:seafloor"],
  "grid": {"water.type": ["I", "II", "3C"]},
  "methods": ["clahe", "dcp"],
  "metrics": ["ssim", "psnr"],
  "thumbnails": 32
})";

// Relative path -> bytes of every file under `root` (the lock file, the journal and the timing
// tables aside: they hold wall-clock times).
std::map<std::string, std::string> DeterministicFiles(const std::string& root) {
  std::map<std::string, std::string> out;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file()) continue;
    const std::string rel = fs::relative(entry.path(), root).string();
    if (rel == ".turbid.lock" || rel == "journal.jsonl" || rel.rfind("timings.", 0) == 0) continue;
    out[rel] = ReadFileText(entry.path().string());
  }
  return out;
}

void ExpectOneErrorLine(const std::string& err, const std::string& part) {
  EXPECT_EQ(err.rfind("turbid: error: ", 0), 0u) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find(part), std::string::npos) << err;
}

std::vector<json> JournalEntries(const std::string& path) {
  std::vector<json> entries;
  std::istringstream in(ReadFileText(path));
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) entries.push_back(json::parse(line));
  return entries;
}

void WriteJournal(const std::string& path, const std::vector<json>& entries) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  for (const json& entry : entries) out << entry.dump() << "\n";
}

TEST(DiskFull, AJournalAppendOnAFullDeviceIsAnOutputError) {
  // Writing to /dev/full fails with ENOSPC, as on a full disk.
  Journal journal("/dev/full");
  try {
    journal.Append(json{{"id", "x"}});
    FAIL() << "appended to /dev/full";
  } catch (const OutputError& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind("/dev/full: ", 0), 0u) << message;
    EXPECT_NE(message.find(std::strerror(ENOSPC)), std::string::npos) << message;
  }
}

TEST(DiskFull, AnAtomicWritePastAFileSizeLimitIsAnOutputErrorAndLeavesNothing) {
  TempDir dir;
  const std::string path = dir.File("big.txt");
  const pid_t child = fork();
  if (child == 0) {  // the limit applies to the child only
    signal(SIGXFSZ, SIG_IGN);
    const struct rlimit limit = {1000, 1000};
    setrlimit(RLIMIT_FSIZE, &limit);
    try {
      AtomicWriteText(path, std::string(5000, 'x'), true);
    } catch (const OutputError& error) {
      const std::string message = error.what();
      _exit(message.rfind(path + ": cannot write: ", 0) == 0 &&
                    message.find(std::strerror(EFBIG)) != std::string::npos
                ? 0
                : 2);
    } catch (...) {
      _exit(3);  // another exception type: a method failure for the sweep
    }
    _exit(4);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "2: wrong message, 3: not an OutputError, 4: no error";
  EXPECT_TRUE(fs::is_empty(dir.path())) << "the file or its temporary was left behind";
}

TEST(DiskFull, AFileThatCannotBeRenamedIntoPlaceIsAnOutputError) {
  TempDir dir;
  fs::create_directories(dir.File("taken.png"));  // rename(2) onto a directory: EISDIR
  EXPECT_THROW(AtomicWriteText(dir.File("taken.png"), "bytes", true), OutputError);
  EXPECT_THROW(AtomicWriteText(dir.File("no/folder.txt"), "bytes", true), OutputError);
  for (const auto& entry : fs::directory_iterator(dir.path()))
    EXPECT_FALSE(IsTemporaryName(entry.path().filename().string())) << entry.path();
}

// A method's thumbnail that cannot be written stops the sweep: before, it was recorded as a
// failure of the method (NaN scores) and the item journaled as done, so that a plain rerun kept
// the NaN cells.
TEST(DiskFullCli, AThumbnailWriteFailureStopsTheSweepInsteadOfFailingTheMethod) {
  TempDir dir;
  const std::string exp = dir.Write("exp.json", kExperiment);
  const CliRun reference = RunTurbid({"sweep", exp, "--out", dir.File("ref"), "--quiet"});
  ASSERT_EQ(reference.exit_code, 0) << reference.err;
  const std::vector<json> ref_entries = JournalEntries(dir.File("ref/journal.jsonl"));
  ASSERT_EQ(ref_entries.size(), 3u);
  for (const char* label : {"clahe", "dcp"}) {
    SCOPED_TRACE(label);
    const std::string out = dir.File(std::string("out_") + label);
    const std::string id = ref_entries[1].at("id").get<std::string>();
    const std::string blocked = out + "/thumbs/" + id + "/" + label + ".png";
    fs::create_directories(blocked);  // the thumbnail's name is taken by a folder
    const CliRun stopped = RunTurbid({"sweep", exp, "--out", out, "--quiet", "--threads", "1"});
    EXPECT_EQ(stopped.exit_code, 1) << stopped.out;
    ExpectOneErrorLine(stopped.err, blocked + ": cannot rename");
    EXPECT_NE(stopped.err.find("the sweep stopped"), std::string::npos) << stopped.err;
    for (const json& entry : JournalEntries(out + "/journal.jsonl")) {
      EXPECT_NE(entry.at("id"), id) << "the item whose thumbnail failed was journaled";
      for (const json& row : entry.at("methods")) EXPECT_FALSE(row.contains("error")) << row;
    }
    EXPECT_FALSE(fs::exists(out + "/summary.md"));
    fs::remove(blocked);
    const CliRun rerun = RunTurbid({"sweep", exp, "--out", out, "--quiet"});
    ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
    EXPECT_TRUE(DeterministicFiles(out) == DeterministicFiles(dir.File("ref")));
  }
}

// The same through the batch path (FinishBatch), with an in-process batch method: our thumbnail
// write stops the sweep, while the method's own exceptions, an OutputError included (its own
// write), stay failures of its cells.
TEST(DiskFull, InTheBatchPathOurWriteStopsTheSweepAndTheMethodsOwnErrorsFailItsCells) {
  TempDir dir;
  const json doc = json::parse(R"({
    "name": "batch", "seed": 2, "scale": 0.05, "scenes": ["builtin:seafloor"],
    "grid": {"water.type": ["I", "II", "3C", "5C"]},
    "methods": [{"name": "mine", "python": "mine", "batch": true, "batch_size": 2}],
    "metrics": ["psnr"], "thumbnails": 16
  })");
  const Experiment experiment = ParseExperiment(doc, dir.File("exp.json"), RegistryCatalog());
  const std::vector<ItemSpec> specs = ExpandItems(experiment);
  const auto run = [&](const std::string& out, const InProcessMethod& method) {
    HarnessRunnerOptions options;
    options.in_process["mine"] = method;
    const HarnessRunner runner(experiment, out, options);
    SweepOptions sweep;
    sweep.out_dir = out;
    sweep.threads = 1;
    return RunSweep(experiment, sweep, runner.Hooks());
  };
  const InProcessMethod identity = [](const json&, const std::vector<cv::Mat>& images,
                                      const std::vector<std::string>&) { return images; };
  // Our write: the batch's thumbnail of item 2 cannot be renamed into place.
  const std::string blocked = dir.File("out/thumbs/" + specs[2].id + "/mine.png");
  fs::create_directories(blocked);
  EXPECT_THROW(run(dir.File("out"), identity), OutputError);
  const std::vector<json> journaled = JournalEntries(dir.File("out/journal.jsonl"));
  ASSERT_EQ(journaled.size(), 2u) << "the first batch only";
  for (const json& entry : journaled) EXPECT_FALSE(entry.at("methods")[0].contains("error"));
  fs::remove(blocked);
  const SweepSummary resumed = run(dir.File("out"), identity);
  EXPECT_EQ(resumed.ran, 2);
  EXPECT_EQ(resumed.failed_rows, 0);
  // The method's own errors: every cell fails, the sweep completes.
  for (const bool output_error : {false, true}) {
    const InProcessMethod failing = [&](const json&, const std::vector<cv::Mat>&,
                                        const std::vector<std::string>&) -> std::vector<cv::Mat> {
      if (output_error) throw OutputError("/its/own/file.png", "cannot write: disk full");
      throw Error("out of GPU memory");
    };
    const std::string out = dir.File(output_error ? "own_write" : "own_error");
    const SweepSummary summary = run(out, failing);
    EXPECT_EQ(summary.ran, 4);
    EXPECT_EQ(summary.failed_rows, 4);
    EXPECT_TRUE(summary.tables_written);
  }
}

// The same for `generate`: one line naming the file, and a rerun completes the same bytes.
TEST(DiskFullCli, GenerateStopsOnAFailedWriteAndARerunCompletesTheSameBytes) {
  TempDir dir;
  const std::string config = dir.Write("gen.json", R"({
    "scenes": ["builtin:seafloor"], "scale": 0.1, "seed": 3, "grid": {"water.type": ["I", "3C"]}
  })");
  ASSERT_EQ(RunTurbid({"generate", config, "--out", dir.File("ref")}).exit_code, 0);
  const std::string blocked = dir.File("out/ground_truth/seafloor_000001.png");
  fs::create_directories(blocked);
  const CliRun stopped = RunTurbid({"generate", config, "--out", dir.File("out")});
  EXPECT_EQ(stopped.exit_code, 1);
  ExpectOneErrorLine(stopped.err, blocked + ": cannot rename");
  fs::remove(blocked);
  ASSERT_EQ(RunTurbid({"generate", config, "--out", dir.File("out")}).exit_code, 0);
  EXPECT_TRUE(DeterministicFiles(dir.File("out")) == DeterministicFiles(dir.File("ref")));
}

// `merge` and `report`: a table that cannot be written is one line naming it.
TEST(DiskFullCli, MergeAndReportStopOnAFailedWrite) {
  TempDir dir;
  const std::string exp = dir.Write("exp.json", kExperiment);
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", dir.File("s"), "--quiet"}).exit_code, 0);
  fs::create_directories(dir.File("m/items.csv"));
  const CliRun merge = RunTurbid({"merge", dir.File("s"), "--out", dir.File("m")});
  EXPECT_EQ(merge.exit_code, 1);
  ExpectOneErrorLine(merge.err, dir.File("m/items.csv") + ": cannot rename");
  fs::remove(dir.File("m/items.csv"));
  ASSERT_EQ(RunTurbid({"merge", dir.File("s"), "--out", dir.File("m")}).exit_code, 0);
  EXPECT_EQ(ReadFileText(dir.File("m/items.csv")), ReadFileText(dir.File("s/items.csv")));

  std::ofstream(dir.File("s/report")) << "a file where the report folder goes";
  const CliRun report = RunTurbid({"report", dir.File("s"), "--gnuplot", "/nonexistent"});
  EXPECT_EQ(report.exit_code, 1);
  ExpectOneErrorLine(report.err, dir.File("s/report") + ": cannot create");
}

// ---- Journal validation ---------------------------------------------------------------------

struct Mutation {
  const char* name;
  std::function<void(json*)> apply;
};

const std::vector<Mutation>& Mutations() {
  static const std::vector<Mutation> mutations = {
      {"no method rows", [](json* e) { (*e)["methods"] = json::array(); }},
      {"a method row missing", [](json* e) { (*e)["methods"].erase(1); }},
      {"a method row twice", [](json* e) { (*e)["methods"][1] = (*e)["methods"][0]; }},
      {"rows swapped", [](json* e) { std::swap((*e)["methods"][0], (*e)["methods"][1]); }},
      {"a metric missing", [](json* e) { (*e)["methods"][0]["metrics"].erase("psnr"); }},
      {"an unknown metric", [](json* e) { (*e)["methods"][1]["metrics"]["x"] = 1.0; }},
      {"another item's level", [](json* e) { (*e)["level"] = "no such level"; }},
      {"another seed", [](json* e) { (*e)["seed"] = (*e)["seed"].get<uint64_t>() + 1; }},
      {"a row without metrics", [](json* e) { (*e)["methods"][0].erase("metrics"); }},
  };
  return mutations;
}

TEST(JournalValidationCli, AnIncompleteEntryIsRunAgainOnResumeWithANote) {
  TempDir dir;
  const std::string exp = dir.Write("exp.json", kExperiment);
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", dir.File("ref"), "--quiet"}).exit_code, 0);
  const std::vector<json> entries = JournalEntries(dir.File("ref/journal.jsonl"));
  ASSERT_EQ(entries.size(), 3u);
  for (const Mutation& mutation : Mutations()) {
    SCOPED_TRACE(mutation.name);
    const std::string out = dir.File("out");
    fs::remove_all(out);
    fs::create_directories(out);
    fs::copy_file(dir.File("ref/experiment.json"), out + "/experiment.json");
    std::vector<json> edited = entries;
    mutation.apply(&edited[1]);
    WriteJournal(out + "/journal.jsonl", edited);
    const CliRun rerun = RunTurbid({"sweep", exp, "--out", out, "--quiet"});
    ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
    const std::string id = entries[1].at("id").get<std::string>();
    EXPECT_NE(rerun.err.find("turbid: note: " + out + "/journal.jsonl: the entry of item '" + id +
                             "' is incomplete"),
              std::string::npos)
        << rerun.err;
    EXPECT_NE(rerun.out.find("sweep: 1 items run, 2 already done"), std::string::npos) << rerun.out;
    for (const std::string& name : DeterministicOutputs())
      EXPECT_TRUE(ReadFileText(dir.File("ref/" + name)) == ReadFileText(out + "/" + name)) << name;
  }
}

TEST(JournalValidationCli, MergeAndReportRefuseAnIncompleteEntry) {
  TempDir dir;
  const std::string exp = dir.Write("exp.json", kExperiment);
  for (int shard = 0; shard < 2; ++shard) {
    ASSERT_EQ(RunTurbid({"sweep", exp, "--out", dir.File("s" + std::to_string(shard)), "--shard",
                         std::to_string(shard) + "/2", "--quiet"})
                  .exit_code,
              0);
  }
  const std::string journal = dir.File("s1/journal.jsonl");
  const std::vector<json> entries = JournalEntries(journal);
  ASSERT_FALSE(entries.empty());
  for (const Mutation& mutation : Mutations()) {
    SCOPED_TRACE(mutation.name);
    std::vector<json> edited = entries;
    mutation.apply(&edited[0]);
    WriteJournal(journal, edited);
    const std::string id = entries[0].at("id").get<std::string>();
    const CliRun merge =
        RunTurbid({"merge", dir.File("s0"), dir.File("s1"), "--out", dir.File("m")});
    EXPECT_EQ(merge.exit_code, 1);
    ExpectOneErrorLine(merge.err, journal + ": the entry of item '" + id + "' is incomplete");
    EXPECT_FALSE(fs::exists(dir.File("m/items.csv")));
    const CliRun report = RunTurbid({"report", dir.File("s1"), "--gnuplot", "/nonexistent"});
    EXPECT_EQ(report.exit_code, 1);
    ExpectOneErrorLine(report.err, journal + ": the entry of item '" + id + "' is incomplete");
  }
  // Rerunning the shard repairs it: merge then gives the unsharded tables.
  ASSERT_EQ(
      RunTurbid({"sweep", exp, "--out", dir.File("s1"), "--shard", "1/2", "--quiet"}).exit_code, 0);
  ASSERT_EQ(RunTurbid({"merge", dir.File("s0"), dir.File("s1"), "--out", dir.File("m")}).exit_code,
            0);
  ASSERT_EQ(RunTurbid({"sweep", exp, "--out", dir.File("whole"), "--quiet"}).exit_code, 0);
  for (const std::string& name : DeterministicOutputs())
    EXPECT_TRUE(ReadFileText(dir.File("whole/" + name)) == ReadFileText(dir.File("m/" + name)))
        << name;
}

}  // namespace
}  // namespace turbid
