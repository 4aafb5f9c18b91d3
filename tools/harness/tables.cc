#include "tools/harness/tables.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_io.h"
#include "tools/harness/protocol.h"
#include "tools/harness/statistics.h"

namespace turbid {
namespace {

// A method's column header: its label, with a dagger when it is privileged.
std::string MethodHeader(const ExperimentMethod& m) {
  return m.privileged ? m.label + " †" : m.label;
}

using nlohmann::json;

json ValueToJson(double value) {
  if (std::isfinite(value)) return value;
  return FormatValue(value);
}

double ValueFromJson(const json& value) {
  if (value.is_number()) return value.get<double>();
  if (value.is_string()) return ParseValue(value.get<std::string>());
  if (value.is_null()) return std::nan("");
  throw Error("metric value must be a number or inf/-inf/nan, got " + value.dump());
}

json MetricsToJson(const std::map<std::string, double>& metrics) {
  json out = json::object();
  for (const auto& [name, value] : metrics) out[name] = ValueToJson(value);
  return out;
}

std::map<std::string, double> MetricsFromJson(const json& in) {
  std::map<std::string, double> out;
  for (const auto& [name, value] : in.items()) out[name] = ValueFromJson(value);
  return out;
}

std::string ParamText(const json& value) {
  if (value.is_object() && value.contains("label")) return value["label"].get<std::string>();
  return value.is_string() ? value.get<std::string>() : value.dump();
}

// Formats a summary cell "mean ± sd" with 4 significant digits.
std::string FormatCell(const Stats& stats) {
  if (stats.n == 0) return "–";
  char buffer[96];
  if (!std::isfinite(stats.mean)) return FormatValue(stats.mean);
  if (stats.n == 1) {
    std::snprintf(buffer, sizeof buffer, "%.4g", stats.mean);
  } else {
    std::snprintf(buffer, sizeof buffer, "%.4g ± %.2g", stats.mean, stats.sd);
  }
  return buffer;
}

// Indices of the best finite means among `stats` (ties all marked); excluded columns skipped.
std::set<size_t> BestColumns(const std::vector<Stats>& stats, const std::vector<bool>& excluded,
                             bool higher_is_better) {
  std::set<size_t> best;
  double best_value = 0.0;
  bool any = false;
  for (size_t i = 0; i < stats.size(); ++i) {
    if (excluded[i] || stats[i].n == 0 || std::isnan(stats[i].mean)) continue;
    const double v = stats[i].mean;
    const bool better = !any || (higher_is_better ? v > best_value : v < best_value);
    if (better) {
      best = {i};
      best_value = v;
      any = true;
    } else if (v == best_value) {
      best.insert(i);
    }
  }
  return best;
}

std::string SizeLabel(const ItemResult& item) {
  return std::to_string(item.width) + "x" + std::to_string(item.height);
}

}  // namespace

std::string FormatValue(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.10g", value);
  return buffer;
}

double ParseValue(const std::string& text) {
  if (text == "inf" || text == "+inf") return HUGE_VAL;
  if (text == "-inf") return -HUGE_VAL;
  if (text == "nan" || text.empty()) return std::nan("");
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || used == 0) throw Error("'" + text + "' is not a number");
  return value;
}

std::string CsvEscape(const std::string& field) {
  if (field.find_first_of(",\"\n\r") == std::string::npos) return field;
  std::string out = "\"";
  for (char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.push_back(std::move(field));
      field.clear();
    } else if (c != '\r') {  // CRLF files: a bare CR outside quotes is line-ending residue
      field += c;
    }
  }
  fields.push_back(std::move(field));
  return fields;
}

json ItemResultToJson(const ItemResult& item, bool with_timing) {
  json out = json::object();
  out["index"] = item.index;
  out["id"] = item.id;
  out["scene"] = item.scene;
  out["condition"] = item.condition;
  out["level"] = item.level;
  out["level_value"] = item.level_value;
  out["params"] = item.params;
  out["seed"] = item.seed;
  out["width"] = item.width;
  out["height"] = item.height;
  if (!item.error.empty()) out["error"] = item.error;
  json methods = json::array();
  for (const MethodResult& m : item.methods) {
    json row = {{"method", m.label}, {"metrics", MetricsToJson(m.metrics)}};
    if (!m.error.empty()) row["error"] = m.error;
    if (with_timing) {
      row["time_ms"] = ValueToJson(m.time_ms);
      if (m.time_is_batch_share) row["time_batch"] = true;
    }
    methods.push_back(row);
  }
  out["methods"] = methods;
  out["reference_metrics"] = MetricsToJson(item.reference_metrics);
  if (with_timing) out["render_ms"] = item.render_ms;
  return out;
}

namespace {
// An int field of a journaled item (index, condition, width, height): an integral number in
// [0, INT_MAX]; anything else is a malformed entry (never a cast of 1e300 or of a string).
int ItemInt(const json& in, const char* key) {
  const std::optional<int64_t> v = JsonInteger(in.at(key), 0, std::numeric_limits<int>::max());
  if (!v) throw Error(std::string("malformed item result: ") + key + " is not an integer >= 0");
  return static_cast<int>(*v);
}
}  // namespace

ItemResult ItemResultFromJson(const json& in) {
  try {
    ItemResult item;
    item.index = ItemInt(in, "index");
    item.id = in.at("id").get<std::string>();
    item.scene = in.at("scene").get<std::string>();
    item.condition = ItemInt(in, "condition");
    item.level = in.at("level").get<std::string>();
    item.level_value = in.at("level_value").get<double>();
    item.params = in.at("params");
    const std::optional<uint64_t> seed = JsonUnsigned(in.at("seed"));
    if (!seed) throw Error("malformed item result: seed is not an unsigned 64-bit integer");
    item.seed = *seed;
    item.width = ItemInt(in, "width");
    item.height = ItemInt(in, "height");
    item.error = in.value("error", "");
    for (const json& row : in.at("methods")) {
      MethodResult m;
      m.label = row.at("method").get<std::string>();
      m.metrics = MetricsFromJson(row.at("metrics"));
      m.error = row.value("error", "");
      m.time_ms = row.contains("time_ms") ? ValueFromJson(row["time_ms"]) : 0.0;
      m.time_is_batch_share = row.value("time_batch", false);
      item.methods.push_back(std::move(m));
    }
    item.reference_metrics = MetricsFromJson(in.at("reference_metrics"));
    item.render_ms = in.value("render_ms", 0.0);
    return item;
  } catch (const json::exception& error) {
    throw Error(std::string("malformed item result: ") + error.what());
  }
}

Stats ComputeStats(const std::vector<double>& values) {
  Stats stats;
  double sum = 0.0;
  for (double v : values) {
    if (std::isnan(v)) continue;
    if (stats.n == 0) stats.min = stats.max = v;
    stats.min = std::min(stats.min, v);
    stats.max = std::max(stats.max, v);
    sum += v;
    ++stats.n;
  }
  if (stats.n == 0) return stats;
  stats.mean = sum / stats.n;
  if (stats.n > 1 && std::isfinite(stats.mean)) {
    double squares = 0.0;
    for (double v : values) {
      if (!std::isnan(v)) squares += (v - stats.mean) * (v - stats.mean);
    }
    stats.sd = std::sqrt(squares / (stats.n - 1));
  }
  return stats;
}

std::vector<SummaryCell> Summarize(const Experiment& experiment,
                                   const std::vector<ItemResult>& items) {
  std::vector<std::string> levels = LevelLabels(experiment);
  levels.push_back("all");
  std::vector<SummaryCell> cells;
  for (const std::string& level : levels) {
    for (size_t m = 0; m < experiment.methods.size(); ++m) {
      const std::string& label = experiment.methods[m].label;
      for (const HarnessMetricInfo& metric : experiment.metrics) {
        SummaryCell cell;
        cell.level = level;
        cell.method = label;
        cell.metric = metric.name;
        cell.domain = MetricDomain(experiment.score_domain, metric.needs_reference);
        for (const ItemResult& item : items) {
          if (level != "all" && item.level != level) continue;
          double value = std::nan("");
          for (const MethodResult& row : item.methods) {
            if (row.label != label) continue;
            const auto it = row.metrics.find(metric.name);
            if (it != row.metrics.end()) value = it->second;
            cell.failed += !row.error.empty() || !item.error.empty();
          }
          cell.values.push_back(value);
        }
        cell.stats = ComputeStats(cell.values);
        cells.push_back(std::move(cell));
      }
    }
  }
  // Intervals: independent per cell (own seed), so computed in parallel with the same result.
  cv::parallel_for_(cv::Range(0, static_cast<int>(cells.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      SummaryCell& cell = cells[static_cast<size_t>(i)];
      const Interval ci = BootstrapMeanCi(
          cell.values,
          kBootstrapSeed ^ StableHash(cell.level + '\x1f' + cell.method + '\x1f' + cell.metric));
      cell.ci_lo = ci.lo;
      cell.ci_hi = ci.hi;
    }
  });
  return cells;
}

SummaryCell ReferenceSummaryCell(const std::vector<ItemResult>& items, const std::string& level,
                                 const std::string& metric) {
  SummaryCell cell;
  cell.level = level;
  cell.method = "ground truth";
  cell.metric = metric;
  for (const ItemResult& item : items) {
    if (level != "all" && item.level != level) continue;
    const auto it = item.reference_metrics.find(metric);
    if (it != item.reference_metrics.end()) cell.values.push_back(it->second);
  }
  cell.stats = ComputeStats(cell.values);
  const Interval ci = BootstrapMeanCi(
      cell.values, kBootstrapSeed ^ StableHash(level + '\x1f' + "ground truth" + '\x1f' + metric));
  cell.ci_lo = ci.lo;
  cell.ci_hi = ci.hi;
  return cell;
}

RowVerdict JudgeRow(const std::vector<const SummaryCell*>& row, const std::vector<bool>& excluded,
                    bool higher_is_better) {
  RowVerdict verdict;
  std::vector<int> ranked;
  for (size_t i = 0; i < row.size(); ++i) {
    if (excluded[i] || row[i] == nullptr || row[i]->stats.n == 0 || std::isnan(row[i]->stats.mean))
      continue;
    ranked.push_back(static_cast<int>(i));
  }
  if (ranked.empty()) return verdict;
  const auto mean = [&](int i) { return row[static_cast<size_t>(i)]->stats.mean; };
  std::stable_sort(ranked.begin(), ranked.end(), [&](int a, int b) {
    return higher_is_better ? mean(a) > mean(b) : mean(a) < mean(b);
  });
  verdict.best = ranked[0];
  if (ranked.size() == 1) {
    verdict.significant = true;
    return verdict;
  }
  verdict.runner_up = ranked[1];
  const SignedRankResult test =
      WilcoxonSignedRank(row[static_cast<size_t>(verdict.best)]->values,
                         row[static_cast<size_t>(verdict.runner_up)]->values);
  verdict.p_value = test.p_value;
  verdict.pairs = test.n;
  // The ranks must point the same way as the means (they can disagree on skewed differences).
  const double centre = test.n * (test.n + 1.0) / 4.0;
  const bool same_way = higher_is_better ? test.w_plus > centre : test.w_plus < centre;
  verdict.significant =
      mean(verdict.best) != mean(verdict.runner_up) && same_way && test.p_value < 0.05;
  return verdict;
}

const std::vector<std::string>& DeterministicOutputs() {
  static const std::vector<std::string> files = {"experiment.json", "items.csv",   "items.jsonl",
                                                 "summary.md",      "summary.csv", "protocol.json"};
  return files;
}

namespace {

// items.csv and items.jsonl: one row per item and method, one line per item.
void ItemTables(const Experiment& experiment, const std::vector<ItemResult>& items,
                std::ostringstream& csv, std::ostringstream& jsonl) {
  std::vector<std::string> param_paths;
  for (const auto& entry : experiment.grid) param_paths.push_back(entry.first);
  for (const SampledParam& p : experiment.sampled) param_paths.push_back(p.path);

  csv << "id,scene,condition,level";
  for (const std::string& path : param_paths) csv << "," << CsvEscape("param:" + path);
  // score_domain: where the full-reference columns were scored (no-reference ones: linear).
  csv << ",method,score_domain";
  for (const HarnessMetricInfo& metric : experiment.metrics) csv << "," << CsvEscape(metric.name);
  csv << ",error\n";
  const bool any_full =
      std::any_of(experiment.metrics.begin(), experiment.metrics.end(),
                  [](const HarnessMetricInfo& metric) { return metric.needs_reference; });
  const std::string domain = MetricDomain(experiment.score_domain, any_full);
  for (const ItemResult& item : items) {
    jsonl << ItemResultToJson(item, false).dump() << "\n";
    for (const MethodResult& row : item.methods) {
      csv << CsvEscape(item.id) << "," << CsvEscape(item.scene) << "," << item.condition << ","
          << CsvEscape(item.level);
      for (const std::string& path : param_paths) {
        csv << "," << CsvEscape(item.params.contains(path) ? ParamText(item.params[path]) : "");
      }
      csv << "," << CsvEscape(row.label) << "," << domain;
      for (const HarnessMetricInfo& metric : experiment.metrics) {
        const auto it = row.metrics.find(metric.name);
        csv << "," << (it == row.metrics.end() ? "nan" : FormatValue(it->second));
      }
      csv << "," << CsvEscape(!row.error.empty() ? row.error : item.error) << "\n";
    }
  }
}

// summary.csv: the summary in long format.
std::string SummaryCsv(const std::vector<SummaryCell>& cells) {
  std::ostringstream summary_csv;
  summary_csv << "level,method,metric,domain,n,mean,sd,ci_lo,ci_hi,min,max,failed\n";
  for (const SummaryCell& cell : cells) {
    summary_csv << CsvEscape(cell.level) << "," << CsvEscape(cell.method) << ","
                << CsvEscape(cell.metric) << "," << cell.domain << "," << cell.stats.n << ","
                << (cell.stats.n ? FormatValue(cell.stats.mean) : "nan") << ","
                << (cell.stats.n ? FormatValue(cell.stats.sd) : "nan") << ","
                << (cell.stats.n ? FormatValue(cell.ci_lo) : "nan") << ","
                << (cell.stats.n ? FormatValue(cell.ci_hi) : "nan") << ","
                << (cell.stats.n ? FormatValue(cell.stats.min) : "nan") << ","
                << (cell.stats.n ? FormatValue(cell.stats.max) : "nan") << "," << cell.failed
                << "\n";
  }
  return summary_csv.str();
}

// Per method: never marked best.
std::vector<bool> BestExcluded(const Experiment& experiment) {
  std::vector<bool> excluded;
  for (const ExperimentMethod& m : experiment.methods) {
    excluded.push_back(std::find(experiment.best_excludes.begin(), experiment.best_excludes.end(),
                                 m.label) != experiment.best_excludes.end());
  }
  return excluded;
}

// Where the metrics were scored, as the tables say it (tools/harness/score_domain.h).
std::string DomainSentence(const Experiment& experiment) {
  std::string full, other;
  for (const HarnessMetricInfo& metric : experiment.metrics) {
    std::string& list = metric.needs_reference ? full : other;
    list += (list.empty() ? "" : ", ") + metric.name;
  }
  std::string out = "Score domain: **" + ScoreDomainName(experiment.score_domain) + "**";
  if (full.empty())
    return out + " (no full-reference metric here; every metric reads linear light).";
  out += experiment.score_domain == ScoreDomain::kEncoded
             ? " — full-reference metrics (" + full +
                   ") compare the images as the camera writes them (its encoding, quantised to its "
                   "bit depth, data range 2^bits − 1)"
             : " — full-reference metrics (" + full + ") compare linear-light float images";
  if (!other.empty()) out += "; the others (" + other + ") read linear light";
  return out + ".";
}

// summary.md's title and the paragraph that explains the cells.
void SummaryMarkdownHead(const Experiment& experiment, const std::vector<ItemResult>& items,
                         std::ostringstream& md) {
  md << "# " << experiment.name << ": summary\n\n";
  if (!experiment.description.empty()) md << experiment.description << "\n\n";
  md << items.size() << " of " << experiment.ItemCount() << " items; ground truth: "
     << (experiment.ground_truth == "lit" ? "lit J = (E_A + E_L) rho" : "clean rho") << "; level: `"
     << experiment.level_path << "`. " << DomainSentence(experiment)
     << " Cells: mean over items [95 % percentile-bootstrap interval, " << kBootstrapResamples
     << " resamples, seeded]; **bold** = best per row where a two-sided Wilcoxon signed-rank "
        "test over the same items says it beats the runner-up at 5 %, otherwise the row says "
        "\"tied\"";
  if (!experiment.best_excludes.empty()) {
    md << " (not counting";
    for (const std::string& label : experiment.best_excludes) md << " " << label;
    md << ")";
  }
  md << "; ↑ higher is better, ↓ lower is better. Run times: timings.md.\n";
  if (std::any_of(experiment.methods.begin(), experiment.methods.end(),
                  [](const ExperimentMethod& m) { return m.privileged; })) {
    md << "\n† privileged: receives true simulation parameters (water, light power, PSF, noise or "
          "exact geometry) that its published version does not have — a reference, not a "
          "competitor (docs/methods.md, \"Which inputs each method sees\").\n";
  }
}

// A summary cell: "mean [ci_lo, ci_hi]" with 4 significant digits (the mean alone for n = 1).
std::string FormatSummaryCell(const SummaryCell& cell) {
  if (cell.stats.n == 0) return "–";
  if (!std::isfinite(cell.stats.mean)) return FormatValue(cell.stats.mean);
  char buffer[128];
  if (cell.stats.n == 1 || cell.ci_lo == cell.ci_hi) {
    std::snprintf(buffer, sizeof buffer, "%.4g", cell.stats.mean);
  } else {
    std::snprintf(buffer, sizeof buffer, "%.4g [%.4g, %.4g]", cell.stats.mean, cell.ci_lo,
                  cell.ci_hi);
  }
  return buffer;
}

// The row's "best" column: the winner and its test, or "tied".
std::string VerdictText(const Experiment& experiment, const RowVerdict& verdict) {
  if (verdict.best < 0) return "–";
  const std::string best = experiment.methods[static_cast<size_t>(verdict.best)].label;
  if (verdict.runner_up < 0) return best + " (alone)";
  const std::string second = experiment.methods[static_cast<size_t>(verdict.runner_up)].label;
  char p[32];
  std::snprintf(p, sizeof p, "%.2g", verdict.p_value);
  return (verdict.significant ? best + " > " + second : "tied: " + best + " ≈ " + second) +
         " (p = " + p + ", n = " + std::to_string(verdict.pairs) + ")";
}

// summary.md: Table I style, one table per level and overall.
std::string SummaryMarkdown(const Experiment& experiment, const std::vector<ItemResult>& items,
                            const std::vector<SummaryCell>& cells) {
  std::map<std::tuple<std::string, std::string, std::string>, const SummaryCell*> lookup;
  std::map<std::pair<std::string, std::string>, int> failed_items;  // (level, method)
  int any_failed = 0;
  for (const SummaryCell& cell : cells) {
    lookup[{cell.level, cell.method, cell.metric}] = &cell;
    failed_items[{cell.level, cell.method}] = cell.failed;
    any_failed += cell.failed;
  }

  const std::vector<bool> excluded = BestExcluded(experiment);
  const auto reference_cell = [&](const std::string& level, const std::string& metric) {
    return ReferenceSummaryCell(items, level, metric);
  };
  bool any_reference = false;
  for (const ItemResult& item : items) any_reference |= !item.reference_metrics.empty();

  std::ostringstream md;
  SummaryMarkdownHead(experiment, items, md);
  std::vector<std::string> levels = LevelLabels(experiment);
  levels.insert(levels.begin(), "all");
  for (const std::string& level : levels) {
    int n_items = 0;
    for (const ItemResult& item : items) n_items += level == "all" || item.level == level;
    const std::string axis = experiment.level_path.rfind('@', 0) == 0
                                 ? experiment.level_path.substr(1)
                                 : experiment.level_path;
    md << "\n## " << (level == "all" ? "All levels" : axis + " = " + level) << " (" << n_items
       << " items)\n\n| metric |";
    for (const ExperimentMethod& m : experiment.methods) md << " " << MethodHeader(m) << " |";
    if (any_reference) md << " ground truth |";
    md << " best (Wilcoxon, 5 %) |\n|---|";
    for (size_t i = 0; i < experiment.methods.size(); ++i) md << "---|";
    if (any_reference) md << "---|";
    md << "---|\n";
    for (const HarnessMetricInfo& metric : experiment.metrics) {
      std::vector<const SummaryCell*> row;
      for (const ExperimentMethod& m : experiment.methods) {
        const auto it = lookup.find({level, m.label, metric.name});
        row.push_back(it == lookup.end() ? nullptr : it->second);
      }
      const RowVerdict verdict = JudgeRow(row, excluded, metric.higher_is_better);
      md << "| " << metric.name << (metric.higher_is_better ? " ↑" : " ↓")
         << (metric.needs_reference ? " (" + ScoreDomainName(experiment.score_domain) + ")" : "")
         << " |";
      for (size_t i = 0; i < row.size(); ++i) {
        const std::string cell = row[i] == nullptr ? "–" : FormatSummaryCell(*row[i]);
        const bool bold = verdict.significant && static_cast<int>(i) == verdict.best;
        md << " " << (bold ? "**" + cell + "**" : cell) << " |";
      }
      if (any_reference) md << " " << FormatSummaryCell(reference_cell(level, metric.name)) << " |";
      md << " " << VerdictText(experiment, verdict) << " |\n";
    }
    if (any_failed > 0) {
      // Items on which a method failed (its metrics are NaN and left out of the cells above).
      md << "| failed (items) |";
      for (const ExperimentMethod& m : experiment.methods) {
        md << " " << failed_items[{level, m.label}] << " |";
      }
      if (any_reference) md << " |";
      md << " |\n";
    }
  }

  return md.str();
}

// timings.csv and timings.md.
void TimingTables(const Experiment& experiment, const std::vector<ItemResult>& items,
                  std::ostringstream& timings_csv, std::ostringstream& timings_md) {
  const std::vector<bool> excluded = BestExcluded(experiment);
  // Timings (not deterministic): per item and method, and a Table I style "time" table per size.
  // timing: "alone" (the method's own wall time), "batch_share" (a batch process's wall time /
  // its items) or "none" (precomputed results: nothing ran).
  timings_csv << "id,method,time_ms,timing\n";
  std::vector<std::string> sizes;
  std::set<std::string> batch_share, not_run;
  for (const ItemResult& item : items) {
    timings_csv << CsvEscape(item.id) << ",render," << FormatValue(item.render_ms) << ",alone\n";
    for (const MethodResult& row : item.methods) {
      const char* timing =
          row.time_is_batch_share ? "batch_share" : (std::isnan(row.time_ms) ? "none" : "alone");
      if (row.time_is_batch_share) batch_share.insert(row.label);
      if (std::isnan(row.time_ms)) not_run.insert(row.label);
      timings_csv << CsvEscape(item.id) << "," << CsvEscape(row.label) << ","
                  << FormatValue(row.time_ms) << "," << timing << "\n";
    }
    if (std::find(sizes.begin(), sizes.end(), SizeLabel(item)) == sizes.end()) {
      sizes.push_back(SizeLabel(item));
    }
  }
  timings_md << "# " << experiment.name << ": run time per image (ms, mean ± sd)\n\n"
             << "Wall time of each method alone on one sweep thread; not deterministic, so kept "
                "apart from summary.md.";
  if (!batch_share.empty()) {
    timings_md << " (batch): the wall time of a process run once per batch of items, divided by "
                  "the batch's items (input and output files included).";
  }
  if (!not_run.empty()) timings_md << " (precomputed): results read from files, nothing ran.";
  timings_md << "\n\n| size | render |";
  for (const ExperimentMethod& m : experiment.methods) {
    timings_md << " " << MethodHeader(m)
               << (batch_share.count(m.label) ? " (batch)"
                                              : (not_run.count(m.label) ? " (precomputed)" : ""))
               << " |";
  }
  timings_md << "\n|---|---|";
  for (size_t i = 0; i < experiment.methods.size(); ++i) timings_md << "---|";
  timings_md << "\n";
  for (const std::string& size : sizes) {
    std::vector<double> render;
    std::map<std::string, std::vector<double>> per_method;
    for (const ItemResult& item : items) {
      if (SizeLabel(item) != size) continue;
      render.push_back(item.render_ms);
      for (const MethodResult& row : item.methods) per_method[row.label].push_back(row.time_ms);
    }
    std::vector<Stats> row;
    for (const ExperimentMethod& m : experiment.methods) {
      row.push_back(ComputeStats(per_method[m.label]));
    }
    const std::set<size_t> best = BestColumns(row, excluded, false);
    timings_md << "| " << size << " | " << FormatCell(ComputeStats(render)) << " |";
    for (size_t i = 0; i < row.size(); ++i) {
      const std::string cell = FormatCell(row[i]);
      timings_md << " " << (best.count(i) ? "**" + cell + "**" : cell) << " |";
    }
    timings_md << "\n";
  }
}

}  // namespace

void WriteTables(const Experiment& experiment, const std::vector<ItemResult>& items,
                 const std::string& dir, bool with_timings) {
  std::ostringstream csv, jsonl;
  ItemTables(experiment, items, csv, jsonl);
  const std::vector<SummaryCell> cells = Summarize(experiment, items);
  const std::string summary_csv = SummaryCsv(cells);
  const std::string md = SummaryMarkdown(experiment, items, cells) + ProtocolMarkdown(experiment);
  std::ostringstream timings_csv, timings_md;
  TimingTables(experiment, items, timings_csv, timings_md);

  // summary.md last: a sweep takes it as the mark of complete tables (a write that fails before it
  // leaves the tables to be written again by the next run).
  AtomicWriteText(dir + "/items.csv", csv.str(), true);
  AtomicWriteText(dir + "/items.jsonl", jsonl.str(), true);
  AtomicWriteText(dir + "/summary.csv", summary_csv, true);
  WriteProtocol(experiment, dir);
  if (with_timings) {
    AtomicWriteText(dir + "/timings.csv", timings_csv.str(), true);
    AtomicWriteText(dir + "/timings.md", timings_md.str(), true);
  }
  AtomicWriteText(dir + "/summary.md", md, true);
}

}  // namespace turbid
