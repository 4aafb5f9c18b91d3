// `turbid report`, `turbid merge` and `turbid regress` as functions of the extension module
// (common.h, DefineHarness): the library calls the CLI makes, results as JSON text for the
// Python half (turbid/__init__.py), messages in Python's words through the module's translator.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/input_file.h"
#include "python/src/common.h"
#include "tools/harness/harness_runner.h"
#include "tools/harness/report.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace turbid::pyext {
namespace {

namespace fs = std::filesystem;

std::string ReportDir(const std::string& dir, const std::string& out, const std::string& gnuplot) {
  ReportOptions options;
  options.out_file = out;
  options.gnuplot = gnuplot;
  ReportSummary s;
  {
    WorkScope release;
    s = WriteReport(dir, options);
  }
  return json({{"html", s.html_path},
               {"plots", s.plots},
               {"images", s.images},
               {"warning", s.warning}})
      .dump();
}

int Merge(const std::vector<std::string>& dirs, const std::string& out, bool allow_partial,
          bool force) {
  MergeOptions options;
  options.out_dir = out;
  options.allow_partial = allow_partial;
  options.force = force;
  WorkScope release;
  return MergeSweeps(dirs, options);
}

// As `turbid regress`: the results' table of the baseline's kind when `results` is a sweep
// folder, tolerances from the file beside the baseline unless given, directions from the sweep's
// experiment, else the registry. `tolerances`: metric -> (abs, rel).
std::string RegressTables(const std::string& baseline, const std::string& results_arg,
                          const std::map<std::string, std::pair<double, double>>& tolerances,
                          const std::string& tolerance_file_arg, bool strict) {
  WorkScope release;
  RegressOptions options;
  std::string tolerance_file = tolerance_file_arg;
  if (tolerance_file.empty()) {
    const fs::path beside = fs::path(baseline).replace_extension(".tolerances.json");
    if (fs::exists(beside)) tolerance_file = beside.string();
  }
  if (!tolerance_file.empty()) LoadTolerances(tolerance_file, &options);
  for (const auto& [metric, t] : tolerances) {
    if (!(t.first >= 0.0) || !(t.second >= 0.0) || std::isinf(t.first) || std::isinf(t.second))
      throw Error("tolerances: '" + metric + "' must be finite numbers >= 0");
    options.tolerances[metric] = Tolerance{t.first, t.second};
  }
  options.fail_on_improvement = strict;
  std::string results = results_arg;
  if (fs::is_directory(results)) {
    std::string header;
    CheckInputFile(baseline);
    std::ifstream in(baseline);
    std::getline(in, header);
    const bool summary = header.rfind("level,method,metric", 0) == 0 ||
                         (header.empty() && fs::path(baseline).filename().string().find(
                                                "summary") != std::string::npos);
    results += summary ? "/summary.csv" : "/items.csv";
    try {
      const SweepDir dir = LoadSweepDir(results_arg);
      for (const HarnessMetricInfo& m : dir.experiment.metrics)
        options.higher_is_better[m.name] = m.higher_is_better;
    } catch (const Error&) {
      // Not a sweep folder with a journal: the registry below.
    }
  }
  const HarnessCatalog catalog = RegistryCatalog();
  for (const RegressMove& move : Regress(baseline, results, options).moves) {
    if (options.higher_is_better.count(move.metric)) continue;
    try {
      options.higher_is_better[move.metric] = catalog.find_metric(move.metric).higher_is_better;
    } catch (const Error&) {
      // Unknown direction: any move counts as a regression.
    }
  }
  const RegressReport r = Regress(baseline, results, options);
  json moves = json::array();
  for (const RegressMove& m : r.moves)
    moves.push_back({{"key", m.key},
                     {"metric", m.metric},
                     {"baseline", m.baseline},
                     {"result", m.result},
                     {"regression", m.regression}});
  return json({{"failed", r.failed()},
               {"compared", r.compared},
               {"moves", moves},
               {"missing", r.missing},
               {"extra", r.extra},
               {"text", r.Format()},
               {"results", results}})
      .dump();
}

}  // namespace

void DefineHarness(py::module_& m) {
  m.def("report", &ReportDir, py::arg("dir"), py::arg("out"), py::arg("gnuplot"));
  m.def("merge", &Merge, py::arg("dirs"), py::arg("out"), py::arg("allow_partial"),
        py::arg("force"));
  m.def("regress", &RegressTables, py::arg("baseline"), py::arg("results"), py::arg("tolerances"),
        py::arg("tolerance_file"), py::arg("strict"));
}

}  // namespace turbid::pyext
