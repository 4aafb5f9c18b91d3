#include "tools/harness/sweep.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <iostream>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>
#include <utility>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/input_file.h"
#include "core/json_io.h"
#include "core/safe_name.h"
#include "tools/harness/item_scheduler.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string ReadAll(const std::string& path) { return ReadInputFile(path); }

std::string ExperimentText(const Experiment& experiment) {
  return experiment.ToJson().dump(2) + "\n";
}

// What a sweep or merge owns in its folder: it holds the folder's lock, so temporaries of killed
// earlier runs can be removed (RemoveStaleTemporaries) and the work folders that external methods
// got in a killed run are scratch. `turbid report` writes report.html and report/ without the lock:
// left alone.
// Only the folder itself and the subfolders the sweep writes are visited (an --out that happens to
// be some other folder keeps everything below it). Clean-up never follows a symbolic link: a link
// planted where the sweep keeps its own folders (thumbs/, thumbs/<id>/, external/,
// external/<label>/) would aim the clean-up, and the writes after it, at another folder, so the
// sweep refuses it with one line; links found deeper are never followed.
void RemoveLeftovers(const std::string& dir) {
  for (const char* name : {"thumbs", "external", "journal.jsonl"}) {
    RefuseSymlink(dir + "/" + name, "cleans and writes");
  }
  std::error_code ec;
  const auto is_real_folder = [](const std::string& path) {
    std::error_code type_ec;
    return fs::symlink_status(path, type_ec).type() == fs::file_type::directory;
  };
  for (const char* sub : {"/thumbs", "/external"}) {
    if (!is_real_folder(dir + sub)) continue;
    for (const fs::directory_entry& entry : fs::directory_iterator(dir + sub, ec)) {
      RefuseSymlink(entry.path().string(), "cleans and writes");
    }
  }
  RemoveStaleTemporaries(dir, /*recursive=*/false, {"report.html"});
  RemoveStaleTemporaries(dir + "/thumbs", /*recursive=*/true);
  RemoveStaleTemporaries(dir + "/external", /*recursive=*/true);
  if (!is_real_folder(dir + "/external")) return;
  for (const fs::directory_entry& method : fs::directory_iterator(dir + "/external", ec)) {
    if (method.symlink_status(ec).type() != fs::file_type::directory) continue;
    std::vector<fs::path> work;
    for (const fs::directory_entry& entry : fs::directory_iterator(method.path(), ec)) {
      if (entry.symlink_status(ec).type() == fs::file_type::directory &&
          entry.path().filename().string().rfind("work-", 0) == 0)
        work.push_back(entry.path());
    }
    // remove_all does not follow the links inside a work folder (it removes the links).
    for (const fs::path& folder : work) fs::remove_all(folder, ec);
  }
}

// Writes DIR/experiment.json, or checks that the one there is the same experiment.
void ClaimDir(const Experiment& experiment, const std::string& dir, bool force) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw OutputError(dir, "cannot create the output folder: " + ec.message());
  const std::string path = dir + "/experiment.json";
  const std::string text = ExperimentText(experiment);
  if (fs::exists(path)) {
    if (ReadAll(path) == text) return;
    if (!force) {
      throw Error(dir,
                  "holds the results of a different experiment (or of an older version of "
                  "this one); use another --out or --force to start over");
    }
    for (const char* name : {"journal.jsonl", "items.csv", "items.jsonl", "summary.md",
                             "summary.csv", "timings.csv", "timings.md", "report.html"}) {
      fs::remove(dir + "/" + name, ec);
    }
    fs::remove_all(dir + "/thumbs", ec);
    fs::remove_all(dir + "/external", ec);
    fs::remove_all(dir + "/report", ec);
  }
  AtomicWriteText(path, text, true);
}

std::vector<ItemResult> SortedResults(const std::map<std::string, json>& entries) {
  std::vector<ItemResult> items;
  items.reserve(entries.size());
  for (const auto& [id, entry] : entries) items.push_back(ItemResultFromJson(entry));
  std::sort(items.begin(), items.end(),
            [](const ItemResult& a, const ItemResult& b) { return a.index < b.index; });
  return items;
}

// Checks that journaled entries belong to this experiment (same id at the same index).
void CheckEntries(const std::map<std::string, json>& entries, const std::vector<ItemSpec>& specs,
                  const std::string& where) {
  std::map<std::string, int> index_of;
  for (const ItemSpec& spec : specs) index_of[spec.id] = spec.index;
  for (const auto& [id, entry] : entries) {
    const auto it = index_of.find(id);
    const auto index = entry.is_object() && entry.contains("index")
                           ? JsonInteger(entry["index"], 0, std::numeric_limits<int>::max())
                           : std::nullopt;
    if (it == index_of.end() || index != std::optional<int64_t>(it->second)) {
      throw Error(where, "journal entry '" + id + "' is not an item of this experiment");
    }
  }
}

// Why a journaled entry cannot stand for its item ("" when it can). A complete entry is a
// well-formed result of this very item (index, scene, condition, level, seed) holding exactly one
// row per method of the experiment, in the experiment's order, each with a value (NaN when the cell
// failed) for exactly the experiment's metrics, and the ground truth's no-reference scores (none
// when the render failed). A journal only ever receives complete entries; anything else was cut,
// edited or written by another tool, and its item must not be taken as done.
std::string EntryProblem(const json& entry, const ItemSpec& spec, const Experiment& experiment) {
  ItemResult item;
  try {
    item = ItemResultFromJson(entry);
  } catch (const Error& error) {
    return error.what();
  }
  if (item.index != spec.index) return "index " + std::to_string(item.index) + " is not the item's";
  if (item.scene != experiment.scenes.at(static_cast<size_t>(spec.scene_index)).name)
    return "scene '" + item.scene + "' is not the item's";
  if (item.condition != spec.condition || item.level != spec.level)
    return "condition " + std::to_string(item.condition) + " is not the item's";
  if (item.seed != spec.seed) return "seed " + std::to_string(item.seed) + " is not the item's";
  if (item.methods.size() != experiment.methods.size()) {
    return "it holds " + std::to_string(item.methods.size()) + " method rows, the experiment " +
           std::to_string(experiment.methods.size());
  }
  std::set<std::string> metrics, reference_only;
  for (const HarnessMetricInfo& metric : experiment.metrics) {
    metrics.insert(metric.name);
    if (!metric.needs_reference && !metric.needs_original) reference_only.insert(metric.name);
  }
  const auto names = [](const std::map<std::string, double>& values) {
    std::set<std::string> out;
    for (const auto& [name, value] : values) out.insert(name);
    return out;
  };
  for (size_t m = 0; m < item.methods.size(); ++m) {
    const MethodResult& row = item.methods[m];
    const std::string& label = experiment.methods[m].label;
    if (row.label != label)
      return "method row " + std::to_string(m + 1) + " is '" + row.label + "', not '" + label + "'";
    if (names(row.metrics) != metrics) return "the row of method '" + label + "' lacks metrics";
  }
  const std::set<std::string> reference = names(item.reference_metrics);
  if (item.error.empty() ? reference != reference_only
                         : !std::includes(reference_only.begin(), reference_only.end(),
                                          reference.begin(), reference.end()))
    return "its reference_metrics are not the experiment's no-reference metrics";
  return "";
}

// The id and problem of the first incomplete entry of `entries` (in item order), or {"", ""}.
std::pair<std::string, std::string> FirstIncompleteEntry(const std::map<std::string, json>& entries,
                                                         const std::vector<ItemSpec>& specs,
                                                         const Experiment& experiment) {
  for (const ItemSpec& spec : specs) {
    const auto it = entries.find(spec.id);
    if (it == entries.end()) continue;
    const std::string problem = EntryProblem(it->second, spec, experiment);
    if (!problem.empty()) return {spec.id, problem};
  }
  return {"", ""};
}

// Refuses (Error naming `journal` and the item) a set of entries with an incomplete one.
void RefuseIncompleteEntries(const std::map<std::string, json>& entries,
                             const std::vector<ItemSpec>& specs, const Experiment& experiment,
                             const std::string& journal, const std::string& advice) {
  const auto [id, problem] = FirstIncompleteEntry(entries, specs, experiment);
  if (!id.empty())
    throw Error(journal,
                "the entry of item '" + id + "' is incomplete (" + problem + "); " + advice);
}

std::string FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long total = static_cast<long>(seconds + 0.5);
  char buffer[32];
  if (total >= 3600) {
    std::snprintf(buffer, sizeof buffer, "%ld:%02ld:%02ld", total / 3600, (total / 60) % 60,
                  total % 60);
  } else {
    std::snprintf(buffer, sizeof buffer, "%ld:%02ld", total / 60, total % 60);
  }
  return buffer;
}

// Copies the thumbnails of a shard folder into the merged one, each file atomically (a kill leaves
// a temporary, never a partial PNG under its name). Files already there are kept: the shards'
// thumbnails of one item are the same bytes.
void CopyThumbnails(const std::string& from, const std::string& to) {
  std::error_code ec;
  fs::recursive_directory_iterator it(from, ec);
  for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    const fs::path relative = it->path().lexically_relative(from);
    const fs::path target = fs::path(to) / relative;
    // Links are never followed: a link in a shard's thumbs/ would copy (and `report` would then
    // publish) a file from outside the shard.
    const fs::file_type type = it->symlink_status(ec).type();
    if (type == fs::file_type::directory) {
      fs::create_directories(target, ec);
      if (ec)
        throw OutputError(target.string(), "cannot create the thumbnail folder: " + ec.message());
      continue;
    }
    if (type != fs::file_type::regular || IsTemporaryName(relative.filename().string())) continue;
    if (fs::exists(target, ec)) continue;
    AtomicWriteText(target.string(), ReadAll(it->path().string()), true);
  }
  if (ec) throw Error(from, "cannot list the thumbnails: " + ec.message());
}

}  // namespace

bool SweepOptions::Check(std::string* why) const {
  if (out_dir.empty()) {
    *why = "--out is required";
    return false;
  }
  if (threads < 0 || threads > 1024) {
    *why = "--threads must be in [0, 1024] (0 = all cores)";
    return false;
  }
  if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count) {
    *why = "--shard must be i/N with 0 <= i < N";
    return false;
  }
  return true;
}

std::map<std::string, json> Journal::Load(bool repair) {
  std::map<std::string, json> entries;
  std::error_code ec;
  if (!fs::exists(path_, ec)) return entries;
  CheckInputFile(path_);  // a FIFO or device planted as the journal would block or never end
  std::ifstream in(path_, std::ios::binary);
  if (!in) return entries;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  size_t start = 0;
  size_t good_end = 0;
  int line_number = 0;
  while (start < text.size()) {
    const size_t newline = text.find('\n', start);
    ++line_number;
    if (newline == std::string::npos) break;  // partial last line: the writer was killed
    const std::string line = text.substr(start, newline - start);
    if (!line.empty()) {
      json entry;
      try {
        entry = ParseJson(line, path_);
      } catch (const JsonError& e) {  // syntax, depth, duplicate key, 1e999
        throw Error(path_, "line " + std::to_string(line_number) + " is corrupt (" + e.problem() +
                               "; not a partial last line); move the file away to start over");
      }
      const json* id = entry.is_object() && entry.contains("id") ? &entry["id"] : nullptr;
      if (!id || !id->is_string() || id->get<std::string>().empty())
        throw Error(path_, "line " + std::to_string(line_number) + " has no id");
      entries[id->get<std::string>()] = std::move(entry);
    }
    start = newline + 1;
    good_end = start;
  }
  if (repair && good_end < text.size()) {
    if (::truncate(path_.c_str(), static_cast<off_t>(good_end)) != 0) {
      throw OutputError(path_,
                        std::string("cannot drop the partial last line: ") + std::strerror(errno));
    }
  }
  return entries;
}

void Journal::Append(const json& entry) {
  static std::mutex mutex;
  const std::string line = entry.dump() + "\n";
  std::lock_guard<std::mutex> lock(mutex);
  const int fd = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0)
    throw OutputError(path_, std::string("cannot open the journal: ") + std::strerror(errno));
  // The journal's length before this line: a failed append (full disk, file-size limit) cuts the
  // file back to it, so the partial line cannot end up in the middle of the journal when another
  // thread appends after it.
  struct stat before {};
  if (::fstat(fd, &before) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw OutputError(path_, "cannot append to the journal: " + why);
  }
  // One write() for the whole line: a kill leaves either the full line or a partial last line
  // (never interleaved lines); a short write on a full disk is completed by further writes.
  size_t written = 0;
  while (written < line.size()) {
    const ssize_t n = ::write(fd, line.data() + written, line.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = std::strerror(n < 0 ? errno : ENOSPC);
      if (written > 0 && ::ftruncate(fd, before.st_size) != 0) {
        // Left as a partial last line, which the next run drops (Load(repair)).
      }
      ::close(fd);
      throw OutputError(path_, "cannot append to the journal: " + why);
    }
    written += static_cast<size_t>(n);
  }
  // A line the kernel could not store after all (an I/O error on write-back) is cut off again, so
  // the item is not taken as done; fsync and close are both checked.
  if (FsyncOutputs() && ::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) {
    const std::string why = std::strerror(errno);
    if (::ftruncate(fd, before.st_size) != 0) {
      // Left for Load to judge (a partial or incomplete line is dropped on resume).
    }
    ::close(fd);
    throw OutputError(path_, "cannot append to the journal: " + why + " (on fsync)");
  }
  if (::close(fd) != 0)
    throw OutputError(path_, std::string("cannot append to the journal: ") + std::strerror(errno) +
                                 " (on close)");
}

std::string ProgressLine(int done, int total, double elapsed_s, int width) {
  const double fraction = total > 0 ? static_cast<double>(done) / total : 1.0;
  const int filled = static_cast<int>(fraction * width + 1e-9);
  std::string bar(static_cast<size_t>(filled), '#');
  bar.resize(static_cast<size_t>(width), ' ');
  const double eta = done > 0 ? elapsed_s / done * (total - done) : -1.0;
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, "[%s] %d/%d %3.0f%%  elapsed %s  ETA %s", bar.c_str(), done,
                total, fraction * 100.0, FormatDuration(elapsed_s).c_str(),
                done > 0 ? FormatDuration(eta).c_str() : "--:--");
  return buffer;
}

bool ShouldShowProgress() {
  const char* ci = std::getenv("CI");
  if (ci != nullptr && (std::string(ci) == "true" || std::string(ci) == "1")) return false;
  return ::isatty(STDERR_FILENO) == 1;
}

SweepSummary RunSweep(const Experiment& experiment, const SweepOptions& options,
                      const ItemRunner& runner) {
  SweepHooks hooks;
  hooks.run = [&runner](const ItemTask& task) { return runner(*task.spec); };
  return RunSweep(experiment, options, hooks);
}

namespace {

// Labels of the failed method rows of a journaled item; all labels when the item itself failed.
std::vector<std::string> FailedLabels(const ItemResult& item, bool* whole_item) {
  std::vector<std::string> labels;
  *whole_item = !item.error.empty();
  for (const MethodResult& row : item.methods) {
    if (!row.error.empty()) labels.push_back(row.label);
  }
  return labels;
}

// A retried item: the journaled rows, with the rows of the retried methods replaced.
ItemResult MergeRetry(ItemResult previous, const ItemResult& fresh,
                      const std::vector<std::string>& only) {
  for (MethodResult& row : previous.methods) {
    if (std::find(only.begin(), only.end(), row.label) == only.end()) continue;
    for (const MethodResult& update : fresh.methods) {
      if (update.label == row.label) row = update;
    }
  }
  previous.error = fresh.error;
  previous.render_ms = fresh.render_ms;
  return previous;
}

// Incomplete entries (e.g. method rows missing) do not count as done: their items run again,
// and the new entry, appended after them, is the one read from then on. One note each.
void DropIncompleteEntries(const Experiment& experiment, const std::vector<ItemSpec>& specs,
                           const SweepOptions& options, const std::string& journal_path,
                           std::map<std::string, json>* done, SweepSummary* summary) {
  for (const ItemSpec& spec : specs) {
    const auto it = done->find(spec.id);
    if (it == done->end()) continue;
    const std::string problem = EntryProblem(it->second, spec, experiment);
    if (problem.empty()) continue;
    done->erase(it);
    summary->notes.push_back(journal_path + ": the entry of item '" + spec.id +
                             "' is incomplete (" + problem + ")" +
                             (options.shard.Contains(spec.index)
                                  ? "; the item is run again"
                                  : "; left out of the tables (the item is in another shard)"));
  }
}

// The items of this shard still to run (with, when failed cells are retried, the methods to
// rerun) and the journaled results of the retried ones.
struct PendingItems {
  std::vector<ItemTask> tasks;
  std::map<std::string, ItemResult> previous;  // journaled results of retried items
};

PendingItems PlanPending(const std::vector<ItemSpec>& specs,
                         const std::map<std::string, json>& done, const SweepOptions& options,
                         SweepSummary* summary) {
  PendingItems plan;
  for (const ItemSpec& spec : specs) {
    if (!options.shard.Contains(spec.index)) continue;
    ++summary->items_in_shard;
    const auto entry = done.find(spec.id);
    if (entry == done.end()) {
      plan.tasks.push_back({&spec, {}});
      continue;
    }
    if (options.retry_failed) {
      ItemResult item = ItemResultFromJson(entry->second);
      bool whole_item = false;
      std::vector<std::string> labels = FailedLabels(item, &whole_item);
      if (whole_item || !labels.empty()) {
        if (whole_item) labels.clear();  // rerun everything
        plan.tasks.push_back({&spec, labels});
        plan.previous.emplace(spec.id, std::move(item));
        ++summary->retried;
        continue;
      }
    }
    ++summary->already_done;
  }
  return plan;
}

// One run of the pending items on the thread pool: results are journaled as they come (or per
// batch when the hooks finish batches); the first error stops the run.
struct SweepExecution {
  SweepExecution(const Experiment& experiment, const SweepOptions& options,
                 const SweepHooks& hooks, Journal& journal, const std::vector<ItemTask>& pending,
                 const std::map<std::string, ItemResult>& previous)
      : experiment(experiment),
        options(options),
        hooks(hooks),
        journal(journal),
        pending(pending),
        previous(previous) {}

  const Experiment& experiment;
  const SweepOptions& options;
  const SweepHooks& hooks;
  Journal& journal;
  const std::vector<ItemTask>& pending;
  const std::map<std::string, ItemResult>& previous;
  std::atomic<int> finished{0};
  std::atomic<int> failed_rows{0};
  std::atomic<bool> stop{false};
  std::mutex error_mutex;
  std::exception_ptr first_error;
  std::mutex wake_mutex;
  std::condition_variable wake;

  void RecordError() {
    std::lock_guard<std::mutex> lock(error_mutex);
    if (!first_error) first_error = std::current_exception();
    stop = true;
  }

  // Completes a result (identity fields from the spec, journaled rows kept when retrying) and
  // appends it to the journal.
  void JournalResult(const ItemTask& task, ItemResult result) {
    const ItemSpec& spec = *task.spec;
    result.index = spec.index;
    result.id = spec.id;
    result.scene = experiment.scenes[spec.scene_index].name;
    result.condition = spec.condition;
    result.level = spec.level;
    result.level_value = spec.level_value;
    result.params = spec.params;
    result.seed = spec.seed;
    const auto old = previous.find(spec.id);
    if (old != previous.end() && !task.only.empty()) {
      result = MergeRetry(old->second, result, task.only);
    }
    int failures = 0;
    for (const MethodResult& m : result.methods) failures += !m.error.empty();
    {
      const ScopedStage timed(options.profile, "I/O: journal");
      journal.Append(ItemResultToJson(result, true));
    }
    failed_rows += failures;
    ++finished;
  }

  // Runs tasks [begin, end) on the thread pool; results are journaled at once, or stored in
  // `out` (indexed from begin) when the batch is finished afterwards.
  void RunRange(size_t begin, size_t end, std::vector<ItemResult>* out) {
    int threads = options.threads > 0 ? options.threads
                                      : static_cast<int>(std::thread::hardware_concurrency());
    threads = std::max(1, std::min<int>(threads, static_cast<int>(end - begin)));
    ItemScheduler scheduler(
        end - begin,
        hooks.group ? std::function<int(size_t)>(
                          [&](size_t k) { return hooks.group(pending[begin + k]); })
                    : std::function<int(size_t)>(),
        hooks.cost ? std::function<double(size_t)>(
                         [&](size_t k) { return hooks.cost(pending[begin + k]); })
                   : std::function<double(size_t)>(),
        static_cast<bool>(hooks.group) && static_cast<bool>(hooks.prepare));
    const auto work = [&]() {
      while (!stop.load()) {
        const ItemScheduler::Work next = scheduler.Next();
        if (next.kind == ItemScheduler::Work::Kind::kDone) break;
        if (next.kind == ItemScheduler::Work::Kind::kPrepare) {
          try {
            hooks.prepare(next.group);
          } catch (...) {
            RecordError();
            scheduler.Stop();
          }
          scheduler.Prepared(next.group);
          continue;
        }
        const size_t k = begin + next.task;
        try {
          ItemResult result = hooks.run(pending[k]);
          if (out != nullptr) {
            (*out)[k - begin] = std::move(result);
          } else {
            JournalResult(pending[k], std::move(result));
          }
        } catch (...) {
          RecordError();
          scheduler.Stop();
        }
        wake.notify_all();
      }
      wake.notify_all();
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(work);
    for (std::thread& thread : pool) thread.join();
  }

  void Drive() {
    if (!hooks.finish) {
      RunRange(0, pending.size(), nullptr);
    } else {
      const size_t batch = hooks.batch_items > 0 ? static_cast<size_t>(hooks.batch_items)
                                                 : std::max<size_t>(1, pending.size());
      for (size_t begin = 0; begin < pending.size() && !stop.load(); begin += batch) {
        const size_t end = std::min(pending.size(), begin + batch);
        std::vector<ItemResult> results(end - begin);
        RunRange(begin, end, &results);
        if (stop.load()) break;
        try {
          const std::vector<ItemTask> tasks(pending.begin() + static_cast<long>(begin),
                                            pending.begin() + static_cast<long>(end));
          hooks.finish(tasks, &results);
          for (size_t k = begin; k < end; ++k) JournalResult(pending[k], results[k - begin]);
        } catch (...) {
          RecordError();
        }
      }
    }
    stop = true;  // wakes the progress loop
    wake.notify_all();
  }

  // Drives the run on its own thread while this one shows progress on stderr (when asked).
  void Run() {
    const auto start = std::chrono::steady_clock::now();
    const int total = static_cast<int>(pending.size());
    std::thread driver([this] { Drive(); });
    if (options.progress && total > 0) {
      std::unique_lock<std::mutex> lock(wake_mutex);
      while (finished.load() < total && !stop.load()) {
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::cerr << "\r" << ProgressLine(finished.load(), total, elapsed, 30) << std::flush;
        wake.wait_for(lock, std::chrono::milliseconds(250));
      }
    }
    driver.join();
    if (options.progress && total > 0) {
      const double elapsed =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::cerr << "\r" << ProgressLine(finished.load(), total, elapsed, 30) << "\n";
    }
  }
};

// Rethrows the first error of a run.
void RethrowFirstError(const std::exception_ptr& first_error, const SweepSummary& summary) {
  if (!first_error) return;
  try {
    std::rethrow_exception(first_error);
  } catch (const OutputError& error) {
    // Not a failure of the experiment: the item being written is not journaled, so a plain
    // rerun (after freeing space) runs it and completes the same results.
    throw OutputError(std::string(error.what()) + "; the sweep stopped (" +
                      std::to_string(summary.ran) +
                      " items journaled now are kept: run it again to continue)");
  }
}

// Tables from everything journaled in this folder (the shard, or the whole sweep).
void WriteSweepTables(const Experiment& experiment, const std::vector<ItemSpec>& specs,
                      const SweepOptions& options, Journal& journal) {
  const ScopedStage timed(options.profile, "tables");
  std::map<std::string, json> done = journal.Load(/*repair=*/false);
  for (const ItemSpec& spec : specs) {  // only out-of-shard entries can be incomplete now
    const auto it = done.find(spec.id);
    if (it != done.end() && !EntryProblem(it->second, spec, experiment).empty()) done.erase(it);
  }
  // The mark of complete tables goes first, so that tables left half-written by a failed write
  // (or a kill) are written again by the next run rather than taken as finished.
  std::error_code ec;
  fs::remove(options.out_dir + "/summary.md", ec);
  if (ec) throw OutputError(options.out_dir + "/summary.md", "cannot remove: " + ec.message());
  WriteTables(experiment, SortedResults(done), options.out_dir);
}

}  // namespace

SweepSummary RunSweep(const Experiment& experiment, const SweepOptions& options,
                      const SweepHooks& hooks) {
  ThrowIfInvalid(options, "sweep");
  if (!hooks.run) throw Error("sweep: no item runner");
  const FolderLock lock(options.out_dir, "sweep or merge");
  RemoveLeftovers(options.out_dir);
  ClaimDir(experiment, options.out_dir, options.force);
  Journal journal(options.out_dir + "/journal.jsonl");
  const std::vector<ItemSpec> specs = ExpandItems(experiment);
  std::map<std::string, json> done = journal.Load(/*repair=*/true);
  CheckEntries(done, specs, journal.path());

  SweepSummary summary;
  DropIncompleteEntries(experiment, specs, options, journal.path(), &done, &summary);
  summary.items_total = static_cast<int>(specs.size());
  const PendingItems plan = PlanPending(specs, done, options, &summary);
  const bool tables_exist = fs::exists(options.out_dir + "/summary.md");
  if (plan.tasks.empty() && tables_exist) return summary;  // a finished sweep: nothing to do

  SweepExecution run(experiment, options, hooks, journal, plan.tasks, plan.previous);
  run.Run();
  summary.ran = run.finished.load();
  summary.failed_rows = run.failed_rows.load();
  RethrowFirstError(run.first_error, summary);
  WriteSweepTables(experiment, specs, options, journal);
  summary.tables_written = true;
  return summary;
}

SweepDir LoadSweepDir(const std::string& dir) {
  const std::string path = dir + "/experiment.json";
  if (!fs::exists(path)) throw Error(dir, "not a sweep folder (no experiment.json)");
  SweepDir out;
  out.experiment_json = ReadJsonFile(path);
  out.experiment = ExperimentFromResolvedJson(out.experiment_json, path);
  Journal journal(dir + "/journal.jsonl");
  const std::map<std::string, json> entries = journal.Load(/*repair=*/false);
  const std::vector<ItemSpec> specs = ExpandItems(out.experiment);
  CheckEntries(entries, specs, journal.path());
  RefuseIncompleteEntries(entries, specs, out.experiment, journal.path(),
                          "run the sweep into this folder again to rerun the item");
  out.items = SortedResults(entries);
  return out;
}

int MergeSweeps(const std::vector<std::string>& dirs, const MergeOptions& options) {
  if (dirs.empty()) throw Error("merge: give at least one sweep folder");
  if (options.out_dir.empty()) throw Error("merge: --out is required");
  std::string experiment_text;
  Experiment experiment;
  std::vector<ItemSpec> specs;
  std::map<std::string, json> merged;
  for (const std::string& dir : dirs) {
    const std::string text = ReadAll(dir + "/experiment.json");
    if (experiment_text.empty()) {
      experiment_text = text;
      experiment = LoadSweepDir(dir).experiment;
      specs = ExpandItems(experiment);
    } else if (text != experiment_text) {
      throw Error(dir, "is a different experiment from " + dirs.front() +
                           " (experiment.json "
                           "differs)");
    }
    Journal journal(dir + "/journal.jsonl");
    const std::map<std::string, json> entries = journal.Load(/*repair=*/false);
    CheckEntries(entries, specs, journal.path());
    RefuseIncompleteEntries(entries, specs, experiment, journal.path(),
                            "run the sweep into " + dir + " again to rerun the item, then merge");
    for (auto& [id, entry] : entries) {
      const auto it = merged.find(id);
      if (it == merged.end()) {
        merged.emplace(id, entry);
        continue;
      }
      // The same item run twice (overlapping shards): results must agree apart from timings.
      if (ItemResultToJson(ItemResultFromJson(it->second), false) !=
          ItemResultToJson(ItemResultFromJson(entry), false)) {
        throw Error(dir, "item '" + id + "' disagrees with another input folder");
      }
    }
  }
  CheckEntries(merged, specs, "merge");
  if (!options.allow_partial && merged.size() != specs.size()) {
    std::string first_missing;
    for (const ItemSpec& spec : specs) {
      if (!merged.count(spec.id)) {
        first_missing = spec.id;
        break;
      }
    }
    throw Error("merge: " + std::to_string(specs.size() - merged.size()) + " of " +
                std::to_string(specs.size()) + " items are missing (first: " + first_missing +
                "); run the missing shards or pass --allow-partial");
  }
  for (const std::string& dir : dirs) RefuseSymlink(dir + "/thumbs", "copies thumbnails");
  const FolderLock lock(options.out_dir, "sweep or merge");
  RemoveLeftovers(options.out_dir);
  ClaimDir(experiment, options.out_dir, options.force);
  // The merged journal in item order, so the merged folder can be resumed and reported on.
  std::vector<ItemResult> items = SortedResults(merged);
  std::ostringstream journal_text;
  for (const ItemResult& item : items) {
    journal_text << merged.at(item.id).dump() << "\n";
  }
  AtomicWriteText(options.out_dir + "/journal.jsonl", journal_text.str(), true);
  for (const std::string& dir : dirs) {
    if (fs::is_directory(dir + "/thumbs") &&
        fs::weakly_canonical(dir) != fs::weakly_canonical(options.out_dir)) {
      CopyThumbnails(dir + "/thumbs", options.out_dir + "/thumbs");
    }
  }
  WriteTables(experiment, items, options.out_dir);
  return static_cast<int>(items.size());
}

}  // namespace turbid
