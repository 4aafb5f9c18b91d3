// `turbid report DIR`: one static, self-contained HTML page for a finished sweep: the experiment,
// the summary and run-time tables, image grids (clean / degraded / each method per scene and
// turbidity level, from the thumbnails the sweep saved) and plots made by gnuplot (SVG): each
// metric against the turbidity level per method, and run time against the primary metric per
// method. Images and plots are embedded as data: URIs, so the page needs no network and no other
// file; the gnuplot scripts and data are kept in DIR/report/ so every plot can be re-made.
#pragma once

#include <string>

namespace turbid {

struct ReportOptions {
  std::string out_file;             // default: DIR/report.html
  std::string gnuplot = "gnuplot";  // the gnuplot executable; plots are skipped (with a note on
                                    // the page and a warning) when it cannot be run
  int max_grid_rows = 60;           // image-grid rows (scene x level) shown at most
  bool Check(std::string* why) const;
};

struct ReportSummary {
  std::string html_path;
  int plots = 0;        // plots embedded
  int images = 0;       // thumbnails embedded
  std::string warning;  // non-empty when something was skipped (e.g. gnuplot missing)
};

// Throws Error when DIR is not a sweep folder or holds no finished item.
ReportSummary WriteReport(const std::string& dir, const ReportOptions& options);

// Standard base64 (RFC 4648) of bytes, for data: URIs.
std::string Base64(const std::string& bytes);

}  // namespace turbid
