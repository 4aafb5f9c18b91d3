// `turbid report DIR`: one static HTML page for a finished sweep, DIR/report.html (docs/report.md):
// the experiment, the results as tables (methods as grouped rows, one number format per metric,
// the summary's Wilcoxon verdicts marked ▲ best / ≈ tied), plots made by gnuplot as SVG (each
// metric against the level in small multiples per method group with bootstrap bands; run time
// against the primary metric), an image grid with a viewer (full size beside the clean image and
// the degraded input, or a slider), run times and the protocol. The page links the images the
// sweep saved (thumbs/) and the plots (report/, with their gnuplot scripts and data) by relative
// paths: the folder is the report, it works from file:// and fetches nothing from a network.
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
  int images = 0;       // images linked in the grid
  std::string warning;  // non-empty when something was skipped (e.g. gnuplot missing)
};

// Throws Error when DIR is not a sweep folder or holds no finished item.
ReportSummary WriteReport(const std::string& dir, const ReportOptions& options);

// Standard base64 (RFC 4648) of bytes, for data: URIs.
std::string Base64(const std::string& bytes);

}  // namespace turbid
