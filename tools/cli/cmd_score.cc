// `turbid score`: metrics of images against a reference, over a `turbid generate` manifest, or
// feature matching over image pairs. Reference: docs/cli/score.md.
#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "core/input_file.h"
#include "core/json_io.h"
#include "metrics/feature_matching.h"
#include "metrics/image_checks.h"
#include "metrics/registry.h"
#include "scenes/image_io.h"
#include "tools/cli/cli.h"
#include "tools/harness/experiment.h"
#include "tools/harness/external_method.h"
#include "tools/harness/file_context.h"
#include "tools/harness/file_encoding.h"
#include "tools/harness/manifest.h"
#include "tools/harness/metric_image.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {
namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Output: one row per scored image.

struct ScoreRow {
  std::string label;                                // image path (or manifest id)
  nlohmann::json extra = nlohmann::json::object();  // reference / original paths in batch mode
  std::map<std::string, double> values;
};

enum class Format { kTable, kJson, kCsv };

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

void PrintRows(const std::vector<std::string>& metrics, const std::vector<ScoreRow>& rows,
               Format format, const nlohmann::json& header, std::ostream& out) {
  // Mean per metric over rows (finite values only would hide problems: plain mean, inf stays).
  std::map<std::string, double> mean;
  for (const std::string& m : metrics) {
    double sum = 0.0;
    for (const ScoreRow& r : rows) sum += r.values.at(m);
    mean[m] = rows.empty() ? 0.0 : sum / rows.size();
  }
  if (format == Format::kJson) {
    nlohmann::json doc = header;
    doc["metrics"] = metrics;
    nlohmann::json results = nlohmann::json::array();
    for (const ScoreRow& r : rows) {
      nlohmann::json row = {{"image", r.label}};
      row.update(r.extra);
      for (const std::string& m : metrics) row[m] = MetricValueToJson(r.values.at(m));
      results.push_back(row);
    }
    doc["results"] = results;
    nlohmann::json means = nlohmann::json::object();
    for (const std::string& m : metrics) means[m] = MetricValueToJson(mean[m]);
    doc["mean"] = means;
    out << doc.dump(2) << "\n";
    return;
  }
  std::vector<std::string> extra_keys;
  if (!rows.empty())
    for (auto it = rows.front().extra.begin(); it != rows.front().extra.end(); ++it)
      extra_keys.push_back(it.key());
  if (format == Format::kCsv) {
    out << "image";
    for (const std::string& k : extra_keys) out << "," << CsvField(k);
    for (const std::string& m : metrics) out << "," << m;
    out << "\n";
    for (const ScoreRow& r : rows) {
      out << CsvField(r.label);
      for (const std::string& k : extra_keys)
        out << "," << CsvField(r.extra.value(k, std::string()));
      for (const std::string& m : metrics) out << "," << MetricValueToText(r.values.at(m));
      out << "\n";
    }
    return;
  }
  // Human table: image column then one column per metric, a mean row when there are several.
  size_t label_width = 5;
  for (const ScoreRow& r : rows) label_width = std::max(label_width, r.label.size());
  std::vector<size_t> widths;
  for (const std::string& m : metrics) widths.push_back(std::max<size_t>(12, m.size()));
  out << std::left << std::setw(static_cast<int>(label_width)) << "image";
  for (size_t i = 0; i < metrics.size(); ++i)
    out << "  " << std::right << std::setw(static_cast<int>(widths[i])) << metrics[i];
  out << "\n";
  auto line = [&](const std::string& label, const std::map<std::string, double>& values) {
    out << std::left << std::setw(static_cast<int>(label_width)) << label;
    for (size_t i = 0; i < metrics.size(); ++i)
      out << "  " << std::right << std::setw(static_cast<int>(widths[i]))
          << MetricValueToText(values.at(metrics[i]));
    out << "\n";
  };
  for (const ScoreRow& r : rows) line(r.label, r.values);
  if (rows.size() > 1) line("mean", mean);
}

Format ParseFormat(bool json, bool csv) {
  if (json && csv) throw Error("--json and --csv are exclusive");
  return json ? Format::kJson : (csv ? Format::kCsv : Format::kTable);
}

// ---------------------------------------------------------------------------------------------
// Manifests: CSV with a header, or JSON lines; columns found by name.

using Record = ManifestRecord;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// First column of `keys` whose lower-cased name is in `candidates` (candidate order wins).
std::string FindColumn(const std::vector<std::string>& keys,
                       const std::vector<std::string>& candidates) {
  for (const std::string& c : candidates)
    for (const std::string& k : keys)
      if (Lower(k) == c) return k;
  return "";
}

// A level's position on plot axes: its number, else its rank.
double ParseValueOr(const std::string& text, int rank) {
  try {
    const double value = ParseValue(text);
    return std::isfinite(value) ? value : rank;
  } catch (const Error&) {
    return rank;
  }
}

std::string ResolvePath(const std::string& manifest, const std::string& value) {
  const fs::path p(value);
  if (p.is_absolute()) return value;
  return (fs::path(manifest).parent_path() / p).lexically_normal().string();
}

// The reference and the original are checked (NaN, inf, empty) under their own names before the
// metrics run: the metrics' own checks would be reported against the scored image.
void CheckSideImage(const std::vector<std::string>& metrics, bool reference,
                    const std::string& path, const cv::Mat& pixels) {
  for (const std::string& name : metrics) {
    const MetricInfo& info = FindMetric(name);
    if (reference ? info.needs_reference : info.needs_original) {
      CheckMetricImage(pixels, path);
      return;
    }
  }
}

// ---------------------------------------------------------------------------------------------

struct ScoreArgs {
  std::string ref;
  std::vector<std::string> images;
  std::string original;
  std::string metrics = "";
  std::string manifest;
  std::string image_column;
  std::string ref_column;
  std::string original_column;
  std::string pairs;
  std::string detector = "orb";
  std::string sidecar;
  bool json = false;
  bool csv = false;
  bool list = false;
  // --results: a folder of enhanced images scored against a `turbid generate` dataset.
  std::string results;
  std::string name;
  std::string out;
  std::string level = "beta_gray";
  std::string encoding = "linear";
  std::string ground_truth = "clean";
  int threads = 0;
};

// Aligned columns as wide as their longest entry, two spaces apart (a fixed width ran "--original"
// into the summary).
void ListMetricsCommand() {
  const std::vector<MetricInfo> metrics = ListMetrics();
  const auto needs = [](const MetricInfo& info) -> std::string {
    return info.needs_reference ? "--ref" : (info.needs_original ? "--original" : "-");
  };
  size_t name_width = std::string("metric").size(), needs_width = std::string("needs").size();
  for (const MetricInfo& info : metrics) {
    name_width = std::max(name_width, info.name.size());
    needs_width = std::max(needs_width, needs(info).size());
  }
  const int name_column = static_cast<int>(name_width + 2);
  const int needs_column = static_cast<int>(needs_width + 2);
  std::cout << std::left << std::setw(name_column) << "metric" << std::setw(needs_column) << "needs"
            << "summary\n";
  for (const MetricInfo& info : metrics) {
    std::cout << std::left << std::setw(name_column) << info.name << std::setw(needs_column)
              << needs(info) << info.summary << (info.higher_is_better ? "" : " (lower is better)")
              << "\n";
  }
}

void ScoreAgainstReference(const ScoreArgs& args) {
  if (args.images.empty()) throw Error("score: give at least one image to score");
  const bool has_ref = !args.ref.empty();
  const bool has_orig = !args.original.empty();
  const std::string default_list = has_ref ? "ssim,psnr" : "cnr";
  const std::vector<std::string> metrics =
      ParseMetricList(args.metrics.empty() ? default_list : args.metrics, has_ref, has_orig);
  MetricImage ref, orig;
  if (has_ref) ref = LoadMetricImage(args.ref);
  if (has_orig) orig = LoadMetricImage(args.original);
  CheckSideImage(metrics, true, args.ref, ref.pixels);
  CheckSideImage(metrics, false, args.original, orig.pixels);
  // Encodings as recorded (--sidecar for the scored images, else beside each file): the metrics
  // compare stored values, so differently coded images get a warning.
  std::optional<KnownEncoding> given;
  if (!args.sidecar.empty()) {
    const nlohmann::json j = ReadJsonFile(args.sidecar);
    const std::optional<std::string> name = SidecarEncoding(j);
    if (!name) throw Error(args.sidecar, "not a turbid render sidecar (no encoding recorded)");
    given = KnownEncoding{*name, args.sidecar};
  }
  const std::optional<KnownEncoding> ref_encoding =
      has_ref ? EncodingBeside(args.ref) : std::nullopt;
  std::vector<ScoreRow> rows;
  for (const std::string& path : args.images) {
    WarnOnEncodingMismatch("score", path, given ? given : EncodingBeside(path),
                           "the reference " + args.ref, ref_encoding);
    MetricImage img = LoadMetricImage(path);
    MetricImage r = ref, o = orig;  // shallow copies; rescaled only when depths differ
    MetricInputs in;
    in.data_range = CommonScale({&r, &img, &o});
    in.reference = r.pixels;
    in.image = img.pixels;
    in.original = o.pixels;
    ScoreRow row;
    row.label = path;
    try {
      row.values = WithFileContext(path, "scoring it", [&] { return ComputeMetrics(metrics, in); });
    } catch (const Error& e) {
      const std::string message = e.what();
      throw message.rfind(path + ": ", 0) == 0 ? e : Error(path, message);
    }
    rows.push_back(row);
  }
  nlohmann::json header = {
      {"reference", has_ref ? nlohmann::json(args.ref) : nlohmann::json()},
      {"original", has_orig ? nlohmann::json(args.original) : nlohmann::json()}};
  PrintRows(metrics, rows, ParseFormat(args.json, args.csv), header, std::cout);
}

// A manifest's columns: given by flags, else found by their usual names.
struct ManifestColumns {
  std::string image, ref, orig, id;
  bool has_ref = false, has_orig = false;
};

ManifestColumns FindManifestColumns(const ScoreArgs& args, const std::vector<Record>& records) {
  std::vector<std::string> keys;
  for (const auto& [k, v] : records.front()) keys.push_back(k);
  const std::vector<std::string> image_names = {
      "enhanced",      "enhanced_path", "restored", "image",  "image_path",  "degraded",
      "degraded_path", "rendered",      "render",   "output", "output_path", "path"};
  const std::vector<std::string> ref_names = {
      "ground_truth", "ground_truth_path", "gt",  "gt_path", "clean", "clean_path", "clear",
      "reference",    "reference_path",    "ref", "truth"};
  const std::vector<std::string> degraded_names = {"original",      "original_path", "degraded",
                                                   "degraded_path", "rendered",      "render"};
  ManifestColumns c;
  c.image = args.image_column.empty() ? FindColumn(keys, image_names) : args.image_column;
  c.ref = args.ref_column.empty() ? FindColumn(keys, ref_names) : args.ref_column;
  c.orig = args.original_column;
  if (c.orig.empty()) {
    c.orig = FindColumn(keys, degraded_names);
    if (c.orig == c.image) c.orig.clear();  // scoring the degraded image itself
  }
  std::string known;
  for (const std::string& k : keys) known += (known.empty() ? "" : ", ") + k;
  if (c.image.empty() || !records.front().count(c.image))
    throw Error(args.manifest,
                "no image column found (columns: " + known + "; choose one with --image-column)");
  if (!args.ref_column.empty() && !records.front().count(c.ref))
    throw Error(args.manifest, "no column '" + c.ref + "' (columns: " + known + ")");
  c.id = FindColumn(keys, {"id", "name", "item", "sample"});
  c.has_ref = !c.ref.empty();
  c.has_orig = !c.orig.empty() && records.front().count(c.orig);
  return c;
}

// A generate manifest's "encoding" column codes its own image and ground_truth files; other
// files are looked up beside them.
std::optional<KnownEncoding> RecordEncoding(const Record& record, const std::string& col,
                                            const std::string& path, const std::string& manifest) {
  if (auto beside = EncodingBeside(path)) return beside;
  auto it = record.find("encoding");
  if ((col == "image" || col == "ground_truth") && it != record.end() &&
      (it->second == "srgb" || it->second == "linear"))
    return KnownEncoding{it->second, manifest};
  return std::nullopt;
}

// One manifest row (on line `line`) scored; differently coded image and reference warn once
// (counted in `mismatches`).
ScoreRow ScoreManifestRow(const ScoreArgs& args, const ManifestColumns& c,
                          const std::vector<std::string>& metrics, const Record& record, int line,
                          int* mismatches) {
  auto get = [&](const std::string& col) {
    auto it = record.find(col);
    const std::string value = it == record.end() ? std::string() : it->second;
    // An empty path would name the manifest's folder (or no reference at all).
    if (value.empty())
      throw Error(args.manifest, "line " + std::to_string(line) + ": empty '" + col + "'");
    return value;
  };
  const std::string image_path = ResolvePath(args.manifest, get(c.image));
  if (c.has_ref) {
    const std::string ref_path = ResolvePath(args.manifest, get(c.ref));
    const auto a = RecordEncoding(record, c.image, image_path, args.manifest);
    const auto b = RecordEncoding(record, c.ref, ref_path, args.manifest);
    if (a && b && a->name != b->name && (*mismatches)++ == 0)
      WarnOnEncodingMismatch("score", image_path, a, "its reference " + ref_path, b);
  }
  MetricImage img = LoadMetricImage(image_path), ref, orig;
  ScoreRow row;
  row.label = c.id.empty() ? get(c.image) : record.at(c.id);
  if (!c.id.empty()) row.extra["path"] = get(c.image);
  if (c.has_ref) {
    const std::string ref_path = ResolvePath(args.manifest, get(c.ref));
    ref = LoadMetricImage(ref_path);
    CheckSideImage(metrics, true, ref_path, ref.pixels);
    row.extra["reference"] = get(c.ref);
  }
  if (c.has_orig) {
    const std::string orig_path = ResolvePath(args.manifest, get(c.orig));
    orig = LoadMetricImage(orig_path);
    CheckSideImage(metrics, false, orig_path, orig.pixels);
    row.extra["original"] = get(c.orig);
  }
  MetricInputs in;
  in.data_range = CommonScale({&ref, &img, &orig});
  in.reference = ref.pixels;
  in.image = img.pixels;
  in.original = orig.pixels;
  try {
    row.values =
        WithFileContext(image_path, "scoring it", [&] { return ComputeMetrics(metrics, in); });
  } catch (const Error& e) {
    const std::string message = e.what();
    throw message.rfind(image_path + ": ", 0) == 0 ? e : Error(image_path, message);
  }
  return row;
}

void ScoreManifest(const ScoreArgs& args) {
  std::vector<int> lines;
  const std::vector<Record> records = ReadManifest(args.manifest, &lines);
  if (records.empty()) throw Error(args.manifest, "manifest has no rows");
  const ManifestColumns c = FindManifestColumns(args, records);
  const std::string default_list = c.has_ref ? "ssim,psnr" : "cnr";
  const std::vector<std::string> metrics =
      ParseMetricList(args.metrics.empty() ? default_list : args.metrics, c.has_ref, c.has_orig);
  int mismatches = 0;
  std::vector<ScoreRow> rows;
  for (size_t k = 0; k < records.size(); ++k) {
    rows.push_back(ScoreManifestRow(args, c, metrics, records[k], lines[k], &mismatches));
  }
  if (mismatches > 1)
    std::cerr << "score: warning: " << mismatches
              << " rows compare differently coded image and reference\n";
  nlohmann::json header = {{"manifest", args.manifest},
                           {"image_column", c.image},
                           {"reference_column", c.ref},
                           {"original_column", c.has_orig ? c.orig : std::string()}};
  PrintRows(metrics, rows, ParseFormat(args.json, args.csv), header, std::cout);
}

// What scoring a results folder shares between its items.
struct ResultsScoring {
  std::string gt_column;  // the manifest column of the ground truth
  std::string name;       // the scored method's name
  std::vector<nlohmann::json> levels;
  std::vector<std::string> metric_names, reference_only;
};

// The checks of --results's arguments and the manifest's columns, in order; returns the ground
// truth's column.
std::string CheckResultsArgs(const ScoreArgs& args, const std::vector<Record>& records) {
  if (records.empty()) throw Error(args.manifest, "manifest has no rows");
  if (!fs::is_directory(args.results)) throw Error(args.results, "not a folder");
  const std::string gt_column = args.ground_truth == "lit" ? "lit" : "ground_truth";
  if (args.ground_truth != "clean" && args.ground_truth != "lit") {
    throw Error("--ground-truth must be clean or lit, not '" + args.ground_truth + "'");
  }
  if (args.encoding != "srgb" && args.encoding != "linear") {
    throw Error("--encoding must be srgb or linear, not '" + args.encoding + "'");
  }
  for (const std::string& column :
       {std::string("id"), std::string("image"), gt_column, args.level}) {
    if (!records.front().count(column)) {
      throw Error(args.manifest, "no column '" + column +
                                     "' (a manifest.csv or manifest.jsonl of `turbid generate`)");
    }
  }
  return gt_column;
}

// --name, else the results folder's name; 1-64 characters of [A-Za-z0-9_-], not 'none'.
std::string ResultsName(const ScoreArgs& args) {
  std::string name = args.name;
  if (name.empty()) name = fs::path(args.results).lexically_normal().filename().string();
  if (name.empty())
    name = fs::path(args.results).lexically_normal().parent_path().filename().string();
  const bool safe = !name.empty() && name.size() <= 64 && name != "none" &&
                    name.find_first_not_of(
                        "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                        "0123456789_-") == std::string::npos;
  if (!safe) {
    throw Error("--name '" + name + "': need 1-64 characters of [A-Za-z0-9_-], not 'none'");
  }
  return name;
}

// The sweep a results folder stands for: methods `none` and NAME, one grid axis (the level
// column, its values in order of appearance); fills the levels and metric names of `s`.
Experiment ResultsExperiment(const ScoreArgs& args, const std::vector<Record>& records,
                             ResultsScoring* s) {
  Experiment e;
  e.name = s->name;
  e.description = "results folder " + args.results + " scored against the dataset " +
                  args.manifest + " (`turbid score --results`)";
  e.source_path = args.manifest;
  for (const std::string& metric :
       ParseMetricList(args.metrics.empty() ? "ssim,psnr" : args.metrics, true, true)) {
    const MetricInfo& info = FindMetric(metric);
    e.metrics.push_back(
        {info.name, info.higher_is_better, info.needs_reference, info.needs_original});
  }
  ExperimentMethod identity, scored;
  identity.name = identity.label = "none";
  scored.name = scored.label = s->name;
  e.methods = {identity, scored};
  e.best_excludes = {"none"};
  e.ground_truth = args.ground_truth;
  e.score_domain = ScoreDomain::kEncoded;  // the files' values as written (integer codes)
  e.thumbnail_width = 0;
  e.level_path = args.level;
  e.listed_items = static_cast<int>(records.size());
  std::set<std::string> seen;
  for (const Record& record : records) {
    if (seen.insert(record.at(args.level)).second) s->levels.push_back(record.at(args.level));
  }
  e.grid.emplace_back(args.level, s->levels);
  e.scenes.push_back({"", "", "dataset", 1.0, {}, 0});
  for (const HarnessMetricInfo& m : e.metrics) {
    s->metric_names.push_back(m.name);
    if (!m.needs_reference && !m.needs_original) s->reference_only.push_back(m.name);
  }
  return e;
}

// Item K of the manifest: its identity, then both methods' metrics. A missing or unreadable
// results file is the item's error; an unreadable dataset file throws.
void ScoreResultItem(const ScoreArgs& args, const ResultsScoring& s, const Record& record, size_t k,
                     ItemResult& item) {
  item.index = static_cast<int>(k);
  item.id = record.at("id");
  const size_t underscore = item.id.rfind('_');
  item.scene = underscore == std::string::npos ? item.id : item.id.substr(0, underscore);
  item.level = record.at(args.level);
  item.condition = static_cast<int>(
      std::find(s.levels.begin(), s.levels.end(), nlohmann::json(item.level)) - s.levels.begin());
  item.level_value = ParseValueOr(item.level, item.condition);
  item.params = {{args.level, item.level}};
  const cv::Mat degraded = ReadImage(ResolvePath(args.manifest, record.at("image")));
  cv::Mat reference = ReadImage(ResolvePath(args.manifest, record.at(s.gt_column)));
  if (args.ground_truth == "lit") cv::min(cv::max(reference, 0.0), 1.0, reference);
  item.width = degraded.cols;
  item.height = degraded.rows;
  if (!s.reference_only.empty()) {
    MetricInputs inputs;
    inputs.image = reference;
    item.reference_metrics = ComputeMetrics(s.reference_only, inputs);
  }
  MetricInputs inputs;
  inputs.reference = reference;
  inputs.original = degraded;
  inputs.image = degraded;
  std::map<std::string, double> nan_metrics;
  for (const std::string& m : s.metric_names) nan_metrics[m] = std::nan("");
  MethodResult none{"none", ComputeMetrics(s.metric_names, inputs), "", std::nan("")};
  MethodResult row{s.name, nan_metrics, "", std::nan("")};
  try {
    const std::string path = FindOutputFile(args.results, item.id);
    if (path.empty()) throw Error("missing results file " + item.id + ".*");
    inputs.image = ReadMethodOutput(path, args.encoding, degraded);
    row.metrics = ComputeMetrics(s.metric_names, inputs);
  } catch (const std::exception& error) {
    row.error = error.what();
  }
  item.methods = {none, row};
}

// Every item, on --threads threads; the first dataset failure is thrown after all have joined.
std::vector<ItemResult> ScoreResultItems(const ScoreArgs& args, const ResultsScoring& s,
                                         const std::vector<Record>& records) {
  std::vector<ItemResult> items(records.size());
  std::atomic<size_t> next{0};
  std::mutex error_mutex;
  std::string first_error;
  const auto work = [&] {
    for (size_t k = next++; k < records.size(); k = next++) {
      try {
        ScoreResultItem(args, s, records[k], k, items[k]);
      } catch (const std::exception& error) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (first_error.empty()) first_error = items[k].id + ": " + error.what();
      }
    }
  };
  const int threads = std::max(
      1, std::min<int>(args.threads > 0 ? args.threads
                                        : static_cast<int>(std::thread::hardware_concurrency()),
                       static_cast<int>(records.size())));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work);
  for (std::thread& thread : pool) thread.join();
  if (!first_error.empty()) throw Error(args.manifest, first_error);
  return items;
}

// A results folder against a generate dataset: the enhanced image of item ID is RESULTS/ID.<ext>.
// Writes a sweep's tables (items.csv, items.jsonl, summary.md, summary.csv) with two methods:
// `none` (the degraded input as it is) and NAME (the results).
void ScoreResults(const ScoreArgs& args) {
  const std::vector<Record> records = ReadManifest(args.manifest);
  ResultsScoring s;
  s.gt_column = CheckResultsArgs(args, records);
  s.name = ResultsName(args);
  const std::string& name = s.name;
  const std::string out =
      args.out.empty() ? (fs::path(args.results) / "turbid-score").string() : args.out;
  const Experiment e = ResultsExperiment(args, records, &s);
  std::set<std::string> ids;
  for (const Record& record : records) {
    if (!ids.insert(record.at("id")).second) {
      throw Error(args.manifest, "item id '" + record.at("id") + "' appears twice");
    }
  }
  const std::vector<ItemResult> items = ScoreResultItems(args, s, records);

  // Files in RESULTS that belong to no item (a typo in the names shows here).
  int unmatched = 0;
  for (const auto& entry : fs::directory_iterator(args.results)) {
    if (entry.is_regular_file() && !ids.count(entry.path().stem().string())) ++unmatched;
  }
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw Error(out, "cannot create the output folder: " + ec.message());
  WriteTables(e, items, out, /*with_timings=*/false);
  int failed = 0;
  for (const ItemResult& item : items) failed += !item.methods[1].error.empty();
  std::cout << "score: " << items.size() << " items of " << args.manifest << ", " << name
            << " from " << args.results << ": " << (items.size() - failed) << " scored, " << failed
            << " failed or missing (see the error column of items.csv)";
  if (unmatched > 0) std::cout << "; " << unmatched << " files in the folder match no item";
  std::cout << "\ntables: " << out << "/summary.md, " << out << "/summary.csv, " << out
            << "/items.csv\n";
}

// Pairs file: one pair per line, "A,B" or "A B"; '#' comments; an optional header line whose
// first field is a non-file word like "a", "first", "image_a".
std::vector<std::pair<std::string, std::string>> ReadPairs(const std::string& path) {
  CheckInputFile(path);
  std::ifstream in(path);
  if (!in) throw Error(path, "cannot open pairs file");
  std::vector<std::pair<std::string, std::string>> pairs;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos || line[0] == '#') continue;
    std::vector<std::string> fields =
        line.find(',') != std::string::npos ? SplitCsvLine(line) : std::vector<std::string>{};
    if (fields.empty()) {
      std::istringstream words(line);
      for (std::string w; words >> w;) fields.push_back(w);
    }
    if (fields.size() < 2) throw Error(path, "line " + std::to_string(number) + ": need two paths");
    const std::string first = Lower(fields[0]);
    if (pairs.empty() && (first == "a" || first == "first" || first == "image_a" ||
                          first == "left" || first == "source" || first == "query"))
      continue;
    pairs.emplace_back(ResolvePath(path, fields[0]), ResolvePath(path, fields[1]));
  }
  if (pairs.empty()) throw Error(path, "no image pairs");
  return pairs;
}

void ScorePairs(const ScoreArgs& args) {
  const auto pairs = ReadPairs(args.pairs);
  std::vector<FeatureDetector> detectors;
  if (args.detector == "all")
    detectors = {FeatureDetector::kOrb, FeatureDetector::kAkaze, FeatureDetector::kSift};
  else
    detectors = {ParseFeatureDetector(args.detector)};
  std::vector<MatchBatchResult> batches;
  for (FeatureDetector d : detectors) {
    FeatureMatchOptions options;
    options.detector = d;
    std::vector<PairMatchResult> results;
    for (const auto& [a, b] : pairs) {
      const MetricImage ia = LoadMetricImage(a), ib = LoadMetricImage(b);
      // Checked here to name the file (MatchFeatures would say "first image").
      CheckFeatureImageSize(d, ia.pixels, a);
      CheckFeatureImageSize(d, ib.pixels, b);
      try {
        // Each image is converted with its own data range: pairs need not share a bit depth.
        cv::Mat a01, b01;
        ia.pixels.convertTo(a01, CV_32F, 1.0 / ia.data_range);
        ib.pixels.convertTo(b01, CV_32F, 1.0 / ib.data_range);
        results.push_back(WithFileContext(a + " / " + b, "matching features",
                                          [&] { return MatchFeatures(options, a01, b01, 1.0); }));
      } catch (const Error& e) {
        throw Error(a + " / " + b, e.what());
      }
    }
    batches.push_back(SummarizeMatches(options, results));
  }
  const Format format = ParseFormat(args.json, args.csv);
  if (format == Format::kJson) {
    nlohmann::json doc = {{"pairs_file", args.pairs}, {"detectors", nlohmann::json::array()}};
    for (size_t k = 0; k < batches.size(); ++k) {
      nlohmann::json j = batches[k].ToJson();
      for (size_t i = 0; i < pairs.size(); ++i) {
        j["pairs_detail"][i]["a"] = pairs[i].first;
        j["pairs_detail"][i]["b"] = pairs[i].second;
      }
      doc["detectors"].push_back(j);
    }
    std::cout << doc.dump(2) << "\n";
    return;
  }
  if (format == Format::kCsv) {
    std::cout << "detector,a,b,keypoints_a,keypoints_b,correspondences,inliers,active\n";
    for (const MatchBatchResult& batch : batches)
      for (size_t i = 0; i < pairs.size(); ++i) {
        const PairMatchResult& p = batch.per_pair[i];
        std::cout << batch.detector << "," << CsvField(pairs[i].first) << ","
                  << CsvField(pairs[i].second) << "," << p.keypoints_a << "," << p.keypoints_b
                  << "," << p.correspondences << "," << p.inliers << "," << (p.active ? 1 : 0)
                  << "\n";
      }
    return;
  }
  std::cout << std::left << std::setw(10) << "detector" << std::right << std::setw(8) << "pairs"
            << std::setw(13) << "active_sets" << std::setw(18) << "mean_corresp." << std::setw(14)
            << "mean_inliers"
            << "\n";
  for (const MatchBatchResult& b : batches)
    std::cout << std::left << std::setw(10) << b.detector << std::right << std::setw(8) << b.pairs
              << std::setw(13) << b.active_sets << std::setw(18) << std::fixed
              << std::setprecision(2) << b.mean_correspondences << std::setw(14) << b.mean_inliers
              << "\n";
}

}  // namespace

void AddScoreCommand(CLI::App& app) {
  auto args = std::make_shared<ScoreArgs>();
  CLI::App* cmd = app.add_subcommand(
      "score", "score images against a reference (or without one), a generate manifest, or pairs");
  PathOption(cmd->add_option("images", args->images, "images to score (PNG/JPEG/TIFF/EXR/PFM)"));
  PathOption(cmd->add_option("--ref", args->ref, "ground-truth image for full-reference metrics"));
  PathOption(cmd->add_option("--original", args->original,
                             "degraded input the restoration started from (visible-edge metrics)"));
  cmd->add_option(
      "--metrics", args->metrics,
      "comma-separated metric names or 'all' (default: ssim,psnr with --ref, else cnr)");
  PathOption(cmd->add_option(
      "--manifest", args->manifest,
      "batch: manifest.csv / .jsonl from `turbid generate` (paths relative to it)"));
  cmd->add_option("--image-column", args->image_column, "manifest column of the image to score");
  cmd->add_option("--ref-column", args->ref_column, "manifest column of the ground truth");
  cmd->add_option("--original-column", args->original_column,
                  "manifest column of the original degraded image");
  PathOption(cmd->add_option(
      "--results", args->results,
      "with --manifest: a folder of enhanced images named by item id, scored against "
      "the dataset into a sweep's tables"));
  cmd->add_option("--name", args->name,
                  "with --results: the method's name (default: the folder's)");
  PathOption(cmd->add_option(
      "--out", args->out, "with --results: folder for the tables (default: RESULTS/turbid-score)"));
  cmd->add_option("--level", args->level,
                  "with --results: manifest column that is the tables' level (default beta_gray)");
  cmd->add_option("--encoding", args->encoding,
                  "with --results: srgb | linear; srgb decodes the result files (only them) "
                  "to linear. Default linear: results, ground truth and inputs are all scored "
                  "on their stored codes, as score --manifest does");
  cmd->add_option("--ground-truth", args->ground_truth,
                  "with --results: clean (rho, default) | lit (J, clipped to [0, 1])");
  InRange(
      cmd->add_option("--threads", args->threads, "with --results: worker threads (0 = all cores)"),
      0, 1024);
  PathOption(cmd->add_option("--pairs", args->pairs,
                             "feature matching over a file of image pairs (one 'A,B' per line)"));
  cmd->add_option("--detector", args->detector, "orb | akaze | sift | all (with --pairs)");
  PathOption(cmd->add_option("--sidecar", args->sidecar,
                             "the render sidecar of the scored images (their encoding; default: "
                             "OUT.json beside each image)"));
  cmd->add_flag("--json", args->json, "JSON on stdout");
  cmd->add_flag("--csv", args->csv, "CSV on stdout");
  cmd->add_flag("--list", args->list, "list the metrics and exit");
  cmd->callback([args]() {
    if (args->list) return ListMetricsCommand();
    if (!args->results.empty() && args->manifest.empty())
      throw Error("score: --results needs --manifest DIR/manifest.csv (the dataset)");
    const int modes = (!args->manifest.empty()) + (!args->pairs.empty()) + (!args->images.empty());
    if (modes != 1)
      throw Error(
          "score: give images (with --ref / --original), or --manifest FILE, or --pairs FILE");
    if (!args->results.empty()) return ScoreResults(*args);
    if (!args->manifest.empty()) return ScoreManifest(*args);
    if (!args->pairs.empty()) return ScorePairs(*args);
    ScoreAgainstReference(*args);
  });
  cmd->footer("Example: turbid score sea.png sea_dcp.png");
}

}  // namespace turbid
