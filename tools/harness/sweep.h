// The sweep engine: runs every item of an experiment (or one shard of them) on a pool of threads,
// appends each finished item to DIR/journal.jsonl in one write, resumes from that journal after
// any interruption (kill -9 included), and writes the tables when the shard is complete.
// `MergeSweeps` combines shard folders into the unsharded result, byte for byte.
//
// The per-item work is injected (ItemRunner), so the engine is tested with fake runners; the real
// one (render, enhance, score) is tools/harness/harness_runner.h.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "tools/harness/experiment.h"
#include "tools/harness/stage_profile.h"
#include "tools/harness/tables.h"

namespace turbid {

// Runs one item; called concurrently from several threads, so it must be thread-safe. Returns
// the item's result (failures of single methods are recorded in the result, not thrown); a
// thrown exception stops the sweep (what is already journaled is kept).
using ItemRunner = std::function<ItemResult(const ItemSpec& item)>;

// One unit of work for the extended form of RunSweep: an item, and, when failed cells are retried,
// the labels of the methods to run again (empty: every method).
struct ItemTask {
  const ItemSpec* spec = nullptr;
  std::vector<std::string> only;
};

struct SweepHooks {
  // Runs one item (thread-safe). Rows of methods outside task.only are ignored: the journaled
  // rows of those methods are kept.
  std::function<ItemResult(const ItemTask& task)> run;
  // Set: the pending items run in batches of batch_items; when a batch's items have run, finish
  // completes their results (one call on one thread, e.g. an external program started once for
  // the batch), then they are journaled. Unset: each item is journaled as soon as it has run.
  std::function<void(const std::vector<ItemTask>& tasks, std::vector<ItemResult>* results)>
      finish;
  int batch_items = 0;  // items per batch when finish is set (0: every pending item at once)
  // Optional scheduling (tools/harness/item_scheduler.h); results do not depend on it. group: the
  // shared state a task needs (a scene), prepared once by prepare(group) on one worker while the
  // others run tasks whose group is ready (prepare must not throw: the runner reports a failed
  // preparation when the group's tasks run); cost: a task's relative cost, asked before its group
  // is prepared (an estimate, 0 = unknown) and again after; the costliest task runs first, so
  // the largest images do not end the sweep on one thread while the others idle. Unset: item order.
  std::function<int(const ItemTask& task)> group;
  std::function<void(int group)> prepare;
  std::function<double(const ItemTask& task)> cost;
};

struct SweepOptions {
  std::string out_dir;    // created if missing; holds experiment.json, journal and tables
  int threads = 0;        // worker threads; 0 = std::thread::hardware_concurrency()
  Shard shard;            // which slice of the items to run (default: all)
  bool progress = false;  // draw a progress bar with ETA on stderr
  bool force = false;     // start over when out_dir holds a different experiment
  // Run again the method cells that failed (error set) in journaled items; the other cells are
  // kept. Without it a journaled item is never rerun.
  bool retry_failed = false;
  // Journal appends and the tables are timed into it (`turbid bench --sweep`); null = off.
  StageProfile* profile = nullptr;
  bool Check(std::string* why) const;
};

struct SweepSummary {
  int items_total = 0;     // items in the whole experiment
  int items_in_shard = 0;  // items this run is responsible for
  int already_done = 0;    // found in the journal at start
  int ran = 0;             // run now (retried items included)
  int retried = 0;         // journaled items whose failed cells were run again
  int failed_rows = 0;     // method rows with an error among the items run now (not fatal)
  bool tables_written = false;
  // One line per journal entry found incomplete (method rows or metrics missing, another item's
  // fields): the entry was not taken as done and its item was run again.
  std::vector<std::string> notes;
};

SweepSummary RunSweep(const Experiment& experiment, const SweepOptions& options,
                      const ItemRunner& runner);
SweepSummary RunSweep(const Experiment& experiment, const SweepOptions& options,
                      const SweepHooks& hooks);

// The results journal: one JSON object per line, each appended with a single write() on an
// O_APPEND descriptor, so a kill leaves at most one partial last line, which Load() drops.
class Journal {
 public:
  explicit Journal(std::string path) : path_(std::move(path)) {}
  // Reads every complete entry (by item id; the last of duplicates wins, so an item whose failed
  // cells were retried is read as its latest entry) and truncates a
  // partial trailing line. Throws Error for a corrupt line that is not the last one.
  std::map<std::string, nlohmann::json> Load(bool repair);
  void Append(const nlohmann::json& entry);  // thread-safe across processes' appends
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Loads DIR/experiment.json and every journaled item (sorted by index).
struct SweepDir {
  Experiment experiment;
  nlohmann::json experiment_json;
  std::vector<ItemResult> items;
};
SweepDir LoadSweepDir(const std::string& dir);

struct MergeOptions {
  std::string out_dir;
  bool allow_partial = false;  // write tables even when items are missing
  bool force = false;          // replace an out_dir that holds a different experiment
};
// Returns the number of items merged. Throws Error when the inputs are different experiments,
// disagree on an item, or (without allow_partial) do not cover every item.
int MergeSweeps(const std::vector<std::string>& dirs, const MergeOptions& options);

// Progress text "[#####     ] 12/40  30%  ETA 0:45" (exposed for tests).
std::string ProgressLine(int done, int total, double elapsed_s, int width);
// True when stderr is a terminal and $CI is not "true"/"1".
bool ShouldShowProgress();

}  // namespace turbid
