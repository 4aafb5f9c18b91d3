// The report's plots (docs/report.md, "Plots"), made by gnuplot as SVG in DIR/report/ next to
// their scripts and data: per metric, small multiples (one panel per method group, the other
// groups in grey behind) of the mean against the level with the 95 % bootstrap interval of the
// mean as a band; and run time against the primary metric, numbered points with a key and a
// table beside it. Okabe–Ito colours together with dash and point types, so that lines stay
// apart for colour-blind readers and in black and white.
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "core/atomic_file.h"
#include "tools/harness/report_format.h"
#include "tools/harness/report_internal.h"

namespace turbid::report {
namespace {

namespace fs = std::filesystem;

// Okabe & Ito (2008), "Color Universal Design": blue, vermillion, bluish green, reddish purple,
// orange, sky blue, black; yellow last (faint on white).
const char* const kPalette[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                "#E69F00", "#56B4E9", "#000000", "#F0E442"};
constexpr int kPaletteSize = 8;
const int kPointTypes[] = {7, 5, 9, 11, 13, 6, 4, 8};  // filled circle, square, triangles, ...
constexpr int kDashTypes = 5;
// The scatter's point type per group: square (reference), circle (paper), triangle (baselines),
// diamond (yours).
const int kGroupPoint[] = {5, 7, 9, 13};

std::string ShellQuote(const std::string& arg) {
  std::string quoted = "'";
  for (char c : arg) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
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

std::string SafeFileName(const std::string& text) {
  std::string out;
  for (char c : text) out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
  return out;
}

// Runs gnuplot in DIR/report on scripts that name only files in that folder, by relative names
// made of [A-Za-z0-9_-] (SafeFileName): no path of the user's reaches a script.
struct Plotter {
  std::string dir;  // DIR/report
  std::string gnuplot;
  std::string warning;
  bool available = true;

  // Runs one script; returns false when gnuplot failed.
  bool Run(const std::string& name, int width, int height, const std::string& script) {
    if (!available) return false;
    const std::string gp = dir + "/" + name + ".gp";
    const std::string svg = dir + "/" + name + ".svg";
    AtomicWriteText(gp,
                    "set terminal svg size " + std::to_string(width) + "," +
                        std::to_string(height) +
                        " fixed noenhanced font 'sans,12' background rgb 'white'\n"
                        "set encoding utf8\nset output " +
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
      return false;
    }
    return true;
  }
};

// A method's place in its group: its colour, dash and point in the metric plots.
size_t PlaceInGroup(const ReportData& d, size_t method) {
  const auto& members = d.by_group[static_cast<size_t>(d.groups[method])];
  return static_cast<size_t>(std::find(members.begin(), members.end(), method) - members.begin());
}

std::string Colour(const ReportData& d, size_t method) {
  return "lc rgb '" + std::string(kPalette[PlaceInGroup(d, method) % kPaletteSize]) + "'";
}

std::string LineStyle(const ReportData& d, size_t method) {
  const size_t k = PlaceInGroup(d, method);
  return Colour(d, method) + " dt " + std::to_string(k % kDashTypes + 1) + " pt " +
         std::to_string(kPointTypes[k % 8]);
}

std::string XTics(const ReportData& d) {
  if (d.numeric_levels) return "";
  std::string xtics = "set xtics (";
  for (const std::string& level : d.levels) {
    if (!d.level_x.count(level)) continue;
    xtics += (xtics.back() == '(' ? "" : ", ") + GpTicLabel(level) + " " +
             FormatValue(d.level_x.at(level));
  }
  return xtics + ")\n";
}

// The data of one metric: x, then mean, interval low, interval high per method. Returns the
// finite values' range in *lo, *hi; false when nothing is finite.
bool MetricData(const ReportData& d, const HarnessMetricInfo& metric, std::string* data, double* lo,
                double* hi) {
  const Experiment& e = d.sweep->experiment;
  std::ostringstream out;
  out << "# level_x";
  for (const ExperimentMethod& m : e.methods) {
    const std::string label = OneLine(m.label);
    out << " " << label << ":mean " << label << ":ci_lo " << label << ":ci_hi";
  }
  out << "\n";
  *lo = HUGE_VAL;
  *hi = -HUGE_VAL;
  for (const std::string& level : d.levels) {
    if (!d.level_x.count(level)) continue;
    out << FormatValue(d.level_x.at(level));
    for (const ExperimentMethod& m : e.methods) {
      const SummaryCell* cell = d.Cell(level, m.label, metric.name);
      const bool ok = cell != nullptr && cell->stats.n > 0 && std::isfinite(cell->stats.mean);
      if (!ok) {
        out << " ? ? ?";
        continue;
      }
      const bool band = std::isfinite(cell->ci_lo) && std::isfinite(cell->ci_hi);
      const double a = band ? cell->ci_lo : cell->stats.mean;
      const double b = band ? cell->ci_hi : cell->stats.mean;
      out << " " << FormatValue(cell->stats.mean) << " " << FormatValue(a) << " " << FormatValue(b);
      *lo = std::min({*lo, a, cell->stats.mean});
      *hi = std::max({*hi, b, cell->stats.mean});
    }
    out << "\n";
  }
  *data = out.str();
  return *lo <= *hi;
}

// One plot per metric: small multiples, a panel per method group with the rest in grey.
void PlotMetricsAgainstLevel(const ReportData& d, Plotter& plotter, std::vector<Plot>* plots) {
  const Experiment& e = d.sweep->experiment;
  std::vector<int> panels;
  for (int g = 0; g < kMethodGroups; ++g)
    if (!d.by_group[static_cast<size_t>(g)].empty()) panels.push_back(g);
  const int columns = panels.size() > 1 ? 2 : 1;
  const int rows = (static_cast<int>(panels.size()) + columns - 1) / columns;
  const int width = columns == 2 ? 1100 : 640, height = 60 + rows * 380;
  for (const HarnessMetricInfo& metric : e.metrics) {
    std::string data;
    double lo = 0.0, hi = 0.0;
    if (panels.empty() || !MetricData(d, metric, &data, &lo, &hi)) continue;
    const std::string name = "metric_" + SafeFileName(metric.name);
    AtomicWriteText(d.report_dir + "/" + name + ".dat", data, true);
    const double pad = hi > lo ? 0.05 * (hi - lo) : std::max(1e-9, 0.05 * std::fabs(hi));
    std::ostringstream gp;
    gp << "set datafile missing '?'\nset grid\nset key below left Left reverse samplen 3\n"
       << "set xlabel " << GpString(d.axis) << "\nset ylabel " << GpString(MetricTitle(metric))
       << "\nset yrange [" << FormatValue(lo - pad) << ":" << FormatValue(hi + pad) << "]\n"
       << "set offsets graph 0.03, graph 0.03, 0, 0\nset style fill transparent solid 0.18 "
          "noborder\n"
       << XTics(d) << "set multiplot layout " << rows << "," << columns << " title "
       << GpString(metric.name + " against " + d.axis +
                   ": mean over items, band = 95 % bootstrap interval of the mean")
       << "\n";
    const std::string file = GpString(name + ".dat");
    for (int g : panels) {
      gp << "set title " << GpString(GroupName(static_cast<MethodGroup>(g))) << "\nplot ";
      std::string sep;
      for (size_t m = 0; m < e.methods.size(); ++m) {  // the other groups, grey, behind
        if (static_cast<int>(d.groups[m]) == g) continue;
        gp << sep << file << " using 1:" << 2 + 3 * m
           << " with lines lw 1 lc rgb '#c8c8c8' notitle";
        sep = ", ";
      }
      for (size_t m : d.by_group[static_cast<size_t>(g)]) {
        gp << sep << file << " using 1:" << 3 + 3 * m << ":" << 4 + 3 * m << " with filledcurves "
           << Colour(d, m) << " notitle";
        sep = ", ";
        gp << sep << file << " using 1:" << 2 + 3 * m << " with linespoints lw 2 ps 1.2 "
           << LineStyle(d, m) << " title " << GpString(MethodName(e.methods[m]));
      }
      gp << "\n";
    }
    gp << "unset multiplot\n";
    if (plotter.Run(name, width, height, gp.str())) {
      plots->push_back({metric.name + " against " + d.axis + ", per method group", name + ".svg",
                        "", width, height});
    }
  }
}

struct ScatterPoint {
  double time_ms = 0.0, value = 0.0;  // the plotted position (time > 0 for the log axis)
  double mean_time_ms = 0.0;          // the table's
  int group = 0;
  std::string label;
};

// Offsets (in characters) of the points' number labels: for each point in turn the candidate
// around it farthest from every point and every label placed so far, in screen-like units (the
// log-time and value ranges scaled to a 600 x 380 pixel plot, 8 x 14 pixel characters).
std::vector<std::pair<double, double>> PlaceLabels(const std::vector<ScatterPoint>& points) {
  double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
  for (const ScatterPoint& p : points) {
    x0 = std::min(x0, std::log10(p.time_ms));
    x1 = std::max(x1, std::log10(p.time_ms));
    y0 = std::min(y0, p.value);
    y1 = std::max(y1, p.value);
  }
  const auto px = [&](const ScatterPoint& p) {
    return std::pair<double, double>{(std::log10(p.time_ms) - x0) / std::max(x1 - x0, 1e-9) * 600,
                                     (p.value - y0) / std::max(y1 - y0, 1e-12) * 380};
  };
  static const double kCandidates[][2] = {{1, 0.8}, {1, -0.8},   {-1.8, 0.8}, {-1.8, -0.8},
                                          {0, 1.5}, {0, -1.5},   {1.5, 0},    {-2.5, 0},
                                          {2, 1.6}, {-2.8, 1.6}, {2, -1.6},   {-2.8, -1.6}};
  std::vector<std::pair<double, double>> placed, offsets;
  for (const ScatterPoint& p : points) {
    const auto [x, y] = px(p);
    double best_score = -1.0;
    std::pair<double, double> best{1, 0.8}, best_at{x, y};
    for (const auto& c : kCandidates) {
      const double lx = x + c[0] * 8, ly = y + c[1] * 14;
      double score = HUGE_VAL;
      for (const ScatterPoint& q : points) {
        const auto [qx, qy] = px(q);
        score = std::min(score, std::hypot(lx - qx, (ly - qy) * 1.5));
      }
      for (const auto& [ax, ay] : placed)
        score = std::min(score, std::hypot(lx - ax, (ly - ay) * 1.5));
      if (score > best_score + 1e-9) {
        best_score = score;
        best = {c[0], c[1]};
        best_at = {lx, ly};
      }
    }
    placed.push_back(best_at);
    offsets.push_back(best);
  }
  return offsets;
}

// Each method's mean run time and mean of the primary metric over all items, in group order.
std::vector<ScatterPoint> ScatterPoints(const ReportData& d, const HarnessMetricInfo& primary) {
  const Experiment& e = d.sweep->experiment;
  std::vector<ScatterPoint> points;
  for (int g = 0; g < kMethodGroups; ++g) {
    for (size_t m : d.by_group[static_cast<size_t>(g)]) {
      std::vector<double> times;
      bool batch_share = false;  // an external batch process's time / its items
      for (const ItemResult& item : d.sweep->items) {
        for (const MethodResult& row : item.methods) {
          if (row.label != e.methods[m].label) continue;
          times.push_back(row.time_ms);
          batch_share |= row.time_is_batch_share;
        }
      }
      const Stats t = ComputeStats(times);
      const SummaryCell* q = d.Cell("all", e.methods[m].label, primary.name);
      if (t.n == 0 || q == nullptr || q->stats.n == 0 || !std::isfinite(q->stats.mean)) continue;
      points.push_back({std::max(t.mean, 1e-3), q->stats.mean, t.mean, g,
                        MethodName(e.methods[m]) + (batch_share ? " (batch)" : "")});
    }
  }
  return points;
}

// Run time against the primary (first) metric per method: numbered points with their numbers
// placed apart, a key, and a table beside the plot on the page.
void PlotTimeVsMetric(const ReportData& d, Plotter& plotter, std::vector<Plot>* plots) {
  const HarnessMetricInfo& primary = d.sweep->experiment.metrics.front();
  const std::vector<ScatterPoint> points = ScatterPoints(d, primary);
  if (points.empty()) return;
  std::vector<double> means;
  for (const SummaryCell& cell : d.cells)
    if (cell.metric == primary.name && cell.stats.n > 0) means.push_back(cell.stats.mean);
  const NumberFormat format = ChooseNumberFormat(means);
  const std::vector<std::pair<double, double>> offsets = PlaceLabels(points);
  std::ostringstream data, plot, table;
  data << "# mean_time_ms mean_" << primary.name << " method\n";
  table << "<table class=\"results key\"><thead><tr><th>#</th><th>method</th><th>ms</th><th>"
        << Html(primary.name) << (primary.higher_is_better ? " ↑" : " ↓")
        << "</th></tr></thead>\n<tbody>\n";
  for (size_t i = 0; i < points.size(); ++i) {
    const ScatterPoint& p = points[i];
    // The method's name as a quoted data-file column, for readers of the file; the plot takes
    // its labels from the script.
    std::string quoted = OneLine(p.label);
    std::replace(quoted.begin(), quoted.end(), '"', '\'');
    data << FormatValue(p.time_ms) << " " << FormatValue(p.value) << " \"" << quoted << "\"\n";
    const std::string number = std::to_string(i + 1);
    plot << (i ? ", " : "") << "'time_vs_metric.dat' every ::" << i << "::" << i
         << " using 1:2 with points ps 1.8 pt " << kGroupPoint[p.group] << " lc rgb '"
         << kPalette[i % 7] << "' title " << GpString(number + "  " + p.label)
         << ", '' every ::" << i << "::" << i << " using 1:2:(" << GpString(number)
         << ") with labels offset char " << FormatValue(offsets[i].first) << ","
         << FormatValue(offsets[i].second) << " font ',12' notitle";
    table << "<tr><td>" << number << "</td><th scope=\"row\">" << Html(p.label) << "</th><td>"
          << FormatSignificant(p.mean_time_ms) << "</td><td>" << FormatNumber(p.value, format)
          << "</td></tr>\n";
  }
  AtomicWriteText(d.report_dir + "/time_vs_metric.dat", data.str(), true);
  std::ostringstream gp;
  gp << "set grid\nset logscale x\n"
     << "set xlabel 'mean run time per image, ms (log scale; ← faster)'\nset ylabel "
     << GpString(MetricTitle(primary)) << "\nset title "
     << GpString("run time against " + primary.name + " per method (mean over all items)")
     << "\nset offsets graph 0.08, graph 0.12, graph 0.08, graph 0.08\n"
     << "set key outside right top Left reverse samplen 1 font ',11'\n"
     << "plot " << plot.str() << "\n";
  table << "</tbody></table>";
  if (plotter.Run("time_vs_metric", 820, 520, gp.str())) {
    plots->push_back({"run time against " + primary.name + " (numbers: the table beside)",
                      "time_vs_metric.svg", table.str(), 820, 520});
  }
}

}  // namespace

PlotResult MakePlots(const ReportData& data, const std::string& gnuplot) {
  Plotter plotter{data.report_dir, gnuplot, "", true};
  PlotResult result;
  PlotMetricsAgainstLevel(data, plotter, &result.plots);
  PlotTimeVsMetric(data, plotter, &result.plots);
  result.warning = plotter.warning;
  return result;
}

}  // namespace turbid::report
