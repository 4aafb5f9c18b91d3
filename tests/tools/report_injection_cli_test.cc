// `turbid report` on experiments whose strings are hostile (issue 28, item 1): level labels, the
// axis name, the experiment's description and the results folder's name
// carry gnuplot and shell payloads (backquotes, $(...), system(), quotes that try to close the
// string, backslashes, newlines, '%' and '@'). Every payload would create a file in a watched
// folder if it ran; the tests check that none does, that the plots are still made, and that the
// HTML page holds no markup from the data.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/test_support.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::ReadFileText;
using testing::RunTurbid;
using testing::TempDir;

// A payload that creates $TURBID_PWNED/<name> when a shell runs it. It holds no '/', so it is also
// a valid method label (labels name thumbnail files).
std::string Touch(const std::string& name) { return "cd $TURBID_PWNED; touch " + name; }

// JSON string literal of any text.
std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out + "\"";
}

// Files the payloads created (none expected).
std::string Created(const std::string& pwned) {
  std::string names;
  for (const auto& entry : fs::directory_iterator(pwned))
    names += entry.path().filename().string() + " ";
  return names;
}

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + 1)) ++n;
  return n;
}

class ReportInjection : public ::testing::Test {
 protected:
  void SetUp() override {
    pwned_ = dir_.File("pwned");
    fs::create_directories(pwned_);
    setenv("TURBID_PWNED", pwned_.c_str(), 1);
  }
  void TearDown() override { unsetenv("TURBID_PWNED"); }

  // An experiment of built-in methods only, whose strings are `axis`, `levels` and `method`.
  std::string Experiment(const std::string& axis, const std::vector<std::string>& levels,
                         const std::string& method_label) {
    std::string grid;
    double beta = 0.3;
    for (const std::string& level : levels) {
      grid += std::string(grid.empty() ? "" : ",\n") + "{\"label\": " + JsonString(level) +
              ", \"x\": " + std::to_string(beta) +
              ", \"water.beta_gray_per_m\": " + std::to_string(beta) + "}";
      beta += 0.5;
    }
    // (The name must be [A-Za-z0-9_.-]; the description is free text.)
    return "{\"name\": \"injection\",\n\"description\": " +
           JsonString("</pre><script>alert(2)</script> & 'q' \"dq\" `" + Touch("desc_bq") + "`") +
           ",\n\"seed\": 5, \"scale\": 0.1, \"scenes\": [\"builtin:hull\"],\n\"grid\": {" +
           JsonString(axis) + ": [" + grid + "]},\n\"methods\": [\"clahe\", {\"name\": \"dcp\", " +
           "\"label\": " + JsonString(method_label) +
           "}],\n\"metrics\": [\"ssim\", \"psnr\"], \"thumbnails\": 32}\n";
  }

  TempDir dir_;
  std::string pwned_;
};

// The payload form is live: gnuplot runs it from a double-quoted string (so the tests below would
// see a file if turbid still wrote such strings).
TEST_F(ReportInjection, PayloadRunsInADoubleQuotedGnuplotString) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) GTEST_SKIP() << "no gnuplot";
  const std::string gp = dir_.Write("live.gp", "set title \"x`" + Touch("live") + "`\"\n");
  ASSERT_EQ(std::system(("gnuplot '" + gp + "' 2>/dev/null").c_str()), 0);
  EXPECT_TRUE(fs::exists(pwned_ + "/live"));
}

TEST_F(ReportInjection, HostileLabelsAxisAndFolderRunNothingAndStillPlot) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) GTEST_SKIP() << "no gnuplot";
  const std::string axis =
      "@turb`" + Touch("axis_bq") + "`$(" + Touch("axis_dollar") + ") 'sq' \"dq\" \\\" @x %s %%";
  const std::vector<std::string> levels = {
      "low`" + Touch("level_bq") + "`",
      "mid\"; system(\"" + Touch("level_dq") + "\"); \"",
      "hi'; system('" + Touch("level_sq") + "'); '",
      "back\\\\\"; system(\"" + Touch("level_bs") + "\") #",
      "$(" + Touch("level_dollar") + ")",
      "@axis 100% <b>&amp;",  // (gnuplot cuts tic labels after about 50 characters)
      "<img src=x onerror=alert(3)> %s %d \\",
  };
  // Method labels must be [A-Za-z0-9_-] (they name thumbnail files): no payload fits there.
  const std::string method = "dcp_x";
  const std::string exp = dir_.Write("exp.json", Experiment(axis, levels, method));
  // The results folder's name is hostile too: it reaches gnuplot's `set output` and the shell.
  const std::string out =
      dir_.File("out `" + Touch("dir_bq") + "` $(" + Touch("dir_dollar") + ") 'q' \"d\" 100% \\");
  const CliRun sweep = RunTurbid({"sweep", exp, "--out", out, "--quiet"});
  ASSERT_EQ(sweep.exit_code, 0) << sweep.err;
  const CliRun report = RunTurbid({"report", out});
  ASSERT_EQ(report.exit_code, 0) << report.err;
  EXPECT_EQ(Created(pwned_), "") << "commands ran";
  // Both metric plots and run time vs ssim, from gnuplot without a failure.
  EXPECT_NE(report.out.find("(3 plots"), std::string::npos) << report.out << report.err;
  EXPECT_TRUE(report.err.empty()) << report.err;
  for (const char* svg : {"metric_ssim.svg", "metric_psnr.svg", "time_vs_metric.svg"}) {
    EXPECT_GT(fs::file_size(out + "/report/" + svg), 1000u) << svg;
  }
  // The labels are shown as they are (gnuplot's SVG terminal escapes XML).
  const std::string ssim = ReadFileText(out + "/report/metric_ssim.svg");
  EXPECT_NE(ssim.find("hi'; system('cd $TURBID_PWNED; touch level_sq'); '"), std::string::npos);
  EXPECT_NE(ssim.find("turb`cd $TURBID_PWNED; touch axis_bq`"), std::string::npos);
  // A tic label is a format for gnuplot: its '%' is shown once.
  EXPECT_NE(ssim.find(">@axis 100% &lt;b>&amp;amp;<"), std::string::npos);
  // The page: only turbid's own script element and image tags, every data string escaped.
  const std::string html = ReadFileText(out + "/report.html");
  EXPECT_EQ(Count(html, "<script"), 1) << "markup from the experiment reached the page";
  EXPECT_EQ(Count(html, "<img src=x"), 0);
  EXPECT_EQ(Count(html, "</pre><script"), 0);
  EXPECT_NE(html.find("&lt;img src=x onerror=alert(3)&gt;"), std::string::npos);
  EXPECT_EQ(Count(html, "<b>&amp;"), 0);
}

// A newline in a label or the axis name must not end a gnuplot command (`system(...)` on its own
// line). turbid may refuse such labels up front with one line; it must never run the line.
TEST_F(ReportInjection, NewlinesInLabelsDoNotBreakOutOfTheScript) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) GTEST_SKIP() << "no gnuplot";
  const std::string axis = "@turb\nsystem \"" + Touch("axis_nl") + "\"\nset title \"";
  const std::vector<std::string> levels = {"low\n!" + Touch("level_bang") + "\n",
                                           "high\nsystem('" + Touch("level_nl") + "')\n#"};
  const std::string method = "dcp_x";
  const std::string exp = dir_.Write("exp.json", Experiment(axis, levels, method));
  const std::string out = dir_.File("out\nsystem(\"" + Touch("dir_nl") + "\")\n");
  const CliRun sweep = RunTurbid({"sweep", exp, "--out", out, "--quiet"});
  if (sweep.exit_code != 0) {
    // Refused before any work: one line that names the file.
    EXPECT_EQ(Count(sweep.err, "\n"), 1) << sweep.err;
    EXPECT_NE(sweep.err.find("exp.json"), std::string::npos) << sweep.err;
    EXPECT_EQ(Created(pwned_), "");
    return;
  }
  const CliRun report = RunTurbid({"report", out});
  ASSERT_EQ(report.exit_code, 0) << report.err;
  EXPECT_EQ(Created(pwned_), "") << "commands ran";
  EXPECT_NE(report.out.find("(3 plots"), std::string::npos) << report.out << report.err;
  EXPECT_TRUE(report.err.empty()) << report.err;
  // The scripts are still one command per line: every line of the time plot's script is a known
  // command, nothing a label started.
  std::istringstream gp(ReadFileText(out + "/report/metric_ssim.gp"));
  std::string line;
  const std::regex command("^(set|unset|plot) .*");
  while (std::getline(gp, line)) EXPECT_TRUE(std::regex_match(line, command)) << line;
}

// A downloaded sweep folder may hold symbolic links where thumbnails belong; the report links only
// plain files the sweep wrote (a link planted there could point a shared page, or a copy of the
// folder made by following links, at any readable file of the user's).
TEST_F(ReportInjection, ThumbnailsThatAreLinksAreNotLinked) {
  const std::string exp = dir_.Write("exp.json", Experiment("@turbidity", {"low", "high"}, "dcp_x"));
  const std::string out = dir_.File("out");
  const CliRun sweep = RunTurbid({"sweep", exp, "--out", out, "--quiet"});
  ASSERT_EQ(sweep.exit_code, 0) << sweep.err;
  const std::string secret = dir_.Write("secret.txt", "SECRET-CONTENT-0123456789");
  // One thumbnail replaced by a link to the secret, and a whole item folder replaced by a link
  // to a folder of look-alike files.
  std::vector<fs::path> items;
  for (const auto& entry : fs::directory_iterator(out + "/thumbs"))
    if (fs::exists(entry.path() / "degraded.png")) items.push_back(entry.path());
  ASSERT_GE(items.size(), 2u);
  std::sort(items.begin(), items.end());
  fs::remove(items[0] / "dcp_x.png");
  fs::create_symlink(secret, items[0] / "dcp_x.png");
  const std::string decoy = dir_.File("decoy");
  fs::copy(items[1], decoy, fs::copy_options::recursive);
  for (const auto& entry : fs::directory_iterator(decoy)) {
    fs::remove(entry.path());
    fs::create_symlink(secret, entry.path());
  }
  fs::remove_all(items[1]);
  fs::create_directory_symlink(decoy, items[1]);
  const CliRun report = RunTurbid({"report", out});
  ASSERT_EQ(report.exit_code, 0) << report.err;
  const std::string html = ReadFileText(out + "/report.html");
  EXPECT_EQ(html.find("SECRET-CONTENT"), std::string::npos);
  EXPECT_EQ(html.find("data:"), std::string::npos);  // nothing is embedded
  // Neither the linked thumbnail nor anything in the linked folder is linked from the page.
  EXPECT_EQ(html.find(items[0].filename().string() + "/dcp_x.png"), std::string::npos);
  EXPECT_EQ(html.find(items[1].filename().string() + "/"), std::string::npos);
  // The other thumbnails are still there (a link and an image each).
  EXPECT_GE(Count(html, items[0].filename().string() + "/degraded.png"), 2);
}

}  // namespace
}  // namespace turbid
