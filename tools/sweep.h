// The sweep engine: runs every item of an experiment (or one shard of them) on a pool of threads,
// appends each finished item to DIR/journal.jsonl in one write, resumes from that journal after
// any interruption (kill -9 included), and writes the tables when the shard is complete.
// `MergeSweeps` combines shard folders into the unsharded result, byte for byte.
//
// The per-item work is injected (ItemRunner), so the engine is tested with fake runners; the real
// one (render, enhance, score) is tools/harness_runner.h.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "tools/experiment.h"
#include "tools/tables.h"

namespace turbid {

// Runs one item; called concurrently from several threads, so it must be thread-safe. Returns
// the item's result (failures of single methods are recorded in the result, not thrown); a
// thrown exception stops the sweep (what is already journaled is kept).
using ItemRunner = std::function<ItemResult(const ItemSpec& item)>;

struct SweepOptions {
  std::string out_dir;    // created if missing; holds experiment.json, journal and tables
  int threads = 0;        // worker threads; 0 = std::thread::hardware_concurrency()
  Shard shard;            // which slice of the items to run (default: all)
  bool progress = false;  // draw a progress bar with ETA on stderr
  bool force = false;     // start over when out_dir holds a different experiment
  bool Check(std::string* why) const;
};

struct SweepSummary {
  int items_total = 0;     // items in the whole experiment
  int items_in_shard = 0;  // items this run is responsible for
  int already_done = 0;    // found in the journal at start
  int ran = 0;             // run now
  int failed_rows = 0;     // method rows with an error (recorded, not fatal)
  bool tables_written = false;
};

SweepSummary RunSweep(const Experiment& experiment, const SweepOptions& options,
                      const ItemRunner& runner);

// The results journal: one JSON object per line, each appended with a single write() on an
// O_APPEND descriptor, so a kill leaves at most one partial last line, which Load() drops.
class Journal {
 public:
  explicit Journal(std::string path) : path_(std::move(path)) {}
  // Reads every complete entry (by item id; the first of duplicates wins) and truncates a
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
