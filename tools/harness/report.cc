#include "tools/harness/report.h"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/input_file.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const std::string& path) {
  if (!InputFileProblem(path).empty()) return "";  // missing, or a FIFO / device planted there
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

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

std::string ShellQuote(const std::string& arg) {
  std::string quoted = "'";
  for (char c : arg) {
    if (c == '\'')
      quoted += "'\\''";
    else
      quoted += c;
  }
  return quoted + "'";
}

// A gnuplot string literal for any text: single-quoted, where gnuplot performs no backquote
// command substitution, no macro (@name) expansion and no backslash escapes; a quote is written
// twice. Control characters (a newline would end the command) become spaces. The terminal is
// `noenhanced`, so '@', '^', '_' and braces are shown as they are.
std::string GpString(const std::string& text) {
  std::string out = "'";
  for (char c : text) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (c == '\'')
      out += "''";
    else if (u < 0x20 || u == 0x7f)
      out += ' ';
    else
      out += c;
  }
  return out + "'";
}

// A label of `set xtics ("label" x, ...)`: gnuplot reads it as a format for the tic's value, so a
// '%' is written twice.
std::string GpTicLabel(const std::string& text) {
  std::string escaped;
  for (char c : text) escaped += c == '%' ? std::string("%%") : std::string(1, c);
  return GpString(escaped);
}

// Text for a comment line of a gnuplot data file: control characters become spaces.
std::string OneLine(std::string text) {
  for (char& c : text) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) c = ' ';
  }
  return text;
}

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

// The subset of Markdown that summary.md and timings.md use: headings, paragraphs, tables.
std::string MarkdownToHtml(const std::string& markdown, int heading_offset) {
  std::ostringstream out;
  std::istringstream in(markdown);
  std::string line;
  bool in_table = false, header_row = false;
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
  return out.str();
}

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

std::string DataUri(const std::string& path, const std::string& mime) {
  return "data:" + mime + ";base64," + Base64(ReadAll(path));
}

// Runs gnuplot in DIR/report on scripts that name only files in that folder, by relative names
// made of [A-Za-z0-9_-] (SafeFileName): no path of the user's reaches a script.
struct Plotter {
  std::string dir;  // DIR/report
  std::string gnuplot;
  std::string warning;
  bool available = true;

  // Runs one script; returns the SVG path or "" when gnuplot failed.
  std::string Run(const std::string& name, const std::string& script) {
    if (!available) return "";
    const std::string gp = dir + "/" + name + ".gp";
    const std::string svg = dir + "/" + name + ".svg";
    AtomicWriteText(gp,
                    "set terminal svg size 640,400 fixed noenhanced font 'sans,11' "
                    "background rgb 'white'\nset output " +
                        GpString(name + ".svg") + "\n" + script,
                    true);
    std::error_code ec;
    fs::remove(svg, ec);
    // A gnuplot named by a relative path still works after the cd.
    const std::string program =
        gnuplot.find('/') == std::string::npos ? gnuplot : fs::absolute(gnuplot, ec).string();
    const std::string command = "cd " + ShellQuote(dir) + " && " + ShellQuote(program) + " " +
                                ShellQuote(name + ".gp") + " 2>" + ShellQuote(name + ".log") +
                                " </dev/null";
    const int status = std::system(command.c_str());
    if (status != 0 || !fs::exists(svg) || fs::file_size(svg) == 0) {
      if (WIFEXITED(status) && WEXITSTATUS(status) == 127) {
        available = false;
        warning = "gnuplot ('" + gnuplot + "') not found: plots skipped";
      } else {
        warning = "gnuplot failed on " + gp + " (see " + name + ".log)";
      }
      return "";
    }
    return svg;
  }
};

std::string SafeFileName(const std::string& text) {
  std::string out;
  for (char c : text) out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
  return out;
}

}  // namespace

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

namespace {

// What the plots and the page share: the sweep, its levels along the x axis and the summary cells.
struct ReportData {
  std::string dir;         // the sweep's folder
  std::string report_dir;  // DIR/report
  const SweepDir* sweep = nullptr;
  std::vector<std::string> levels;
  std::string axis;  // the level path, a named axis ("@turbidity") shown without its "@"
  std::map<std::string, double> level_x;
  bool numeric_levels = true;
  std::map<std::tuple<std::string, std::string, std::string>, Stats> lookup;
};

ReportData MakeReportData(const std::string& dir, const std::string& report_dir,
                          const SweepDir& sweep) {
  const Experiment& e = sweep.experiment;
  ReportData d;
  d.dir = dir;
  d.report_dir = report_dir;
  d.sweep = &sweep;
  d.levels = LevelLabels(e);
  // A named axis ("@turbidity") is shown without its "@".
  d.axis = e.level_path.rfind('@', 0) == 0 ? e.level_path.substr(1) : e.level_path;
  for (const ItemResult& item : sweep.items) d.level_x[item.level] = item.level_value;
  for (const std::string& level : d.levels) {
    d.numeric_levels &= d.level_x.count(level) && d.level_x[level] == std::atof(level.c_str()) &&
                        level.find_first_not_of("0123456789.eE+-") == std::string::npos;
  }
  const std::vector<SummaryCell> cells = Summarize(e, sweep.items);
  for (const SummaryCell& cell : cells)
    d.lookup[{cell.level, cell.method, cell.metric}] = cell.stats;
  return d;
}

using Plots = std::vector<std::pair<std::string, std::string>>;  // (caption, svg path)

// One plot per metric: its mean per method against the turbidity level.
void PlotMetricsAgainstLevel(ReportData& d, Plotter& plotter, Plots* plots) {
  const Experiment& e = d.sweep->experiment;
  std::string xtics;
  if (!d.numeric_levels) {
    xtics = "set xtics (";
    for (size_t i = 0; i < d.levels.size(); ++i) {
      if (!d.level_x.count(d.levels[i])) continue;
      xtics += (xtics.back() == '(' ? "" : ", ") + GpTicLabel(d.levels[i]) + " " +
               FormatValue(d.level_x[d.levels[i]]);
    }
    xtics += ")\n";
  }
  for (const HarnessMetricInfo& metric : e.metrics) {
    std::ostringstream data;
    data << "# level_x";
    for (const ExperimentMethod& m : e.methods) data << " " << OneLine(m.label);
    data << "\n";
    int points = 0;
    for (const std::string& level : d.levels) {
      if (!d.level_x.count(level)) continue;
      data << FormatValue(d.level_x[level]);
      for (const ExperimentMethod& m : e.methods) {
        const Stats& s = d.lookup[{level, m.label, metric.name}];
        const bool ok = s.n > 0 && std::isfinite(s.mean);
        data << " " << (ok ? FormatValue(s.mean) : "?");
        points += ok;
      }
      data << "\n";
    }
    if (points == 0) continue;
    const std::string name = "metric_" + SafeFileName(metric.name);
    AtomicWriteText(d.report_dir + "/" + name + ".dat", data.str(), true);
    std::ostringstream gp;
    gp << "set datafile missing '?'\nset grid\nset key outside right top\n"
       << "set xlabel " << GpString(d.axis) << "\nset ylabel "
       << GpString(metric.name +
                   (metric.higher_is_better ? " (higher is better)" : " (lower is better)"))
       << "\nset title " << GpString(metric.name + " vs " + d.axis + " (mean over items)")
       << "\nset offsets graph 0.03, graph 0.03, graph 0.05, graph 0.05\n"
       << xtics << "plot ";
    for (size_t m = 0; m < e.methods.size(); ++m) {
      gp << (m ? ", " : "") << GpString(name + ".dat") << " using 1:" << m + 2
         << " with linespoints lw 2 pt " << (m % 12) + 1 << " dt " << (m / 8) + 1 << " title "
         << GpString(e.methods[m].label);
    }
    gp << "\n";
    const std::string svg = plotter.Run(name, gp.str());
    if (!svg.empty()) plots->push_back({metric.name + " against " + d.axis, svg});
  }
}

// Run time against the primary (first) metric, per method, over all items.
void PlotTimeVsMetric(ReportData& d, Plotter& plotter, Plots* plots) {
  const Experiment& e = d.sweep->experiment;
  const HarnessMetricInfo& primary = e.metrics.front();
  std::ostringstream data;
  data << "# mean_time_ms mean_" << primary.name << " method\n";
  std::ostringstream labels;  // one `set label` per point: the method names stay in the script
  int points = 0;
  for (const ExperimentMethod& m : e.methods) {
    std::vector<double> times;
    bool batch_share = false;  // an external batch process's time / its items
    for (const ItemResult& item : d.sweep->items) {
      for (const MethodResult& row : item.methods) {
        if (row.label != m.label) continue;
        times.push_back(row.time_ms);
        batch_share |= row.time_is_batch_share;
      }
    }
    const Stats t = ComputeStats(times);
    const Stats& q = d.lookup[{"all", m.label, primary.name}];
    if (t.n == 0 || q.n == 0 || !std::isfinite(q.mean)) continue;
    const double time_ms = std::max(t.mean, 1e-3);  // > 0 for the log-scale axis
    const std::string label = batch_share ? m.label + " (batch)" : m.label;
    // The method's name as a quoted data-file column, for readers of the file; the plot takes
    // its labels from the script.
    std::string quoted = OneLine(label);
    std::replace(quoted.begin(), quoted.end(), '"', '\'');
    data << FormatValue(time_ms) << " " << FormatValue(q.mean) << " \"" << quoted << "\"\n";
    ++points;
    labels << "set label " << points << " " << GpString(label) << " at first "
           << FormatValue(time_ms) << ", first " << FormatValue(q.mean) << " center offset 0,1\n";
  }
  if (points == 0) return;
  AtomicWriteText(d.report_dir + "/time_vs_metric.dat", data.str(), true);
  std::ostringstream gp;
  gp << "set grid\nset logscale x\nset xlabel 'mean run time per image (ms, log scale)'\n"
     << "set ylabel "
     << GpString(primary.name +
                 (primary.higher_is_better ? " (higher is better)" : " (lower is better)"))
     << "\nset title " << GpString("run time vs " + primary.name + " per method (all items)")
     << "\nset offsets graph 0.1, graph 0.2, graph 0.1, graph 0.1\nunset key\n"
     << labels.str() << "plot 'time_vs_metric.dat' using 1:2 with points pt 7 ps 1.5\n";
  const std::string svg = plotter.Run("time_vs_metric", gp.str());
  if (!svg.empty()) plots->push_back({"run time against " + primary.name, svg});
}

// The page's head, title and the sweep's one-paragraph description.
void WritePageHead(std::ostringstream& html, const SweepDir& sweep, const std::string& warning) {
  const Experiment& e = sweep.experiment;
  html << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>"
       << Html(e.name) << " — turbid sweep report</title>\n<style>\n"
       << "body{font-family:sans-serif;margin:1.5em;max-width:1400px;color:#222}\n"
       << "table{border-collapse:collapse;margin:0.5em 0 1em}\n"
       << "td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}\n"
       << "th{background:#eee}td:first-child{text-align:left}\n"
       << "pre{background:#f6f6f6;padding:0.6em;overflow:auto;max-height:30em}\n"
       << ".grid td{text-align:center;vertical-align:top;font-size:small}\n"
       << ".grid img{display:block;image-rendering:auto}\n"
       << ".plots img{margin:0.3em;border:1px solid #ddd}\n.warn{color:#a40}\n"
       << "</style>\n</head>\n<body>\n";
  html << "<h1>" << Html(e.name) << "</h1>\n";
  if (!e.description.empty()) html << "<p>" << Html(e.description) << "</p>\n";
  html << "<p>" << sweep.items.size() << " of " << e.ItemCount() << " items (" << e.scenes.size()
       << " scenes × " << e.ConditionCount() << " conditions), " << e.methods.size() << " methods, "
       << e.metrics.size()
       << " metrics. Ground truth: " << (e.ground_truth == "lit" ? "lit J" : "clean ρ")
       << ". Turbidity level: <code>" << Html(e.level_path) << "</code>. Score domain: <b>"
       << ScoreDomainName(e.score_domain) << "</b> ("
       << (e.score_domain == ScoreDomain::kEncoded
               ? "full-reference metrics on the images as the camera writes them"
               : "full-reference metrics on linear-light images")
       << "; no-reference metrics on linear light).</p>\n";
  if (!warning.empty()) html << "<p class=\"warn\">" << Html(warning) << "</p>\n";
}

void WritePlotsSection(std::ostringstream& html, const Plots& plots) {
  html << "<h2>Plots</h2>\n<div class=\"plots\">\n";
  for (const auto& [caption, svg] : plots) {
    html << "<figure style=\"display:inline-block\"><img class=\"plot\" width=\"640\" "
            "height=\"400\" alt=\""
         << Html(caption) << "\" src=\"" << DataUri(svg, "image/svg+xml") << "\"><figcaption>"
         << Html(caption) << "</figcaption></figure>\n";
  }
  if (plots.empty()) html << "<p class=\"warn\">no plots</p>\n";
  html << "</div>\n";
}

// Image grid: one row per (scene, level), the first item of each. Returns the images embedded.
int WriteImageGrid(std::ostringstream& html, const ReportData& d, const ReportOptions& options) {
  const Experiment& e = d.sweep->experiment;
  const std::string& dir = d.dir;
  int images = 0;
  html << "<h2>Images</h2>\n<p>First item of each scene and level; thumbnails are sRGB-encoded "
          "for display.</p>\n<table class=\"grid\">\n<tr><th>item</th><th>clean</th>";
  if (e.ground_truth == "lit") html << "<th>lit J</th>";
  html << "<th>degraded</th>";
  for (const ExperimentMethod& m : e.methods) {
    if (m.name != "none")
      html << "<th>" << Html(m.privileged ? m.label + " †" : m.label) << "</th>";
  }
  html << "</tr>\n";
  std::set<std::pair<std::string, std::string>> shown;
  int rows = 0;
  // Only files the sweep wrote are embedded: a symbolic link planted anywhere below DIR (a
  // downloaded folder) could otherwise copy any readable file of the user's into a shared page.
  const auto image_cell = [&](const std::string& path, const std::string& alt) {
    if (!IsPlainFileBelow(dir, path)) return std::string("<td>–</td>");
    ++images;
    return "<td><img class=\"thumb\" alt=\"" + Html(alt) + "\" src=\"" +
           DataUri(path, "image/png") + "\"></td>";
  };
  for (const ItemResult& item : d.sweep->items) {
    if (rows >= options.max_grid_rows) break;
    if (!shown.insert({item.scene, item.level}).second) continue;
    ++rows;
    const std::string thumbs = dir + "/thumbs/" + item.id;
    html << "<tr><td>" << Html(item.id) << "<br>" << Html(d.axis) << " = " << Html(item.level)
         << "</td>"
         << image_cell(dir + "/thumbs/" + item.scene + "/clean.png", item.scene + " clean");
    if (e.ground_truth == "lit") html << image_cell(thumbs + "/lit.png", item.id + " lit");
    html << image_cell(thumbs + "/degraded.png", item.id + " degraded");
    for (const ExperimentMethod& m : e.methods) {
      if (m.name != "none")
        html << image_cell(thumbs + "/" + m.label + ".png", item.id + " " + m.label);
    }
    html << "</tr>\n";
  }
  html << "</table>\n";
  if (e.thumbnail_width == 0) html << "<p>Thumbnails are off in this experiment.</p>\n";
  return images;
}

// The experiment as run, the list of files, and the image check for headless tests.
void WritePageTail(std::ostringstream& html, const SweepDir& sweep) {
  html << "<h2>Experiment</h2>\n<pre>" << Html(sweep.experiment_json.dump(2)) << "</pre>\n";
  html << "<p>Files: items.csv, items.jsonl, summary.md, summary.csv (identical bytes for any "
          "thread count and shard layout), timings.csv, timings.md; plot scripts and data in "
          "report/.</p>\n";
  // Records in the DOM whether every image decoded, for headless checks (tests).
  html << "<script>\nwindow.addEventListener('load', function () {\n"
          "  var imgs = document.images, bad = 0;\n"
          "  for (var i = 0; i < imgs.length; ++i)\n"
          "    if (!imgs[i].complete || imgs[i].naturalWidth === 0) ++bad;\n"
          "  document.body.setAttribute('data-images', imgs.length);\n"
          "  document.body.setAttribute('data-broken-images', bad);\n"
          "});\n</script>\n</body>\n</html>\n";
}

}  // namespace

ReportSummary WriteReport(const std::string& dir, const ReportOptions& options) {
  ThrowIfInvalid(options, "report");
  const SweepDir sweep = LoadSweepDir(dir);
  const Experiment& e = sweep.experiment;
  if (sweep.items.empty()) throw Error(dir, "no finished items to report on (run the sweep first)");
  if (!fs::exists(dir + "/summary.md")) {
    WriteTables(e, sweep.items, dir);  // e.g. an interrupted sweep: tables of what is there
  }
  ReportSummary summary;
  summary.html_path = options.out_file.empty() ? dir + "/report.html" : options.out_file;
  const std::string report_dir = dir + "/report";
  std::error_code create_error;
  fs::create_directories(report_dir, create_error);
  if (create_error) throw OutputError(report_dir, "cannot create: " + create_error.message());

  // ---- Plots ----
  Plotter plotter{report_dir, options.gnuplot, "", true};
  ReportData data = MakeReportData(dir, report_dir, sweep);
  Plots plots;
  PlotMetricsAgainstLevel(data, plotter, &plots);
  PlotTimeVsMetric(data, plotter, &plots);
  summary.warning = plotter.warning;

  // ---- Page ----
  std::ostringstream html;
  WritePageHead(html, sweep, summary.warning);
  html << "<h2>Summary</h2>\n" << MarkdownToHtml(ReadAll(dir + "/summary.md"), 1);
  html << "<h2>Run time</h2>\n" << MarkdownToHtml(ReadAll(dir + "/timings.md"), 1);
  WritePlotsSection(html, plots);
  summary.images = WriteImageGrid(html, data, options);
  WritePageTail(html, sweep);
  AtomicWriteText(summary.html_path, html.str(), true);
  summary.plots = static_cast<int>(plots.size());
  return summary;
}

}  // namespace turbid
