// `turbid bench` in the turbid executable: runs turbid_bench (beside turbid) with the arguments
// after `bench` and ends with its exit status. turbid_bench holds the command itself
// (cmd_bench.cc), so that only it loads Google Benchmark and the OpenCV contrib peers
// (ximgproc, quality) that the benchmarks compare against.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "core/error.h"
#include "tools/cli/cli.h"

extern char** environ;

namespace turbid {
namespace {
namespace fs = std::filesystem;

std::string BenchExecutablePath() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw Error(std::string("cannot locate ") + kBenchExecutable + ": /proc/self/exe: " +
                      ec.message());
  return (self.parent_path() / kBenchExecutable).string();
}

int RunBenchExecutable(const std::string& program_name, const std::vector<std::string>& args) {
  const std::string path = BenchExecutablePath();
  if (::access(path.c_str(), X_OK) != 0)
    throw Error(path, std::string("`turbid bench` needs this executable (build the target ") +
                          kBenchExecutable + ")");
  // argv[0] is turbid's own name, so that usage lines read "turbid bench ...".
  std::vector<std::string> strings{program_name};
  strings.insert(strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& s : strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  std::cout.flush();
  std::cerr.flush();
  pid_t pid = 0;
  const int rc = ::posix_spawn(&pid, path.c_str(), nullptr, nullptr, argv.data(), environ);
  if (rc != 0) throw Error(path, std::string("cannot run: ") + std::strerror(rc));
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw Error(path, std::string("waitpid: ") + std::strerror(errno));
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

}  // namespace

void AddBenchLauncher(CLI::App& app) {
  CLI::App* cmd = app.add_subcommand("bench", kBenchDescription);
  // Every argument after `bench`, --help included, goes to turbid_bench unparsed.
  cmd->prefix_command();
  cmd->set_help_flag();
  cmd->callback([cmd] {
    const int code = RunBenchExecutable(cmd->get_parent()->get_name(), cmd->remaining());
    if (code != 0) throw ExitStatus{code};
  });
}

}  // namespace turbid
