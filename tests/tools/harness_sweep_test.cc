// The sweep engine with a fake item runner: identical bytes for any thread count, kill -9 and
// resume with nothing lost or duplicated, a finished sweep reruns as a no-op, shards merge into
// exactly the unsharded result, and the regression check catches a perturbed method.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include "core/error.h"
#include "tests/support/test_support.h"
#include "tests/tools/harness_fakes.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::FakeCatalog;
using testing::FakeExperimentJson;
using testing::FakeRunner;
using testing::ReadFileText;
using testing::TempDir;

Experiment FakeExperiment() {
  return ParseExperiment(FakeExperimentJson(), "exp.json", FakeCatalog());
}

SweepSummary Sweep(const Experiment& e, const std::string& dir, int threads, Shard shard = {},
                   std::atomic<int>* calls = nullptr, int delay_ms = 0) {
  SweepOptions options;
  options.out_dir = dir;
  options.threads = threads;
  options.shard = shard;
  FakeRunner runner{&e, 0.0, delay_ms, calls};
  return RunSweep(e, options, runner);
}

void ExpectSameDeterministicFiles(const std::string& a, const std::string& b) {
  for (const std::string& name : DeterministicOutputs()) {
    const std::string left = ReadFileText(a + "/" + name), right = ReadFileText(b + "/" + name);
    EXPECT_FALSE(left.empty()) << name;
    EXPECT_TRUE(left == right) << name << " differs between " << a << " and " << b;
  }
}

TEST(HarnessSweep, DefaultOptionsCheck) {
  SweepOptions options;
  std::string why;
  EXPECT_FALSE(options.Check(&why));  // --out is required
  options.out_dir = "x";
  EXPECT_TRUE(options.Check(&why)) << why;
  RegressOptions regress;
  EXPECT_TRUE(regress.Check(&why)) << why;
}

TEST(HarnessSweep, OneAndThreeThreadsGiveIdenticalBytes) {
  const Experiment e = FakeExperiment();
  TempDir one, three;
  const SweepSummary s1 = Sweep(e, one.path(), 1);
  const SweepSummary s3 = Sweep(e, three.path(), 3);
  EXPECT_EQ(s1.ran, 24);
  EXPECT_EQ(s3.ran, 24);
  EXPECT_EQ(s1.failed_rows, 6);  // fake_b fails at beta 2 on 6 items
  ExpectSameDeterministicFiles(one.path(), three.path());
  // Rows are in item order, then method order; errors are recorded, not fatal.
  const std::string csv = ReadFileText(one.path() + "/items.csv");
  EXPECT_EQ(
      csv.substr(0, csv.find('\n')),
      "id,scene,condition,level,param:water.beta,param:water.type,method,score_domain,up,down,nr,"
      "error");
  EXPECT_NE(csv.find("\na-c0000,a,0,0.1,0.1,"), std::string::npos);
  EXPECT_NE(csv.find("fake failure"), std::string::npos);
  EXPECT_LT(csv.find("\na-c0000,"), csv.find("\na-c0001,"));
  EXPECT_LT(csv.find("\na-c0011,"), csv.find("\nb-c0000,"));
  // Timings exist, but only in the timing files.
  EXPECT_NE(ReadFileText(one.path() + "/timings.csv").find("a-c0000,fake_a,"), std::string::npos);
  EXPECT_EQ(ReadFileText(one.path() + "/items.jsonl").find("time_ms"), std::string::npos);
}

TEST(HarnessSweep, FinishedSweepRerunsAsNoOp) {
  const Experiment e = FakeExperiment();
  TempDir dir;
  Sweep(e, dir.path(), 2);
  const std::string summary = ReadFileText(dir.path() + "/summary.md");
  const auto written = fs::last_write_time(dir.path() + "/summary.md");
  std::atomic<int> calls{0};
  const SweepSummary again = Sweep(e, dir.path(), 2, {}, &calls);
  EXPECT_EQ(calls.load(), 0);
  EXPECT_EQ(again.ran, 0);
  EXPECT_EQ(again.already_done, 24);
  EXPECT_FALSE(again.tables_written);
  EXPECT_EQ(fs::last_write_time(dir.path() + "/summary.md"), written);
  EXPECT_EQ(ReadFileText(dir.path() + "/summary.md"), summary);
}

TEST(HarnessSweep, DifferentExperimentInSameFolderIsRefused) {
  const Experiment e = FakeExperiment();
  TempDir dir;
  Sweep(e, dir.path(), 2);
  nlohmann::json other = FakeExperimentJson();
  other["grid"]["water.beta"] = {0.3};
  const Experiment changed = ParseExperiment(other, "exp.json", FakeCatalog());
  EXPECT_THROW(Sweep(changed, dir.path(), 2), Error);
  SweepOptions options;
  options.out_dir = dir.path();
  options.force = true;
  const SweepSummary forced = RunSweep(changed, options, FakeRunner{&changed});
  EXPECT_EQ(forced.ran, changed.ItemCount());
}

// While one sweep writes a folder (it holds DIR/.turbid.lock), a second one into the same folder
// is refused before it touches anything; the lock goes with the holder.
TEST(HarnessSweep, SecondSweepIntoABusyFolderIsRefused) {
  const Experiment e = FakeExperiment();
  TempDir dir;
  const std::string lock_path = dir.path() + "/.turbid.lock";
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
  try {
    Sweep(e, dir.path(), 1);
    ADD_FAILURE() << "a sweep ran in a locked folder";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("another turbid sweep"), std::string::npos)
        << error.what();
  }
  EXPECT_FALSE(fs::exists(dir.path() + "/journal.jsonl"));
  EXPECT_FALSE(fs::exists(dir.path() + "/experiment.json"));
  ::close(fd);  // the holder ends: the folder is free again
  EXPECT_EQ(Sweep(e, dir.path(), 1).ran, 24);
}

TEST(HarnessSweep, PartialJournalLineIsDroppedOnResume) {
  const Experiment e = FakeExperiment();
  TempDir reference, dir;
  Sweep(e, reference.path(), 2);
  // Simulate a kill in the middle of an append: 10 complete lines and half of the 11th.
  const std::string journal = ReadFileText(reference.path() + "/journal.jsonl");
  size_t cut = 0;
  for (int line = 0; line < 10; ++line) cut = journal.find('\n', cut) + 1;
  const size_t half = cut + (journal.find('\n', cut) - cut) / 2;
  fs::copy_file(reference.path() + "/experiment.json", dir.path() + "/experiment.json");
  std::ofstream(dir.path() + "/journal.jsonl", std::ios::binary) << journal.substr(0, half);
  std::atomic<int> calls{0};
  const SweepSummary resumed = Sweep(e, dir.path(), 2, {}, &calls);
  EXPECT_EQ(resumed.already_done, 10);
  EXPECT_EQ(calls.load(), 14);
  ExpectSameDeterministicFiles(reference.path(), dir.path());
}

TEST(HarnessSweep, CorruptJournalLineIsAnError) {
  const Experiment e = FakeExperiment();
  TempDir dir;
  Sweep(e, dir.path(), 2);
  std::string journal = ReadFileText(dir.path() + "/journal.jsonl");
  journal.replace(journal.find('\n') + 1, 5, "#####");
  std::ofstream(dir.path() + "/journal.jsonl", std::ios::binary) << journal;
  try {
    Sweep(e, dir.path(), 2);
    FAIL() << "a corrupt middle line must not be ignored";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("line 2 is corrupt"), std::string::npos);
  }
}

// kill -9 at random moments: a child process runs the sweep (slow fake items), the parent kills
// it, several times; then one uninterrupted rerun must complete with no missing and no duplicate
// rows, byte-identical to a clean run.
TEST(HarnessSweep, KillNineAndResumeLosesNothing) {
  const Experiment e = FakeExperiment();
  TempDir reference, dir;
  Sweep(e, reference.path(), 2);
  // 24 items x 25 ms on 3 threads take ~200 ms; the kills stop it well before that.
  const int kill_after_ms[] = {10, 30, 20, 35};
  for (int round = 0; round < 4; ++round) {
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      try {
        Sweep(e, dir.path(), 3, {}, nullptr, /*delay_ms=*/25);
      } catch (...) {
        _exit(3);
      }
      _exit(0);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(kill_after_ms[round]));
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
  }
  Journal journal(dir.path() + "/journal.jsonl");
  const size_t before = journal.Load(false).size();
  EXPECT_LT(before, 24u) << "the kills came too late to interrupt anything";
  std::atomic<int> calls{0};
  const SweepSummary resumed = Sweep(e, dir.path(), 2, {}, &calls);
  EXPECT_EQ(static_cast<size_t>(resumed.already_done), before);
  EXPECT_EQ(static_cast<size_t>(calls.load()), 24u - before);
  // No duplicate ids in the journal, every item present.
  const std::string text = ReadFileText(dir.path() + "/journal.jsonl");
  std::map<std::string, int> seen;
  size_t start = 0;
  while (start < text.size()) {
    const size_t end = text.find('\n', start);
    ASSERT_NE(end, std::string::npos) << "journal ends with a partial line";
    ++seen[nlohmann::json::parse(text.substr(start, end - start))["id"].get<std::string>()];
    start = end + 1;
  }
  EXPECT_EQ(seen.size(), 24u);
  for (const auto& [id, count] : seen) EXPECT_EQ(count, 1) << id;
  ExpectSameDeterministicFiles(reference.path(), dir.path());
}

TEST(HarnessSweep, ShardsMergeIntoTheUnshardedResult) {
  const Experiment e = FakeExperiment();
  TempDir whole, s0, s1, s2, merged;
  Sweep(e, whole.path(), 2);
  const SweepSummary part = Sweep(e, s0.path(), 1, Shard{0, 3});
  EXPECT_EQ(part.items_in_shard, 8);
  Sweep(e, s1.path(), 2, Shard{1, 3});
  // Missing shard: refused unless --allow-partial.
  MergeOptions options;
  options.out_dir = merged.path() + "/m";
  EXPECT_THROW(MergeSweeps({s0.path(), s1.path()}, options), Error);
  Sweep(e, s2.path(), 1, Shard{2, 3});
  EXPECT_EQ(MergeSweeps({s2.path(), s0.path(), s1.path()}, options), 24);
  ExpectSameDeterministicFiles(whole.path(), options.out_dir);
  // The merged folder is a complete sweep: rerunning it there does nothing.
  std::atomic<int> calls{0};
  Sweep(e, options.out_dir, 2, {}, &calls);
  EXPECT_EQ(calls.load(), 0);
  // A different experiment cannot be merged in.
  nlohmann::json other = FakeExperimentJson();
  other["seed"] = 8;
  const Experiment changed = ParseExperiment(other, "exp.json", FakeCatalog());
  TempDir foreign;
  Sweep(changed, foreign.path(), 2, Shard{0, 3});
  options.out_dir = merged.path() + "/n";
  EXPECT_THROW(MergeSweeps({s0.path(), foreign.path()}, options), Error);
}

TEST(HarnessSweep, RunnerExceptionStopsTheSweepAndKeepsFinishedItems) {
  const Experiment e = FakeExperiment();
  TempDir dir;
  SweepOptions options;
  options.out_dir = dir.path();
  options.threads = 1;
  FakeRunner fake{&e};
  const ItemRunner failing = [&](const ItemSpec& item) {
    if (item.index == 5) throw Error("disk on fire");
    return fake(item);
  };
  EXPECT_THROW(RunSweep(e, options, failing), Error);
  EXPECT_EQ(Journal(dir.path() + "/journal.jsonl").Load(false).size(), 5u);
  EXPECT_FALSE(fs::exists(dir.path() + "/summary.md"));
  const SweepSummary resumed = RunSweep(e, options, fake);
  EXPECT_EQ(resumed.ran, 19);
}

TEST(HarnessSweep, WorkersRunReadyScenesWhileOneIsPreparedAndCostliestItemsGoFirst) {
  // Scene b (12 items, the costlier) is slow to prepare; scene a is ready at once. With two
  // workers a's items run while b is prepared (b's preparation waits until two of them have
  // started: it would wait in vain if the workers blocked on b); once b is ready its items come
  // before a's remaining ones, although a's come first in item order. The files are those of a
  // plain sweep.
  const Experiment e = FakeExperiment();
  TempDir plain, scheduled;
  Sweep(e, plain.path(), 1);
  FakeRunner fake{&e};
  std::mutex mutex;
  std::condition_variable a_started;
  std::vector<int> started;  // scene of each item, in start order
  SweepHooks hooks;
  hooks.run = [&](const ItemTask& task) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      started.push_back(task.spec->scene_index);
    }
    a_started.notify_all();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return fake(*task.spec);
  };
  hooks.group = [](const ItemTask& task) { return task.spec->scene_index; };
  std::atomic<int> prepares{0};
  bool waited = false;
  hooks.prepare = [&](int scene) {
    ++prepares;
    if (scene != 1) return;
    std::unique_lock<std::mutex> lock(mutex);
    waited = a_started.wait_for(lock, std::chrono::seconds(20), [&] {
      return std::count(started.begin(), started.end(), 0) >= 2;
    });
  };
  hooks.cost = [](const ItemTask& task) { return task.spec->scene_index == 1 ? 2.0 : 1.0; };
  SweepOptions options;
  options.out_dir = scheduled.path();
  options.threads = 2;
  const SweepSummary summary = RunSweep(e, options, hooks);
  EXPECT_EQ(summary.ran, 24);
  EXPECT_EQ(prepares.load(), 2);
  EXPECT_TRUE(waited) << "scene a's items must run while scene b is prepared";
  ASSERT_EQ(started.size(), 24u);
  EXPECT_EQ(started.front(), 0);
  EXPECT_EQ(started.back(), 0) << "b's costlier items must not be left for the end";
  ExpectSameDeterministicFiles(plain.path(), scheduled.path());
}

TEST(HarnessSweep, PrepareExceptionStopsTheSweep) {
  const Experiment e = FakeExperiment();
  TempDir dir;
  FakeRunner fake{&e};
  SweepHooks hooks;
  hooks.run = [&](const ItemTask& task) { return fake(*task.spec); };
  hooks.group = [](const ItemTask& task) { return task.spec->scene_index; };
  hooks.prepare = [](int scene) {
    if (scene == 1) throw Error("scene b", "cannot build");
  };
  SweepOptions options;
  options.out_dir = dir.path();
  options.threads = 2;
  EXPECT_THROW(RunSweep(e, options, hooks), Error);
  EXPECT_FALSE(fs::exists(dir.path() + "/summary.md"));
}

TEST(HarnessSweep, RegressCatchesAPerturbedMethod) {
  const Experiment e = FakeExperiment();
  TempDir base, same, perturbed;
  Sweep(e, base.path(), 2);
  Sweep(e, same.path(), 1);
  SweepOptions options;
  options.out_dir = perturbed.path();
  options.threads = 2;
  RunSweep(e, options, FakeRunner{&e, /*perturb=*/0.05});

  RegressOptions regress;
  for (const HarnessMetricInfo& m : e.metrics)
    regress.higher_is_better[m.name] = m.higher_is_better;
  const RegressReport ok = Regress(base.path() + "/items.csv", same.path() + "/items.csv", regress);
  EXPECT_FALSE(ok.failed()) << ok.Format();
  EXPECT_EQ(ok.compared, 24 * 5 * 3);

  const RegressReport bad =
      Regress(base.path() + "/items.csv", perturbed.path() + "/items.csv", regress);
  EXPECT_TRUE(bad.failed());
  EXPECT_EQ(bad.moves.size(), 24u);  // "up" of fake_a on every item, nothing else
  for (const RegressMove& move : bad.moves) {
    EXPECT_TRUE(move.regression);
    EXPECT_EQ(move.metric, "up");
    EXPECT_NE(move.key.find(" fake_a"), std::string::npos);
    EXPECT_EQ(move.key.find("fake_a2"), std::string::npos);
  }
  EXPECT_NE(bad.Format().find("REGRESSED"), std::string::npos);
  EXPECT_NE(bad.Format().find("regress: FAIL"), std::string::npos);
  // Summary tables are compared the same way (mean per level x method x metric).
  const RegressReport summary =
      Regress(base.path() + "/summary.csv", perturbed.path() + "/summary.csv", regress);
  EXPECT_TRUE(summary.failed());
  EXPECT_EQ(summary.moves.size(), 5u);  // 4 levels + all
  // A loose enough tolerance accepts the move; an improvement is reported but passes.
  regress.tolerances["up"] = {0.06, 0.0};
  EXPECT_FALSE(
      Regress(base.path() + "/items.csv", perturbed.path() + "/items.csv", regress).failed());
  regress.tolerances.clear();
  const RegressReport better =
      Regress(perturbed.path() + "/items.csv", base.path() + "/items.csv", regress);
  EXPECT_FALSE(better.failed()) << better.Format();
  EXPECT_EQ(better.moves.size(), 24u);
  // Mixed table kinds are refused; a missing row fails.
  EXPECT_THROW(Regress(base.path() + "/items.csv", same.path() + "/summary.csv", regress), Error);
  std::string csv = ReadFileText(same.path() + "/items.csv");
  csv.erase(csv.rfind('\n', csv.size() - 2) + 1);
  std::ofstream(same.path() + "/items.csv", std::ios::binary) << csv;
  const RegressReport missing =
      Regress(base.path() + "/items.csv", same.path() + "/items.csv", regress);
  EXPECT_TRUE(missing.failed());
  EXPECT_EQ(missing.missing.size(), 3u);
}

TEST(HarnessSweep, ToleranceFile) {
  TempDir dir;
  std::ofstream(dir.File("tol.json"))
      << R"({"default": {"abs": 0.5, "rel": 0}, "metrics": {"psnr": {"abs": 0.01}}})";
  RegressOptions options;
  LoadTolerances(dir.File("tol.json"), &options);
  EXPECT_EQ(options.default_tolerance.abs, 0.5);
  EXPECT_EQ(options.tolerances["psnr"].abs, 0.01);
  EXPECT_EQ(options.tolerances["psnr"].rel, 0.0);
  std::ofstream(dir.File("bad.json")) << R"({"metrics": {"psnr": {"abs": -1}}})";
  EXPECT_THROW(LoadTolerances(dir.File("bad.json"), &options), Error);
}

TEST(HarnessSweep, ProgressLine) {
  EXPECT_EQ(ProgressLine(0, 10, 0.0, 10), "[          ] 0/10   0%  elapsed 0:00  ETA --:--");
  EXPECT_EQ(ProgressLine(5, 10, 30.0, 10), "[#####     ] 5/10  50%  elapsed 0:30  ETA 0:30");
  EXPECT_EQ(ProgressLine(10, 10, 4000.0, 4), "[####] 10/10 100%  elapsed 1:06:40  ETA 0:00");
}

}  // namespace
}  // namespace turbid
