// Helpers shared by every test suite.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace turbid::testing {

// A fresh empty folder under the system temp dir, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }
  // Writes `text` (bytes as they are) to File(name) and returns that path.
  std::string Write(const std::string& name, const std::string& text) const;

 private:
  std::string path_;
};

// $TURBID_DATA, or nullopt when unset or missing; tests then GTEST_SKIP() with a message.
std::optional<std::string> DataDir();

// Result of running the built `turbid` binary ($TURBID_BIN, set by CTest) with a shell.
struct CliRun {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};
CliRun RunTurbid(const std::vector<std::string>& args);

std::string ReadFileText(const std::string& path);

}  // namespace turbid::testing

// Skips the current test when $TURBID_DATA is not available.
#define TURBID_REQUIRE_DATA(var)                                                   \
  const auto var##_opt = ::turbid::testing::DataDir();                             \
  if (!var##_opt) GTEST_SKIP() << "TURBID_DATA not set: skipping real-data test"; \
  const std::string var = *var##_opt
