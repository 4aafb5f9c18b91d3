// turbid regress: a results table against a baseline table (items.csv or summary.csv), metric by
// metric within tolerances (docs/cli/harness.md "regress"). Declared in tools/harness/tables.h.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/fields.h"
#include "core/input_file.h"
#include "core/json_io.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

using nlohmann::json;

struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  int Column(const std::string& name) const {
    for (size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return static_cast<int>(i);
    }
    return -1;
  }
};

CsvTable ReadCsv(const std::string& path) {
  CheckInputFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open");
  CsvTable table;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::vector<std::string> fields = SplitCsvLine(line);
    if (table.header.empty()) {
      table.header = std::move(fields);
    } else {
      if (fields.size() != table.header.size()) {
        throw Error(path, "line " + std::to_string(line_number) + " has " +
                              std::to_string(fields.size()) + " fields, header has " +
                              std::to_string(table.header.size()));
      }
      table.rows.push_back(std::move(fields));
    }
  }
  if (table.header.empty()) throw Error(path, "empty CSV file");
  return table;
}

// A table reduced to key -> metric -> value for the regression check.
struct KeyedValues {
  std::vector<std::string> keys;  // in file order
  std::map<std::string, std::map<std::string, std::string>> values;
  std::vector<std::string> metrics;  // in file order (items.csv kind)
  // The score domain of the full-reference metrics ("" when the table predates the column).
  std::string domain;
  // Summary tables with ci_lo / ci_hi: the baseline interval of each mean, by key and metric.
  std::map<std::string, std::map<std::string, std::pair<double, double>>> intervals;
};

KeyedValues Keyed(const CsvTable& table, const std::string& path, bool* is_summary) {
  KeyedValues keyed;
  const bool summary = table.Column("level") >= 0 && table.Column("metric") >= 0 &&
                       table.Column("mean") >= 0 && table.Column("method") >= 0;
  const bool items = table.Column("id") >= 0 && table.Column("method") >= 0;
  if (!summary && !items) {
    throw Error(path, "not a sweep table (need items.csv or summary.csv columns)");
  }
  *is_summary = summary;
  const auto add = [&](const std::string& key, const std::string& metric, const std::string& v) {
    if (!keyed.values.count(key)) keyed.keys.push_back(key);
    if (keyed.values[key].count(metric)) throw Error(path, "duplicate row '" + key + "'");
    keyed.values[key][metric] = v;
  };
  if (summary) {
    const int level = table.Column("level"), method = table.Column("method");
    const int metric = table.Column("metric"), mean = table.Column("mean");
    const int domain = table.Column("domain");
    const int lo = table.Column("ci_lo"), hi = table.Column("ci_hi");
    for (const auto& row : table.rows) {
      add(row[level] + " " + row[method], row[metric], row[mean]);
      if (lo >= 0 && hi >= 0) {
        keyed.intervals[row[level] + " " + row[method]][row[metric]] = {ParseValue(row[lo]),
                                                                        ParseValue(row[hi])};
      }
      if (domain >= 0 && row[domain] == "encoded") keyed.domain = "encoded";
      if (domain >= 0 && keyed.domain.empty()) keyed.domain = "linear";
    }
    return keyed;
  }
  const int id = table.Column("id"), method = table.Column("method");
  const std::set<std::string> fixed = {"id",     "scene",        "condition", "level",
                                       "method", "score_domain", "error"};
  if (const int domain = table.Column("score_domain"); domain >= 0 && !table.rows.empty())
    keyed.domain = table.rows.front()[domain];
  std::vector<int> metric_columns;
  for (size_t i = 0; i < table.header.size(); ++i) {
    if (fixed.count(table.header[i]) || table.header[i].rfind("param:", 0) == 0) continue;
    metric_columns.push_back(static_cast<int>(i));
    keyed.metrics.push_back(table.header[i]);
  }
  for (const auto& row : table.rows) {
    for (int c : metric_columns) add(row[id] + " " + row[method], table.header[c], row[c]);
  }
  return keyed;
}

}  // namespace

bool RegressOptions::Check(std::string* why) const {
  const auto bad = [](const Tolerance& t) {
    return !(t.abs >= 0.0) || !(t.rel >= 0.0) || !std::isfinite(t.abs) || !std::isfinite(t.rel);
  };
  if (bad(default_tolerance)) {
    *why = "default tolerance must be finite and >= 0";
    return false;
  }
  for (const auto& [metric, tolerance] : tolerances) {
    if (bad(tolerance)) {
      *why = "tolerance of '" + metric + "' must be finite and >= 0";
      return false;
    }
  }
  return true;
}

bool RegressReport::failed() const {
  if (!missing.empty()) return true;
  return std::any_of(moves.begin(), moves.end(), [](const RegressMove& m) { return m.regression; });
}

std::string RegressReport::Format() const {
  std::ostringstream out;
  int regressions = 0;
  for (const RegressMove& move : moves) {
    regressions += move.regression;
    char line[512];
    const double delta = move.result - move.baseline;
    std::snprintf(line, sizeof line, "%-11s %-32s %-12s %14s -> %-14s (%+.4g)\n",
                  move.regression ? "REGRESSED" : "improved", move.key.c_str(), move.metric.c_str(),
                  FormatValue(move.baseline).c_str(), FormatValue(move.result).c_str(), delta);
    out << line;
  }
  for (const std::string& key : missing) out << "MISSING     " << key << "\n";
  out << compared << " values compared: " << moves.size() << " moved beyond tolerance ("
      << regressions << " regressed), " << missing.size() << " missing, " << extra.size()
      << " new rows not in the baseline";
  if (within_noise > 0) {
    out << "; " << within_noise
        << " beyond tolerance but inside the baseline's 95 % interval (within noise)";
  }
  out << "\n";
  out << (failed() ? "regress: FAIL\n" : "regress: OK\n");
  return out.str();
}

RegressReport Regress(const std::string& baseline_csv, const std::string& results_csv,
                      const RegressOptions& options) {
  ThrowIfInvalid(options, "regress");
  bool baseline_summary = false, results_summary = false;
  const KeyedValues baseline = Keyed(ReadCsv(baseline_csv), baseline_csv, &baseline_summary);
  const KeyedValues results = Keyed(ReadCsv(results_csv), results_csv, &results_summary);
  if (baseline_summary != results_summary) {
    throw Error(results_csv, std::string("is a ") + (results_summary ? "summary" : "per-item") +
                                 " table but the baseline " + baseline_csv + " is a " +
                                 (baseline_summary ? "summary" : "per-item") + " table");
  }
  if (!baseline.domain.empty() && !results.domain.empty() && baseline.domain != results.domain) {
    throw Error(results_csv, "scored in the '" + results.domain + "' domain but the baseline " +
                                 baseline_csv + " in '" + baseline.domain +
                                 "': re-measure the baseline (or set the experiment's "
                                 "\"score_domain\")");
  }
  RegressReport report;
  for (const std::string& key : baseline.keys) {
    const auto found = results.values.find(key);
    for (const auto& [metric, base_text] : baseline.values.at(key)) {
      if (found == results.values.end() || !found->second.count(metric)) {
        report.missing.push_back(key + " " + metric);
        continue;
      }
      const double base = ParseValue(base_text);
      const double result = ParseValue(found->second.at(metric));
      ++report.compared;
      const auto tol_it = options.tolerances.find(metric);
      const Tolerance& tol =
          tol_it == options.tolerances.end() ? options.default_tolerance : tol_it->second;
      bool same;
      if (std::isnan(base) || std::isnan(result)) {
        same = std::isnan(base) && std::isnan(result);
      } else if (std::isinf(base) || std::isinf(result)) {
        same = base == result;
      } else {
        same = std::fabs(result - base) <= tol.abs + tol.rel * std::fabs(base);
      }
      if (!same && options.within_interval && std::isfinite(result)) {
        const auto key_it = baseline.intervals.find(key);
        if (key_it != baseline.intervals.end() && key_it->second.count(metric)) {
          const auto [lo, hi] = key_it->second.at(metric);
          same = result >= lo && result <= hi;
          report.within_noise += same;
        }
      }
      if (same) continue;
      RegressMove move{key, metric, base, result, true};
      const auto direction = options.higher_is_better.find(metric);
      if (direction != options.higher_is_better.end() && !options.fail_on_improvement &&
          !std::isnan(base) && !std::isnan(result)) {
        move.regression = direction->second ? result < base : result > base;
      }
      report.moves.push_back(move);
    }
  }
  for (const std::string& key : results.keys) {
    if (!baseline.values.count(key)) report.extra.push_back(key);
  }
  return report;
}

namespace {

const Fields<Tolerance>& ToleranceFields() {
  static const Fields<Tolerance> fields =
      Fields<Tolerance>()
          .Number("abs", &Tolerance::abs, "absolute tolerance", NumberRange::AtLeast(0))
          .Number("rel", &Tolerance::rel, "relative tolerance", NumberRange::AtLeast(0));
  return fields;
}

// A tolerance file: {"default": {abs, rel}, "metrics": {NAME: {abs, rel}}, "comment": "..."}.
struct ToleranceFile {
  RegressOptions* options = nullptr;
  std::string path, comment;
};

const Fields<ToleranceFile>& ToleranceFileFields() {
  using F = ToleranceFile;
  static const Fields<F> fields =
      Fields<F>()
          .Custom(
              "default", "object {abs, rel}", "", "the tolerance of metrics not listed",
              [](const nlohmann::json& v, F& out) {
                ToleranceFields().Read(v, &out.options->default_tolerance, out.path, "default");
                return std::string();
              },
              [](const F& in) { return ToleranceFields().ToJson(in.options->default_tolerance); })
          .Custom(
              "metrics", "object {metric: {abs, rel}}", "", "per-metric tolerances",
              [](const nlohmann::json& v, F& out) -> std::string {
                if (!v.is_object()) return "expected an object {metric: {abs, rel}}";
                for (const auto& [metric, tolerance] : v.items()) {
                  Tolerance t = out.options->default_tolerance;
                  if (out.options->tolerances.count(metric)) t = out.options->tolerances[metric];
                  ToleranceFields().Read(tolerance, &t, out.path, "metrics." + metric);
                  out.options->tolerances[metric] = t;
                }
                return "";
              },
              [](const F& in) {
                nlohmann::json out = nlohmann::json::object();
                for (const auto& [metric, t] : in.options->tolerances) {
                  out[metric] = ToleranceFields().ToJson(t);
                }
                return out;
              })
          .String("comment", &F::comment, "free text");
  return fields;
}

}  // namespace

void LoadTolerances(const std::string& path, RegressOptions* options) {
  const json parsed = ReadJsonFile(path);
  ToleranceFile file{options, path, ""};
  ToleranceFileFields().Read(parsed, &file, path);
  std::string why;
  if (!options->Check(&why)) throw Error(path, why);
}

}  // namespace turbid
