// `turbid report` read as a reader reads it (issue 36): one title, grouped method rows whose marks
// are summary.md's verdicts, numbers without exponent noise, every link resolving to a file of the
// folder; then the page opened in headless Chromium at 1280 px (skipped with a message where
// Chromium is not installed): no horizontal overflow, every image and linked image loads, every
// plot is present, also with the image viewer open; and a page with a planted overflow and a
// missing image, which the same check must catch.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>

#include "tests/support/test_support.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

const char* kExperiment = R"({
  "name": "tiny",
  "description": "report test: two tiny built-in scenes, two turbidity levels",
  "seed": 5,
  "scale": 0.1,
  "scenes": ["builtin:hull", "builtin:seafloor"],
  "grid": {"@turbidity": [
    {"label": "0.3", "x": 0.3, "water.beta_gray_per_m": 0.3, "water.beta_rgb_per_m": [0.4, 0.3, 0.25]},
    {"label": "1.2", "x": 1.2, "water.beta_gray_per_m": 1.2, "water.beta_rgb_per_m": [1.5, 1.2, 1.0]}]},
  "methods": ["full", "clahe", "dcp"],
  "metrics": ["ssim", "psnr", "hautiere_e"],
  "thumbnails": 48
})";

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + 1)) ++n;
  return n;
}

std::string UrlDecode(const std::string& text) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size()) {
      out += static_cast<char>(std::stoi(text.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += text[i];
    }
  }
  return out;
}

// The href and src values of a page that name files (not #anchors, not data: URIs).
std::vector<std::string> FileLinks(const std::string& html) {
  std::vector<std::string> links;
  const std::regex attr("(?:href|src)=\"([^\"#][^\"]*)\"");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), attr); it != std::sregex_iterator();
       ++it) {
    const std::string link = (*it)[1];
    if (link.rfind("data:", 0) != 0) links.push_back(link);
  }
  return links;
}

class ReportPage : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    const std::string exp = dir_->Write("tiny.json", kExperiment);
    const CliRun sweep = RunTurbid({"sweep", exp, "--out", dir_->File("out"), "--quiet"});
    ASSERT_EQ(sweep.exit_code, 0) << sweep.err;
    report_ = new CliRun(RunTurbid({"report", dir_->File("out")}));
  }
  static void TearDownTestSuite() {
    delete report_;
    delete dir_;
  }
  static TempDir* dir_;
  static CliRun* report_;
};
TempDir* ReportPage::dir_ = nullptr;
CliRun* ReportPage::report_ = nullptr;

TEST_F(ReportPage, OneTitleOneDescriptionGroupedRows) {
  ASSERT_EQ(report_->exit_code, 0) << report_->err;
  // 3 metric plots + run time vs ssim.
  EXPECT_NE(report_->out.find("(4 plots"), std::string::npos) << report_->out << report_->err;
  const std::string html = ReadFileText(dir_->File("out/report.html"));
  EXPECT_EQ(Count(html, "<h1"), 1);
  // Once above the experiment file (shown as it is at the end).
  const std::string page = html.substr(0, html.find("id=\"protocol\""));
  EXPECT_EQ(Count(page, "report test: two tiny built-in scenes"), 1);
  EXPECT_EQ(Count(html, "tiny: summary"), 0);          // summary.md's own title is not repeated
  EXPECT_EQ(html.find("http://"), std::string::npos);  // nothing fetched from the network
  EXPECT_EQ(html.find("https://"), std::string::npos);
  // Methods are rows, in groups: reference (none, oracle), paper (full), baselines.
  const size_t all = html.find("id=\"all-levels\"");
  const size_t end = html.find("</table>", all);
  ASSERT_NE(all, std::string::npos);
  const std::string table = html.substr(all, end - all);
  const size_t reference = table.find(">reference"), paper = table.find(">paper<"),
               baselines = table.find(">baselines<");
  ASSERT_NE(reference, std::string::npos) << table;
  EXPECT_LT(reference, table.find(">oracle †<"));
  EXPECT_LT(table.find(">oracle †<"), paper);
  EXPECT_LT(paper, table.find(">full<"));
  EXPECT_LT(table.find(">full<"), baselines);
  EXPECT_LT(baselines, table.find(">clahe<"));
  EXPECT_LT(baselines, table.find(">dcp<"));
  // No exponent noise in any cell.
  EXPECT_FALSE(std::regex_search(html, std::regex("<td[^>]*>[-0-9.]+e[-+][0-9]"))) << table;
}

// The marks are summary.md's verdicts (the same Wilcoxon test): every "A > B (p = ..., n = ...)"
// or "tied: A ≈ B (p = ...)" of its "All levels" table is in the report's footer row.
TEST_F(ReportPage, MarksAreTheVerdictsOfSummaryMd) {
  ASSERT_EQ(report_->exit_code, 0) << report_->err;
  const std::string md = ReadFileText(dir_->File("out/summary.md"));
  const std::string html = ReadFileText(dir_->File("out/report.html"));
  const size_t all = html.find("id=\"all-levels\"");
  const std::string table = html.substr(all, html.find("</table>", all) - all);
  const size_t md_all = md.find("## All levels");
  const std::string md_table = md.substr(md_all, md.find("\n## ", md_all + 1) - md_all);
  const std::regex verdict(
      "(tied: )?([A-Za-z0-9_]+) (?:>|≈) ([A-Za-z0-9_]+) \\(p = ([^,]+), n = ([0-9]+)\\)");
  int verdicts = 0;
  for (auto it = std::sregex_iterator(md_table.begin(), md_table.end(), verdict);
       it != std::sregex_iterator(); ++it, ++verdicts) {
    const bool tied = (*it)[1].matched;
    const std::string expected = std::string(tied ? "≈ " : "▲ ") + (*it)[2].str() +
                                 (tied ? " ≈ " : " > ") + (*it)[3].str() +
                                 "<br>p = " + (*it)[4].str() + ", n = " + (*it)[5].str();
    EXPECT_NE(table.find(expected), std::string::npos) << expected << "\n" << table;
    // The cell marks: a significant best is bold with ▲, a tie underlines both.
    EXPECT_NE(table.find(tied ? "</u>&nbsp;≈" : "</b>&nbsp;▲"), std::string::npos);
  }
  EXPECT_EQ(verdicts, 3) << md_table;  // one per metric
}

// Every link of the page names a plain file of the folder, also for a page written elsewhere.
TEST_F(ReportPage, EveryLinkResolves) {
  ASSERT_EQ(report_->exit_code, 0) << report_->err;
  fs::create_directories(dir_->File("pages/sub"));
  const CliRun elsewhere =
      RunTurbid({"report", dir_->File("out"), "--out", dir_->File("pages/sub/r.html")});
  ASSERT_EQ(elsewhere.exit_code, 0) << elsewhere.err;
  for (const std::string& page : {dir_->File("out/report.html"), dir_->File("pages/sub/r.html")}) {
    const std::string html = ReadFileText(page);
    const std::vector<std::string> links = FileLinks(html);
    int svgs = 0, pngs = 0;
    for (const std::string& link : links) {
      const fs::path file = fs::path(page).parent_path() / UrlDecode(link);
      EXPECT_TRUE(fs::is_regular_file(file)) << page << ": " << link;
      svgs += link.size() > 4 && link.substr(link.size() - 4) == ".svg";
      pngs += link.size() > 4 && link.substr(link.size() - 4) == ".png";
    }
    EXPECT_EQ(svgs, 4 * 3) << page;  // img, its link and the caption's "SVG" link per plot
    // 4 items x (clean, degraded, oracle, full, clahe, dcp), link and thumbnail each.
    EXPECT_EQ(pngs, 4 * 6 * 2) << page;
  }
}

bool HaveChromium() { return std::system("command -v chromium >/dev/null 2>&1") == 0; }

// Opens `page` + `hash` in headless Chromium at 1280 x 900 and returns the attributes the page's
// self-check (#check) writes on <body>.
std::map<std::string, std::string> BrowserCheck(const TempDir& dir, const std::string& page,
                                                const std::string& hash) {
  const std::string dom = dir.File("dom.html");
  const std::string command =
      "timeout 120 chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
      "--disable-background-networking --disable-component-update --disable-sync "
      "--window-size=1280,900 --user-data-dir=" +
      dir.File("chromium") + " --virtual-time-budget=10000 --dump-dom 'file://" + page + hash +
      "' >" + dom + " 2>/dev/null";
  std::map<std::string, std::string> attributes;
  if (std::system(command.c_str()) != 0) return attributes;
  const std::string text = ReadFileText(dom);
  std::smatch body;
  if (!std::regex_search(text, body, std::regex("<body([^>]*)>"))) return attributes;
  const std::string tag = body[1];
  const std::regex attr("data-([a-z-]+)=\"([^\"]*)\"");
  for (auto it = std::sregex_iterator(tag.begin(), tag.end(), attr); it != std::sregex_iterator();
       ++it)
    attributes[(*it)[1]] = (*it)[2];
  return attributes;
}

TEST_F(ReportPage, LoadsInHeadlessChromiumAt1280WithoutOverflow) {
  ASSERT_EQ(report_->exit_code, 0) << report_->err;
  if (!HaveChromium()) {
    GTEST_SKIP() << "chromium not installed: skipping the browser check of the report";
  }
  const std::string page = dir_->File("out/report.html");
  for (const std::string hash :
       {"#check", "#check&view=hull-c0001/3/slider", "#check&view=seafloor-c0000/2"}) {
    std::map<std::string, std::string> a = BrowserCheck(*dir_, page, hash);
    ASSERT_EQ(a["check"], "done") << hash << ": the page's check did not finish";
    // 4 plots + 4 items x (clean, degraded, oracle, full, clahe, dcp).
    EXPECT_EQ(a["images"], "28") << hash;
    EXPECT_EQ(a["broken-images"], "0") << hash;
    EXPECT_EQ(a["links"], "24") << hash;
    EXPECT_EQ(a["broken-links"], "0") << hash;
    EXPECT_EQ(a["plots"], "4") << hash;
    EXPECT_EQ(a["overflow-px"], "0") << hash << ": the page is wider than 1280 px";
    EXPECT_EQ(a["viewer-open"], hash == "#check" ? "0" : "1") << hash;
  }
}

// The check is not vacuous: a page with a 2000 px wide element and a deleted image fails it.
TEST_F(ReportPage, BrowserCheckCatchesOverflowAndBrokenImages) {
  ASSERT_EQ(report_->exit_code, 0) << report_->err;
  if (!HaveChromium()) {
    GTEST_SKIP() << "chromium not installed: skipping the browser check of the report";
  }
  TempDir copy;
  fs::copy(dir_->File("out"), copy.File("out"), fs::copy_options::recursive);
  std::string html = ReadFileText(copy.File("out/report.html"));
  html.replace(html.find("<h1>"), 0, "<div style=\"width:2000px\">wide</div>");
  std::ofstream(copy.File("out/report.html"), std::ios::binary) << html;
  fs::remove(copy.File("out/thumbs/hull-c0000/clahe.png"));
  std::map<std::string, std::string> a = BrowserCheck(copy, copy.File("out/report.html"), "#check");
  ASSERT_EQ(a["check"], "done");
  EXPECT_GT(std::stoi(a["overflow-px"]), 600);
  EXPECT_EQ(a["broken-images"], "1");
  EXPECT_EQ(a["broken-links"], "1");
  EXPECT_EQ(a["plots"], "4");
}

}  // namespace
}  // namespace turbid
