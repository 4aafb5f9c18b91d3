// The documented keys of the harness's config files are the keys their field tables declare
// (issue 29: one declaration per key drives the reader, and the docs are checked against it).
// docs/experiments.md ("The experiment file") and docs/cli/render.md (`turbid generate`) list
// one key per row, or several in one row (`comment`, `$schema`), in the first cell.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "tools/harness/experiment.h"
#include "tools/harness/generate.h"

namespace turbid {
namespace {

std::string ReadDoc(const std::string& relative) {
  const std::filesystem::path path =
      std::filesystem::path(__FILE__).parent_path().parent_path().parent_path() / relative;
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << path;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The backquoted names in the first cell of each row of the first table after `heading`.
std::set<std::string> TableKeys(const std::string& doc, const std::string& heading) {
  std::set<std::string> keys;
  size_t at = doc.find(heading);
  EXPECT_NE(at, std::string::npos) << heading;
  if (at == std::string::npos) return keys;
  std::istringstream lines(doc.substr(at));
  std::string line;
  bool in_table = false;
  while (std::getline(lines, line)) {
    const bool row = line.rfind("| ", 0) == 0 || line.rfind("|-", 0) == 0;
    if (!row) {
      if (in_table) break;
      continue;
    }
    in_table = true;
    const size_t end = line.find(" |", 1);
    const std::string cell = line.substr(1, end == std::string::npos ? 0 : end - 1);
    for (size_t open = cell.find('`'); open != std::string::npos;) {
      const size_t close = cell.find('`', open + 1);
      if (close == std::string::npos) break;
      keys.insert(cell.substr(open + 1, close - open - 1));
      open = cell.find('`', close + 1);
    }
  }
  return keys;
}

TEST(ConfigKeysDocs, ExperimentFileTableListsEveryKey) {
  const std::vector<std::string> declared = ExperimentFileKeys();
  EXPECT_EQ(TableKeys(ReadDoc("docs/experiments.md"), "## The experiment file"),
            std::set<std::string>(declared.begin(), declared.end()));
}

TEST(ConfigKeysDocs, GenerateConfigTableListsEveryKey) {
  const std::vector<std::string> declared = GenerateConfigKeys();
  EXPECT_EQ(TableKeys(ReadDoc("docs/cli/render.md"), "## `turbid generate`"),
            std::set<std::string>(declared.begin(), declared.end()));
}

}  // namespace
}  // namespace turbid
