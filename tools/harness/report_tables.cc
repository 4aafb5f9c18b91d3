// The report's tables (docs/report.md, "Tables"): methods are rows, grouped (reference, paper,
// baselines, your methods), metrics or levels are columns, under a header that stays in view.
// The numbers and the verdicts are those of summary.md (Summarize, JudgeRow: bootstrap
// intervals and the Wilcoxon signed-rank test of the best against the runner-up); only their
// layout and number format differ.
#include <algorithm>
#include <cmath>
#include <map>

#include "tools/harness/report_format.h"
#include "tools/harness/report_internal.h"
#include "tools/harness/statistics.h"

namespace turbid::report {
namespace {

// Marks of a judged cell; symbols and type, so that they survive black-and-white printing.
enum class Mark { kNone, kBest, kTied };

// One number format per metric, from every value of it the report shows (means, interval ends,
// the ground truth's scores), so that a metric reads the same in every table.
std::map<std::string, NumberFormat> MetricFormats(const ReportData& d,
                                                  const std::vector<SummaryCell>& references) {
  std::map<std::string, std::vector<double>> values;
  for (const SummaryCell& cell : d.cells) {
    if (cell.stats.n == 0) continue;
    values[cell.metric].insert(values[cell.metric].end(),
                               {cell.stats.mean, cell.ci_lo, cell.ci_hi});
  }
  for (const SummaryCell& cell : references) {
    if (cell.stats.n > 0) values[cell.metric].push_back(cell.stats.mean);
  }
  std::map<std::string, NumberFormat> formats;
  for (const HarnessMetricInfo& metric : d.sweep->experiment.metrics)
    formats[metric.name] = ChooseNumberFormat(values[metric.name]);
  return formats;
}

std::string CellHtml(const SummaryCell* cell, const NumberFormat& format, Mark mark,
                     const std::string& title) {
  if (cell == nullptr || cell->stats.n == 0) return "<td class=\"na\">–</td>";
  const std::string mean = FormatNumber(cell->stats.mean, format);
  std::string out = "<td";
  if (mark == Mark::kBest) out += " class=\"best\"";
  if (mark == Mark::kTied) out += " class=\"tie\"";
  if (!title.empty()) out += " title=\"" + Html(title) + "\"";
  out += ">";
  if (mark == Mark::kBest) out += "<b>" + mean + "</b>&nbsp;▲";
  if (mark == Mark::kTied) out += "<u>" + mean + "</u>&nbsp;≈";
  if (mark == Mark::kNone) out += mean;
  if (cell->stats.n > 1 && cell->ci_lo != cell->ci_hi && std::isfinite(cell->stats.mean)) {
    out += "<span class=\"ci\">" + FormatNumber(cell->ci_lo, format) + " – " +
           FormatNumber(cell->ci_hi, format) + "</span>";
  }
  return out + "</td>";
}

// The verdict of one column (a metric at a level) over the methods.
struct Column {
  std::string level;
  const HarnessMetricInfo* metric = nullptr;
  RowVerdict verdict;
};

Column JudgeColumn(const ReportData& d, const std::string& level, const HarnessMetricInfo& metric) {
  Column column{level, &metric, {}};
  std::vector<const SummaryCell*> row;
  for (const ExperimentMethod& m : d.sweep->experiment.methods)
    row.push_back(d.Cell(level, m.label, metric.name));
  column.verdict = JudgeRow(row, d.excluded, metric.higher_is_better);
  return column;
}

Mark MarkOf(const Column& column, size_t method) {
  const int i = static_cast<int>(method);
  if (column.verdict.best < 0) return Mark::kNone;
  if (column.verdict.significant) return i == column.verdict.best ? Mark::kBest : Mark::kNone;
  return i == column.verdict.best || i == column.verdict.runner_up ? Mark::kTied : Mark::kNone;
}

std::string VerdictNote(const ReportData& d, const Column& column) {
  const RowVerdict& v = column.verdict;
  if (v.best < 0 || v.runner_up < 0) return v.best < 0 ? "–" : "alone";
  const auto& methods = d.sweep->experiment.methods;
  char p[32];
  std::snprintf(p, sizeof p, "%.2g", v.p_value);
  return std::string(v.significant ? "▲ " : "≈ ") + methods[static_cast<size_t>(v.best)].label +
         (v.significant ? " > " : " ≈ ") + methods[static_cast<size_t>(v.runner_up)].label +
         "<br>p = " + p + ", n = " + std::to_string(v.pairs);
}

// Rows of methods, grouped, for `columns`; `reference` (may be empty) is the ground truth's row.
void WriteMethodRows(std::ostringstream& html, const ReportData& d,
                     const std::vector<Column>& columns,
                     const std::map<std::string, NumberFormat>& formats,
                     const std::vector<const SummaryCell*>& reference, bool failed_column) {
  const auto& methods = d.sweep->experiment.methods;
  const size_t width = columns.size() + 1 + (failed_column ? 1 : 0);
  html << "<tbody>\n";
  for (int g = 0; g < kMethodGroups; ++g) {
    const bool with_reference = g == 0 && !reference.empty();
    if (d.by_group[static_cast<size_t>(g)].empty() && !with_reference) continue;
    html << "<tr class=\"group\"><th colspan=\"" << width << "\">"
         << GroupName(static_cast<MethodGroup>(g)) << "</th></tr>\n";
    if (with_reference) {
      html << "<tr class=\"ref\"><th scope=\"row\">ground truth (the clean image)</th>";
      for (size_t c = 0; c < columns.size(); ++c)
        html << CellHtml(reference[c], formats.at(columns[c].metric->name), Mark::kNone, "");
      html << (failed_column ? "<td></td>" : "") << "</tr>\n";
    }
    for (size_t m : d.by_group[static_cast<size_t>(g)]) {
      html << "<tr><th scope=\"row\">" << Html(MethodName(methods[m])) << "</th>";
      int failed = 0;
      for (const Column& column : columns) {
        const SummaryCell* cell = d.Cell(column.level, methods[m].label, column.metric->name);
        if (cell != nullptr) failed = std::max(failed, cell->failed);
        html << CellHtml(cell, formats.at(column.metric->name), MarkOf(column, m),
                         cell == nullptr ? "" : "n = " + std::to_string(cell->stats.n));
      }
      if (failed_column) html << "<td>" << failed << "</td>";
      html << "</tr>\n";
    }
  }
  html << "</tbody>\n<tfoot><tr><th scope=\"row\">best vs runner-up</th>";
  for (const Column& column : columns)
    html << "<td class=\"note\">" << VerdictNote(d, column) << "</td>";
  html << (failed_column ? "<td></td>" : "") << "</tr></tfoot>\n";
}

int ItemsOfLevel(const ReportData& d, const std::string& level) {
  int n = 0;
  for (const ItemResult& item : d.sweep->items) n += level == "all" || item.level == level;
  return n;
}

std::string MetricHeader(const HarnessMetricInfo& metric, const NumberFormat& format,
                         const Experiment& e) {
  std::string out = Html(metric.name) + (metric.higher_is_better ? " ↑" : " ↓");
  if (metric.name == "psnr") out += "<br><small>dB</small>";
  if (metric.needs_reference)
    out += "<br><small>" + Html(ScoreDomainName(e.score_domain)) + "</small>";
  if (format.exponent != 0) out += "<br><small>" + Html(ScaleSuffix(format)) + "</small>";
  return out;
}

}  // namespace

namespace {

// The ground truth's own scores and the number formats, shared by the result tables.
struct TableContext {
  bool any_reference = false, any_failed = false;
  std::vector<std::string> levels;      // the levels, then "all"
  std::vector<SummaryCell> references;  // (level, metric) in order; only with reference scores
  std::map<std::string, NumberFormat> formats;
  const SummaryCell* Reference(const std::string& level, const std::string& metric) const {
    for (const SummaryCell& cell : references)
      if (cell.level == level && cell.metric == metric) return &cell;
    return nullptr;
  }
};

TableContext MakeTableContext(const ReportData& d) {
  const Experiment& e = d.sweep->experiment;
  TableContext t;
  for (const ItemResult& item : d.sweep->items) t.any_reference |= !item.reference_metrics.empty();
  for (const SummaryCell& cell : d.cells) t.any_failed |= cell.failed > 0;
  t.levels = d.levels;
  t.levels.push_back("all");
  if (t.any_reference) {
    for (const std::string& level : t.levels)
      for (const HarnessMetricInfo& metric : e.metrics)
        t.references.push_back(ReferenceSummaryCell(d.sweep->items, level, metric.name));
  }
  t.formats = MetricFormats(d, t.references);
  return t;
}

}  // namespace

void WriteResultTables(std::ostringstream& html, const ReportData& d) {
  const Experiment& e = d.sweep->experiment;
  const TableContext t = MakeTableContext(d);
  std::vector<Column> columns;
  std::vector<const SummaryCell*> reference_row;
  for (const HarnessMetricInfo& metric : e.metrics) {
    columns.push_back(JudgeColumn(d, "all", metric));
    if (t.any_reference) reference_row.push_back(t.Reference("all", metric.name));
  }
  html << "<h3 id=\"all-levels\">All levels (" << ItemsOfLevel(d, "all") << " items)</h3>\n"
       << "<div class=\"tablewrap\"><table class=\"results\">\n<thead><tr><th>method</th>";
  for (const HarnessMetricInfo& metric : e.metrics)
    html << "<th>" << MetricHeader(metric, t.formats.at(metric.name), e) << "</th>";
  if (t.any_failed) html << "<th>failed<br><small>items</small></th>";
  html << "</tr></thead>\n";
  WriteMethodRows(html, d, columns, t.formats, reference_row, t.any_failed);
  html << "</table></div>\n";
}

bool WriteLevelTables(std::ostringstream& html, const ReportData& d) {
  if (d.levels.size() < 2) return false;
  const TableContext t = MakeTableContext(d);
  for (const HarnessMetricInfo& metric : d.sweep->experiment.metrics) {
    std::vector<Column> columns;
    std::vector<const SummaryCell*> reference_row;
    for (const std::string& level : t.levels) {
      columns.push_back(JudgeColumn(d, level, metric));
      if (t.any_reference) reference_row.push_back(t.Reference(level, metric.name));
    }
    html << "<h3>" << Html(MetricTitle(metric)) << Html(ScaleSuffix(t.formats.at(metric.name)))
         << "</h3>\n<div class=\"tablewrap\"><table class=\"results\">\n<thead><tr><th>method</th>";
    for (const std::string& level : t.levels) {
      html << "<th>" << (level == "all" ? "all" : Html(d.axis) + " = " + Html(level))
           << "<br><small>" << ItemsOfLevel(d, level) << " items</small></th>";
    }
    html << "</tr></thead>\n";
    WriteMethodRows(html, d, columns, t.formats, reference_row, false);
    html << "</table></div>\n";
  }
  return true;
}

void WriteTimeTable(std::ostringstream& html, const ReportData& d) {
  const Experiment& e = d.sweep->experiment;
  std::vector<std::string> sizes;
  for (const ItemResult& item : d.sweep->items) {
    const std::string size = std::to_string(item.width) + "×" + std::to_string(item.height);
    if (std::find(sizes.begin(), sizes.end(), size) == sizes.end()) sizes.push_back(size);
  }
  // stats[size][method]; method e.methods.size() is the render.
  std::vector<std::vector<Stats>> stats(sizes.size());
  for (size_t s = 0; s < sizes.size(); ++s) {
    std::vector<std::vector<double>> times(e.methods.size() + 1);
    for (const ItemResult& item : d.sweep->items) {
      if (std::to_string(item.width) + "×" + std::to_string(item.height) != sizes[s]) continue;
      times.back().push_back(item.render_ms);
      for (const MethodResult& row : item.methods) {
        for (size_t m = 0; m < e.methods.size(); ++m)
          if (e.methods[m].label == row.label) times[m].push_back(row.time_ms);
      }
    }
    for (const std::vector<double>& t : times) stats[s].push_back(ComputeStats(t));
  }
  html << "<div class=\"tablewrap\"><table class=\"results times\">\n<thead><tr><th>method</th>";
  for (const std::string& size : sizes) html << "<th>" << size << "<br><small>ms</small></th>";
  html << "</tr></thead>\n<tbody>\n";
  const auto cell = [&](size_t s, size_t m, bool fastest) {
    const Stats& st = stats[s][m];
    if (st.n == 0) return std::string("<td class=\"na\">–</td>");
    const std::string mean = FormatSignificant(st.mean);
    std::string out = fastest ? "<td class=\"best\"><b>" + mean + "</b>&nbsp;▲" : "<td>" + mean;
    if (st.n > 1 && std::isfinite(st.sd))
      out += "<span class=\"ci\">± " + FormatSignificant(st.sd, 2) + "</span>";
    return out + "</td>";
  };
  html << "<tr class=\"ref\"><th scope=\"row\">render (the simulator)</th>";
  for (size_t s = 0; s < sizes.size(); ++s) html << cell(s, e.methods.size(), false);
  html << "</tr>\n";
  std::vector<int> fastest(sizes.size(), -1);
  for (size_t s = 0; s < sizes.size(); ++s) {
    for (size_t m = 0; m < e.methods.size(); ++m) {
      const Stats& st = stats[s][m];
      if (d.excluded[m] || st.n == 0 || std::isnan(st.mean)) continue;
      if (fastest[s] < 0 || st.mean < stats[s][static_cast<size_t>(fastest[s])].mean)
        fastest[s] = static_cast<int>(m);
    }
  }
  for (int g = 0; g < kMethodGroups; ++g) {
    if (d.by_group[static_cast<size_t>(g)].empty()) continue;
    html << "<tr class=\"group\"><th colspan=\"" << sizes.size() + 1 << "\">"
         << GroupName(static_cast<MethodGroup>(g)) << "</th></tr>\n";
    for (size_t m : d.by_group[static_cast<size_t>(g)]) {
      // As timings.md: a batch process's time per item, or precomputed results (nothing ran).
      bool batch = false, not_run = false;
      for (const ItemResult& item : d.sweep->items) {
        for (const MethodResult& row : item.methods) {
          if (row.label != e.methods[m].label) continue;
          batch |= row.time_is_batch_share;
          not_run |= std::isnan(row.time_ms);
        }
      }
      html << "<tr><th scope=\"row\">" << Html(MethodName(e.methods[m]))
           << (batch     ? " (batch)"
               : not_run ? " (precomputed)"
                         : "")
           << "</th>";
      for (size_t s = 0; s < sizes.size(); ++s)
        html << cell(s, m, fastest[s] == static_cast<int>(m));
      html << "</tr>\n";
    }
  }
  html << "</tbody>\n</table></div>\n";
}

}  // namespace turbid::report
