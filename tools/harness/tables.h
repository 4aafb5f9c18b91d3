// Sweep results and the tables made from them: per-item CSV and JSON lines, Table I style
// summaries (mean ± spread per method x turbidity level and overall, best value per row marked),
// run-time tables, and the regression check against a committed baseline.
//
// Determinism: items.csv, items.jsonl, summary.md and summary.csv depend only on the experiment
// and the item results, never on thread count, shard layout or completion order (rows are sorted
// by item index, then method order). Run times live only in timings.csv and timings.md.
#pragma once

#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tools/harness/experiment.h"

namespace turbid {

struct MethodResult {
  std::string label;                      // the method's label in the experiment
  std::map<std::string, double> metrics;  // metric name -> value (+-inf allowed, NaN = failed)
  std::string error;                      // non-empty when the method failed on this item
  double time_ms = 0.0;                   // wall time of the method alone (not deterministic);
                                          // NaN when nothing ran (precomputed results)
  // time_ms is the wall time of a batch process divided by the items of its batch.
  bool time_is_batch_share = false;
};

struct ItemResult {
  int index = 0;
  std::string id;
  std::string scene;
  int condition = 0;
  std::string level;
  double level_value = 0.0;
  nlohmann::json params = nlohmann::json::object();
  uint64_t seed = 0;
  int width = 0, height = 0;          // image size of the item (for the run-time table)
  std::string error;                  // non-empty when the render itself failed
  std::vector<MethodResult> methods;  // in the experiment's method order
  // No-reference metrics of the ground-truth image itself (computed once per scene).
  std::map<std::string, double> reference_metrics;
  double render_ms = 0.0;  // wall time of the render (not deterministic)
};

// One JSON object per item; timings only when with_timing (the journal keeps them, items.jsonl
// does not). Non-finite values are written as the strings "inf", "-inf", "nan".
nlohmann::json ItemResultToJson(const ItemResult& item, bool with_timing);
ItemResult ItemResultFromJson(const nlohmann::json& json);  // throws Error on malformed input

// Number formats shared by every table ("%.10g"; non-finite as inf/-inf/nan).
std::string FormatValue(double value);
double ParseValue(const std::string& text);  // inverse of FormatValue; throws Error
std::string CsvEscape(const std::string& field);
std::vector<std::string> SplitCsvLine(const std::string& line);

// Mean ± spread of the finite values (spread = sample standard deviation; 0 for n = 1).
struct Stats {
  int n = 0;
  double mean = 0.0, sd = 0.0, min = 0.0, max = 0.0;
};
Stats ComputeStats(const std::vector<double>& values);

// Writes items.csv, items.jsonl, summary.md, summary.csv, timings.csv, timings.md into dir
// (atomically, replacing older versions). `items` must be sorted by index.
// with_timings = false leaves out timings.csv and timings.md (scores of files, nothing timed).
void WriteTables(const Experiment& experiment, const std::vector<ItemResult>& items,
                 const std::string& dir, bool with_timings = true);
// The deterministic files, i.e. those that are byte-identical for any thread count and shard
// layout (documented in docs/experiments.md).
const std::vector<std::string>& DeterministicOutputs();

// Summary cell per (level, method, metric); level "all" is the overall row.
struct SummaryCell {
  std::string level, method, metric;
  Stats stats;
  int failed = 0;  // items of the level on which the method failed (error set; metrics NaN)
  std::string domain;  // where the metric was scored: "encoded" or "linear" (MetricDomain)
  // 95 % percentile-bootstrap interval of the mean over the level's items (statistics.h; seeded
  // by the cell's level, method and metric): deterministic.
  double ci_lo = 0.0, ci_hi = 0.0;
  // One value per item of the level, in item order (NaN: failed or absent): the paired test's
  // input.
  std::vector<double> values;
};

// The best method of one summary row and whether it beats the runner-up (statistics.h): a
// two-sided Wilcoxon signed-rank test over the items both have, at the 5 % level, in the
// direction of the means. `best` is -1 when no column qualifies; `runner_up` -1 when only one.
struct RowVerdict {
  int best = -1, runner_up = -1;
  bool significant = false;  // best beats runner_up (p < 0.05) — or there is no runner-up
  double p_value = 1.0;
  int pairs = 0;  // non-zero differences the test used
};
RowVerdict JudgeRow(const std::vector<const SummaryCell*>& row, const std::vector<bool>& excluded,
                    bool higher_is_better);
std::vector<SummaryCell> Summarize(const Experiment& experiment,
                                   const std::vector<ItemResult>& items);
// The ground truth's own scores (ItemResult::reference_metrics) over a level's items ("all": every
// item), with its interval: summary.md's "ground truth" column and the report's row.
SummaryCell ReferenceSummaryCell(const std::vector<ItemResult>& items, const std::string& level,
                                 const std::string& metric);

// ---- Regression check ---------------------------------------------------------------------

// |result - baseline| <= abs + rel * |baseline| counts as unchanged.
struct Tolerance {
  double abs = 1e-6;
  double rel = 1e-4;
};

struct RegressOptions {
  std::map<std::string, Tolerance> tolerances;  // per metric; missing metrics use default_tolerance
  Tolerance default_tolerance;
  // Direction per metric (true: higher is better); metrics not listed count any move as a
  // regression.
  std::map<std::string, bool> higher_is_better;
  bool fail_on_improvement = false;  // strict: any move beyond tolerance fails
  // Summary tables: a mean beyond tolerance that stays inside the baseline's 95 % bootstrap
  // interval of that mean over items (ci_lo, ci_hi) is within the metric's item noise and passes
  // (counted in RegressReport::within_noise). For comparing runs whose items differ (another seed,
  // other samples); a baseline without the columns is compared by tolerance alone.
  bool within_interval = false;
  bool Check(std::string* why) const;
};

struct RegressMove {
  std::string key;  // "<id> <method>" for items.csv, "<level> <method>" for summary.csv
  std::string metric;
  double baseline = 0.0, result = 0.0;
  bool regression = false;  // worse beyond tolerance (or any move when the direction is unknown)
};

struct RegressReport {
  int compared = 0;                  // values compared
  int within_noise = 0;              // beyond tolerance but inside the baseline's interval
  std::vector<RegressMove> moves;    // beyond tolerance, in baseline order
  std::vector<std::string> missing;  // baseline rows/metrics absent from the results
  std::vector<std::string> extra;    // result rows absent from the baseline (informational)
  bool failed() const;
  std::string Format() const;  // human-readable, one line per move
};

// Compares two CSV tables of the same kind (items.csv or summary.csv). Throws Error for
// unreadable files or mismatched kinds.
RegressReport Regress(const std::string& baseline_csv, const std::string& results_csv,
                      const RegressOptions& options);
// Reads {"default": {"abs": a, "rel": r}, "metrics": {"psnr": {"abs": 0.01}}}.
void LoadTolerances(const std::string& path, RegressOptions* options);

}  // namespace turbid
