// Internals of `turbid report` shared by report.cc (the page), report_tables.cc (result and run
// time tables), report_plots.cc (gnuplot) and report_images.cc (image grid and viewer). Not a
// public interface: docs/report.md describes the page.
#pragma once

#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "tools/harness/experiment.h"
#include "tools/harness/report.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace turbid::report {

std::string Html(const std::string& text);  // escaped for element text and quoted attributes
// A relative path as a URL path: bytes outside [A-Za-z0-9._~/-] percent-encoded.
std::string UrlPath(const std::string& relative);
// True when `path` (a file below `root`) is a regular file and neither it nor any folder between
// `root` and it is a symbolic link.
bool IsPlainFileBelow(const std::string& root, const std::string& path);

// The methods' groups, in the order tables and plots show them: the reference rows (privileged
// methods, the identity `none`), the paper's methods (enhancer/paper), the built-in baselines,
// and external methods ("your methods").
enum class MethodGroup { kReference, kPaper, kBaseline, kYours };
constexpr int kMethodGroups = 4;
const char* GroupName(MethodGroup group);
MethodGroup GroupOf(const ExperimentMethod& method);

// What the tables, plots and the page share.
struct ReportData {
  std::string dir;         // the sweep's folder
  std::string report_dir;  // DIR/report
  std::string href_root;   // DIR relative to the page's folder, "" or ending in '/'
  const SweepDir* sweep = nullptr;
  std::vector<std::string> levels;
  std::string axis;  // the level path, a named axis ("@turbidity") shown without its "@"
  std::map<std::string, double> level_x;
  bool numeric_levels = true;
  std::vector<SummaryCell> cells;  // Summarize(): levels, then "all"
  std::map<std::tuple<std::string, std::string, std::string>, const SummaryCell*> lookup;
  std::vector<bool> excluded;                 // per method: never marked best (best_excludes)
  std::vector<MethodGroup> groups;            // per method
  std::vector<std::vector<size_t>> by_group;  // method indices per group (kMethodGroups lists)
  const SummaryCell* Cell(const std::string& level, const std::string& method,
                          const std::string& metric) const;
};
ReportData MakeReportData(const std::string& dir, const std::string& report_dir,
                          const std::string& html_path, const SweepDir& sweep);

// "ssim (↑ better)", "psnr, dB (↑ better)": a metric's axis or column title.
std::string MetricTitle(const HarnessMetricInfo& metric);
std::string MethodName(const ExperimentMethod& method);  // the label, with † when privileged

// Tables (report_tables.cc): results over all levels (methods x metrics), each metric by level
// (methods x levels; false when there is one level) and run times (methods x image sizes).
void WriteResultTables(std::ostringstream& html, const ReportData& data);
bool WriteLevelTables(std::ostringstream& html, const ReportData& data);
void WriteTimeTable(std::ostringstream& html, const ReportData& data);

// Plots (report_plots.cc). Each is an SVG file in DIR/report/ with its gnuplot script and data.
struct Plot {
  std::string caption;
  std::string file;   // the SVG's name in DIR/report/
  std::string aside;  // HTML shown beside the plot (the scatter's key table), may be empty
  int width = 0, height = 0;
};
struct PlotResult {
  std::vector<Plot> plots;
  std::string warning;
};
PlotResult MakePlots(const ReportData& data, const std::string& gnuplot);

// Image grid and viewer (report_images.cc); returns the images linked.
int WriteImageSection(std::ostringstream& html, const ReportData& data, int max_rows);
// The page's one script: the viewer and the self-check the browser test reads.
std::string PageScript();
std::string PageStyle();

}  // namespace turbid::report
