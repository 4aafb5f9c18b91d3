#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <sys/wait.h>

namespace turbid::testing {
namespace fs = std::filesystem;

TempDir::TempDir() {
  std::random_device device;
  std::ostringstream name;
  name << "turbid_test_" << std::hex << device() << device();
  path_ = (fs::temp_directory_path() / name.str()).string();
  fs::create_directories(path_);
}

std::string TempDir::Write(const std::string& name, const std::string& text) const {
  std::ofstream(File(name), std::ios::binary) << text;
  return File(name);
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::optional<std::string> DataDir() {
  const char* dir = std::getenv("TURBID_DATA");
  if (dir == nullptr || *dir == '\0') return std::nullopt;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return std::nullopt;
  return std::string(dir);
}

std::string ReadFileText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

namespace {
std::string ShellQuote(const std::string& arg) {
  std::string quoted = "'";
  for (char c : arg) {
    if (c == '\'') quoted += "'\\''";
    else quoted += c;
  }
  return quoted + "'";
}
}  // namespace

CliRun RunTurbid(const std::vector<std::string>& args) {
  const char* bin = std::getenv("TURBID_BIN");
  CliRun run;
  if (bin == nullptr) {
    ADD_FAILURE() << "TURBID_BIN is not set (run the tests through ctest)";
    return run;
  }
  TempDir io;
  std::string command = ShellQuote(bin);
  for (const std::string& arg : args) command += " " + ShellQuote(arg);
  command += " >" + ShellQuote(io.File("out")) + " 2>" + ShellQuote(io.File("err")) + " </dev/null";
  const int status = std::system(command.c_str());
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.out = ReadFileText(io.File("out"));
  run.err = ReadFileText(io.File("err"));
  return run;
}

}  // namespace turbid::testing
