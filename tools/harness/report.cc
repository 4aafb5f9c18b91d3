#include "tools/harness/report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "enhancer/method.h"
#include "enhancer/paper/entries.h"
#include "tools/harness/protocol.h"
#include "tools/harness/report_internal.h"
#include "tools/harness/statistics.h"

namespace turbid {
namespace report {

namespace fs = std::filesystem;

std::string Html(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string UrlPath(const std::string& relative) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (char c : relative) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '.' || c == '_' || c == '~' || c == '/' || c == '-') {
      out += c;
    } else {
      out += '%';
      out += kHex[u >> 4];
      out += kHex[u & 15];
    }
  }
  return out;
}

namespace {

// Inline formatting of summary.md cells: **bold** -> <b>, the rest escaped.
std::string InlineMarkdown(const std::string& text) {
  std::string out;
  size_t pos = 0;
  bool bold = false;
  while (pos < text.size()) {
    const size_t star = text.find("**", pos);
    const std::string chunk =
        text.substr(pos, star == std::string::npos ? std::string::npos : star - pos);
    std::string escaped = Html(chunk);
    // `code` spans.
    std::string coded;
    bool in_code = false;
    for (char c : escaped) {
      if (c == '`') {
        coded += in_code ? "</code>" : "<code>";
        in_code = !in_code;
      } else {
        coded += c;
      }
    }
    out += coded;
    if (star == std::string::npos) break;
    out += bold ? "</b>" : "<b>";
    bold = !bold;
    pos = star + 2;
  }
  if (bold) out += "</b>";
  return out;
}

// The subset of Markdown that the protocol section uses: headings, paragraphs, lists, tables.
std::string MarkdownToHtml(const std::string& markdown, int heading_offset) {
  std::ostringstream out;
  std::istringstream in(markdown);
  std::string line;
  bool in_table = false, header_row = false, in_list = false;
  const auto cells = [](const std::string& row) {
    std::vector<std::string> parts;
    size_t start = 1;
    while (start < row.size()) {
      const size_t bar = row.find('|', start);
      if (bar == std::string::npos) break;
      std::string cell = row.substr(start, bar - start);
      const size_t first = cell.find_first_not_of(' ');
      const size_t last = cell.find_last_not_of(' ');
      parts.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
      start = bar + 1;
    }
    return parts;
  };
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '|') {
      if (line.rfind("|---", 0) == 0) continue;
      if (!in_table) {
        out << "<table>\n";
        in_table = header_row = true;
      }
      out << "<tr>";
      for (const std::string& cell : cells(line)) {
        out << (header_row ? "<th>" : "<td>") << InlineMarkdown(cell)
            << (header_row ? "</th>" : "</td>");
      }
      out << "</tr>\n";
      header_row = false;
      continue;
    }
    if (in_table) {
      out << "</table>\n";
      in_table = false;
    }
    if (line.rfind("- ", 0) == 0) {
      out << (in_list ? "" : "<ul>\n") << "<li>" << InlineMarkdown(line.substr(2)) << "</li>\n";
      in_list = true;
      continue;
    }
    if (in_list) out << "</ul>\n";
    in_list = false;
    if (line.empty()) continue;
    size_t level = 0;
    while (level < line.size() && line[level] == '#') ++level;
    if (level > 0 && level < line.size() && line[level] == ' ') {
      const int h = std::min(6, static_cast<int>(level) + heading_offset);
      out << "<h" << h << ">" << InlineMarkdown(line.substr(level + 1)) << "</h" << h << ">\n";
    } else {
      out << "<p>" << InlineMarkdown(line) << "</p>\n";
    }
  }
  if (in_table) out << "</table>\n";
  if (in_list) out << "</ul>\n";
  return out.str();
}

}  // namespace

// True when `path` (a file below `root`) is a regular file and neither it nor any folder between
// `root` and it is a symbolic link.
bool IsPlainFileBelow(const std::string& root, const std::string& path) {
  const fs::path base = fs::path(root).lexically_normal();
  const fs::path relative = fs::path(path).lexically_normal().lexically_relative(base);
  if (relative.empty() || *relative.begin() == "..") return false;
  fs::path at = base;
  std::error_code ec;
  for (const fs::path& part : relative) {
    at /= part;
    const fs::file_status status = fs::symlink_status(at, ec);
    if (ec || fs::is_symlink(status)) return false;
  }
  return fs::is_regular_file(fs::symlink_status(at, ec)) && !ec;
}

}  // namespace report

bool ReportOptions::Check(std::string* why) const {
  if (max_grid_rows < 0) {
    *why = "max_grid_rows must be >= 0";
    return false;
  }
  return true;
}

std::string Base64(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (static_cast<uint8_t>(bytes[i]) << 16) |
                       (static_cast<uint8_t>(bytes[i + 1]) << 8) |
                       static_cast<uint8_t>(bytes[i + 2]);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = static_cast<uint8_t>(bytes[i]) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const uint32_t v =
        (static_cast<uint8_t>(bytes[i]) << 16) | (static_cast<uint8_t>(bytes[i + 1]) << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

namespace report {

const char* GroupName(MethodGroup group) {
  switch (group) {
    case MethodGroup::kReference:
      return "reference (privileged † or identity)";
    case MethodGroup::kPaper:
      return "paper";
    case MethodGroup::kBaseline:
      return "baselines";
    case MethodGroup::kYours:
      return "your methods (external)";
  }
  return "";
}

MethodGroup GroupOf(const ExperimentMethod& method) {
  if (method.privileged || method.name == "none") return MethodGroup::kReference;
  if (method.IsExternal()) return MethodGroup::kYours;
  static const std::vector<std::string> paper = [] {
    std::vector<std::string> names;
    for (const MethodEntry& entry : PaperMethodEntries()) names.push_back(entry.info.name);
    return names;
  }();
  return std::find(paper.begin(), paper.end(), method.name) != paper.end() ? MethodGroup::kPaper
                                                                           : MethodGroup::kBaseline;
}

std::string MethodName(const ExperimentMethod& method) {
  return method.privileged ? method.label + " †" : method.label;
}

std::string MetricTitle(const HarnessMetricInfo& metric) {
  const std::string unit = metric.name == "psnr" ? ", dB" : "";
  return metric.name + unit + (metric.higher_is_better ? " (↑ better)" : " (↓ better)");
}

const SummaryCell* ReportData::Cell(const std::string& level, const std::string& method,
                                    const std::string& metric) const {
  const auto it = lookup.find({level, method, metric});
  return it == lookup.end() ? nullptr : it->second;
}

ReportData MakeReportData(const std::string& dir, const std::string& report_dir,
                          const std::string& html_path, const SweepDir& sweep) {
  const Experiment& e = sweep.experiment;
  ReportData d;
  d.dir = fs::path(dir).lexically_normal().string();
  if (!d.dir.empty() && d.dir.back() == '/' && d.dir.size() > 1) d.dir.pop_back();
  d.report_dir = report_dir;
  std::error_code ec;
  const fs::path page_dir = fs::absolute(fs::path(html_path), ec).parent_path();
  const fs::path root = fs::absolute(fs::path(dir), ec).lexically_normal();
  const std::string relative = root.lexically_relative(page_dir.lexically_normal()).string();
  d.href_root = relative.empty() || relative == "." ? "" : relative + "/";
  d.sweep = &sweep;
  d.levels = LevelLabels(e);
  d.axis = e.level_path.rfind('@', 0) == 0 ? e.level_path.substr(1) : e.level_path;
  for (const ItemResult& item : sweep.items) d.level_x[item.level] = item.level_value;
  for (const std::string& level : d.levels) {
    d.numeric_levels &= d.level_x.count(level) && d.level_x[level] == std::atof(level.c_str()) &&
                        level.find_first_not_of("0123456789.eE+-") == std::string::npos;
  }
  d.cells = Summarize(e, sweep.items);
  for (const SummaryCell& cell : d.cells) d.lookup[{cell.level, cell.method, cell.metric}] = &cell;
  d.by_group.resize(kMethodGroups);
  for (size_t m = 0; m < e.methods.size(); ++m) {
    // As summary.md: the methods of best_excludes are never marked best.
    d.excluded.push_back(std::find(e.best_excludes.begin(), e.best_excludes.end(),
                                   e.methods[m].label) != e.best_excludes.end());
    d.groups.push_back(GroupOf(e.methods[m]));
    d.by_group[static_cast<size_t>(d.groups.back())].push_back(m);
  }
  return d;
}

namespace {

// The page's head, its one title and the one paragraph that says what was run.
void WritePageHead(std::ostringstream& html, const SweepDir& sweep, const std::string& warning) {
  const Experiment& e = sweep.experiment;
  html << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>"
       << Html(e.name) << " — turbid sweep report</title>\n<style>\n"
       << PageStyle() << "</style>\n</head>\n<body>\n";
  html << "<h1>" << Html(e.name) << "</h1>\n";
  if (!e.description.empty()) html << "<p>" << InlineMarkdown(e.description) << "</p>\n";
  html << "<p>" << sweep.items.size() << " of " << e.ItemCount() << " items (" << e.scenes.size()
       << " scenes × " << e.ConditionCount() << " conditions), " << e.methods.size() << " methods, "
       << e.metrics.size()
       << " metrics. Ground truth: " << (e.ground_truth == "lit" ? "lit J" : "clean ρ")
       << ". Level: <code>" << Html(e.level_path) << "</code>. Score domain: <b>"
       << ScoreDomainName(e.score_domain) << "</b> ("
       << (e.score_domain == ScoreDomain::kEncoded
               ? "full-reference metrics on the images as the camera writes them"
               : "full-reference metrics on linear-light images")
       << "; no-reference metrics on linear light).</p>\n"
       << "<nav><a href=\"#results\">results</a><a href=\"#plots\">plots</a><a href=\"#images\">"
          "images</a><a href=\"#by-level\">by level</a><a href=\"#times\">run time</a><a "
          "href=\"#protocol\">protocol</a></nav>\n";
  if (!warning.empty()) html << "<p class=\"warn\">" << Html(warning) << "</p>\n";
}

void WriteResultsSection(std::ostringstream& html, const ReportData& d) {
  const Experiment& e = d.sweep->experiment;
  html << "<h2 id=\"results\">Results</h2>\n<p class=\"legend\">Each cell: the mean over items, "
          "below it the 95 % percentile-bootstrap interval of that mean ("
       << kBootstrapResamples
       << " resamples, seeded). <b>Bold ▲</b>: the best of the column, which a two-sided "
          "Wilcoxon signed-rank test over the same items says beats the runner-up at 5 %; "
          "<u>underlined ≈</u>: the best and the runner-up, which the test does not tell apart "
          "(tied). ↑ higher is better, ↓ lower is better. Numbers have one format per metric "
          "(three significant digits of its largest value); “≈ 0” is a value that rounds to zero "
          "in it. The same numbers in full precision: summary.csv (summary.md).";
  if (!e.best_excludes.empty()) {
    html << " Never marked best:";
    for (const std::string& label : e.best_excludes) html << " " << Html(label);
    html << ".";
  }
  if (std::any_of(e.methods.begin(), e.methods.end(),
                  [](const ExperimentMethod& m) { return m.privileged; })) {
    html << " † privileged: receives true simulation parameters its published version does not "
            "have — a reference, not a competitor.";
  }
  html << "</p>\n";
  WriteResultTables(html, d);
}

void WritePlotsSection(std::ostringstream& html, const ReportData& d,
                       const std::vector<Plot>& plots) {
  html << "<h2 id=\"plots\">Plots</h2>\n<p>Each plot is an SVG file in <code>report/</code> "
          "with its gnuplot script (.gp) and data (.dat), to remake or restyle for a paper. "
          "Colours are Okabe–Ito's colour-blind-safe set; dash and point types tell lines "
          "apart in black and white.</p>\n";
  for (const Plot& plot : plots) {
    const std::string href = Html(UrlPath(d.href_root + "report/" + plot.file));
    html << "<div class=\"plotrow\"><figure class=\"plot\"><a href=\"" << href
         << "\"><img class=\"plot\" width=\"" << plot.width << "\" height=\"" << plot.height
         << "\" alt=\"" << Html(plot.caption) << "\" src=\"" << href << "\"></a><figcaption>"
         << Html(plot.caption) << " (<a href=\"" << href << "\">SVG</a>)</figcaption></figure>"
         << plot.aside << "</div>\n";
  }
  if (plots.empty()) html << "<p class=\"warn\">no plots</p>\n";
}

// The experiment as run, the list of files, and the page's one script.
void WritePageTail(std::ostringstream& html, const SweepDir& sweep) {
  html << "<h2 id=\"protocol\">Protocol</h2>\n"
       << MarkdownToHtml(ProtocolMarkdown(sweep.experiment), 1)
       << "<details><summary>The experiment as run (experiment.json)</summary><pre>"
       << Html(sweep.experiment_json.dump(2)) << "</pre></details>\n";
  html << "<p>Files: items.csv, items.jsonl, summary.md, summary.csv (identical bytes for any "
          "thread count and shard layout), timings.csv, timings.md; images in thumbs/; plot "
          "scripts, data and SVG in report/. Keep this page with its folder: it links them "
          "(nothing is fetched from a network).</p>\n";
  html << "<script>\n" << PageScript() << "</script>\n</body>\n</html>\n";
}

}  // namespace
}  // namespace report

ReportSummary WriteReport(const std::string& dir, const ReportOptions& options) {
  ThrowIfInvalid(options, "report");
  const SweepDir sweep = LoadSweepDir(dir);
  const Experiment& e = sweep.experiment;
  if (sweep.items.empty()) throw Error(dir, "no finished items to report on (run the sweep first)");
  namespace fs = std::filesystem;
  if (!fs::exists(dir + "/summary.md")) {
    WriteTables(e, sweep.items, dir);  // e.g. an interrupted sweep: tables of what is there
  }
  ReportSummary summary;
  summary.html_path = options.out_file.empty() ? dir + "/report.html" : options.out_file;
  const std::string report_dir = dir + "/report";
  std::error_code create_error;
  fs::create_directories(report_dir, create_error);
  if (create_error) throw OutputError(report_dir, "cannot create: " + create_error.message());

  const report::ReportData data = report::MakeReportData(dir, report_dir, summary.html_path, sweep);
  const report::PlotResult plots = report::MakePlots(data, options.gnuplot);
  summary.warning = plots.warning;

  std::ostringstream html;
  report::WritePageHead(html, sweep, summary.warning);
  report::WriteResultsSection(html, data);
  report::WritePlotsSection(html, data, plots.plots);
  summary.images = report::WriteImageSection(html, data, options.max_grid_rows);
  std::ostringstream by_level;
  if (report::WriteLevelTables(by_level, data)) {
    html << "<h2 id=\"by-level\">Results by " << report::Html(data.axis)
         << "</h2>\n<p>The tables above for each level; cells and marks as in Results.</p>\n"
         << by_level.str();
  }
  html << "<h2 id=\"times\">Run time</h2>\n<p>Wall time per image of each method alone on one "
          "sweep thread (ms, mean; below: standard deviation over items); not deterministic, so "
          "kept apart from the results (timings.csv, timings.md). <b>Bold ▲</b>: the fastest "
          "mean. (batch): a batch process's wall time divided by its items; (precomputed): "
          "results read from files, nothing ran.</p>\n";
  report::WriteTimeTable(html, data);
  report::WritePageTail(html, sweep);
  AtomicWriteText(summary.html_path, html.str(), true);
  summary.plots = static_cast<int>(plots.plots.size());
  return summary;
}

}  // namespace turbid
