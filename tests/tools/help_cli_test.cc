// `turbid --help`, every subcommand's --help and `turbid score --list` read cleanly (issue 36,
// item 5): subcommands in the order a newcomer uses them, one description style, one value shown
// per repeatable option, aligned columns, and one working example per subcommand.
#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/test_support.h"

namespace turbid {
namespace {

using testing::RunTurbid;
using testing::TempDir;

const std::vector<std::string> kNewcomerOrder = {
    "scene", "sequence", "render", "water",  "enhance", "score",
    "sweep", "merge",    "regress", "report", "generate", "bench"};

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> Words(const std::string& text) {
  std::vector<std::string> words;
  std::istringstream in(text);
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

// The lines of `help` under the heading `title` ("Subcommands:", "Options:"), up to a blank line.
std::vector<std::string> Section(const std::string& help, const std::string& title) {
  std::vector<std::string> section;
  bool inside = false;
  for (const std::string& line : Lines(help)) {
    if (line == title) {
      inside = true;
    } else if (inside) {
      if (line.empty()) break;
      section.push_back(line);
    }
  }
  return section;
}

TEST(HelpCli, TopLevelListsSubcommandsInNewcomerOrderInOneStyle) {
  const auto run = RunTurbid({"--help"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::vector<std::string> names;
  for (const std::string& line : Section(run.out, "Subcommands:")) {
    const std::vector<std::string> words = Words(line);
    ASSERT_GE(words.size(), 2u) << line;
    names.push_back(words[0]);
    // Lower-case phrase, no final period.
    const std::string description = line.substr(line.find(words[1]));
    EXPECT_TRUE(std::islower(static_cast<unsigned char>(description[0]))) << line;
    EXPECT_NE(description.back(), '.') << line;
  }
  EXPECT_EQ(names, kNewcomerOrder) << run.out;
}

TEST(HelpCli, RepeatableOptionsShowOneValuePerFlag) {
  for (const std::string& command : kNewcomerOrder) {
    const auto run = RunTurbid({command, "--help"});
    ASSERT_EQ(run.exit_code, 0) << command << ": " << run.err;
    for (const std::string& line : Section(run.out, "Options:")) {
      // "--set TEXT ..." reads as several values after one --set; each takes one.
      EXPECT_EQ(line.find(" ..."), std::string::npos) << command << ": " << line;
    }
  }
  EXPECT_NE(RunTurbid({"render", "--help"}).out.find("--set KEY=VALUE "), std::string::npos);
  EXPECT_NE(RunTurbid({"enhance", "--help"}).out.find("--param KEY=VALUE "), std::string::npos);
  EXPECT_NE(RunTurbid({"regress", "--help"}).out.find("--tol METRIC=ABS[:REL] "),
            std::string::npos);
  EXPECT_NE(RunTurbid({"scene", "--help"}).out.find("--builtin NAME "), std::string::npos);
  // Still one value per flag, and repeatable.
  const auto two =
      RunTurbid({"render", "--scene", "builtin:seafloor", "--scale", "0.1", "--set",
                 "psf.forward_scatter=0.9", "--set", "psf.forward_scatter=0.5", "--explain"});
  EXPECT_EQ(two.exit_code, 0) << two.err;
}

TEST(HelpCli, ScoreListColumnsAreAligned) {
  const auto run = RunTurbid({"score", "--list"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<std::string> lines = Lines(run.out);
  ASSERT_GT(lines.size(), 5u);
  const size_t needs = lines[0].find("needs"), summary = lines[0].find("summary");
  ASSERT_EQ(lines[0].rfind("metric", 0), 0u) << lines[0];
  ASSERT_NE(needs, std::string::npos);
  ASSERT_NE(summary, std::string::npos);
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    ASSERT_GT(line.size(), summary) << line;
    // Every column starts at its heading, after at least two blanks.
    for (const size_t column : {needs, summary}) {
      EXPECT_EQ(line.substr(column - 2, 2), "  ") << line;
      EXPECT_NE(line[column], ' ') << line;
    }
    const std::vector<std::string> needed = Words(line.substr(needs, summary - needs));
    ASSERT_EQ(needed.size(), 1u) << line;
    EXPECT_TRUE(needed[0] == "--ref" || needed[0] == "--original" || needed[0] == "-") << line;
  }
}

// Every subcommand's help ends with exactly one example, and the examples, run in the order of
// `turbid --help` in an empty folder, all work: each uses the files earlier ones wrote, plus a
// small experiment at scenes/experiments/demo.json, a small dataset.json and the two shards merge
// combines, written here.
TEST(HelpCli, EverySubcommandHasOneExampleThatWorks) {
  TempDir dir;
  std::filesystem::create_directories(dir.File("scenes/experiments"));
  dir.Write("scenes/experiments/demo.json", R"({"name": "demo", "seed": 1, "scale": 0.1,
    "scenes": ["builtin:seafloor"],
    "grid": {"@turbidity": [{"label": "0.3", "x": 0.3, "water.beta_gray_per_m": 0.3},
                            {"label": "1.0", "x": 1.0, "water.beta_gray_per_m": 1.0}]},
    "methods": ["clahe"], "metrics": ["ssim", "cnr"], "ground_truth": "clean"})");
  dir.Write("dataset.json", R"({"scenes": ["builtin:seafloor"], "scale": 0.1, "seed": 5,
    "grid": {"water.type": ["IB", "3C"]}})");
  struct InFolder {  // the examples' relative paths are in `dir`; back on every exit
    std::filesystem::path here = std::filesystem::current_path();
    explicit InFolder(const std::string& path) { std::filesystem::current_path(path); }
    ~InFolder() { std::filesystem::current_path(here); }
  } in_folder(dir.path());
  for (const std::string& command : kNewcomerOrder) {
    const auto help = RunTurbid({command, "--help"});
    ASSERT_EQ(help.exit_code, 0) << command << ": " << help.err;
    std::vector<std::string> examples;
    for (const std::string& line : Lines(help.out))
      if (line.rfind("Example:", 0) == 0) examples.push_back(line);
    ASSERT_EQ(examples.size(), 1u) << command << ":\n" << help.out;
    std::vector<std::string> args = Words(examples[0].substr(std::string("Example:").size()));
    ASSERT_GE(args.size(), 3u) << examples[0];
    EXPECT_EQ(args[0], "turbid") << examples[0];
    EXPECT_EQ(args[1], command) << examples[0];
    EXPECT_EQ(examples[0].find_first_of("'\"\\$"), std::string::npos)
        << "examples are plain words: " << examples[0];
    args.erase(args.begin());
    if (command == "merge") {
      for (const char* shard : {"0", "1"}) {
        const auto sweep = RunTurbid({"sweep", "scenes/experiments/demo.json", "--shard",
                                      std::string(shard) + "/2", "--out",
                                      std::string("demo_shard") + shard, "--quiet"});
        ASSERT_EQ(sweep.exit_code, 0) << sweep.err;
      }
    }
    const auto run = RunTurbid(args);
    EXPECT_EQ(run.exit_code, 0) << examples[0] << "\n" << run.out << run.err;
  }
}

}  // namespace
}  // namespace turbid
