#include "tools/harness/external_method.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <thread>

#include "core/error.h"
#include "scenes/image_io.h"

extern char** environ;

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The last non-empty line of a (possibly large) log file, at most 300 characters.
std::string LogTail(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return "";
  const std::streamoff size = in.tellg();
  const std::streamoff start = std::max<std::streamoff>(0, size - 4096);
  in.seekg(start);
  std::string text(static_cast<size_t>(size - start), '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) {
    text.pop_back();
  }
  const size_t newline = text.find_last_of("\r\n");
  std::string line = newline == std::string::npos ? text : text.substr(newline + 1);
  for (char& c : line) {
    if (static_cast<unsigned char>(c) < 0x20) c = ' ';
  }
  if (line.size() > 300) line = "..." + line.substr(line.size() - 297);
  return line;
}

// Waits up to `seconds` for the child to exit without reaping it (waitid WNOWAIT), so that its
// pid, and with it the process-group id, cannot be reused while the group is signalled.
bool WaitExited(pid_t pid, double seconds) {
  const auto start = Clock::now();
  int sleep_us = 1000;
  while (true) {
    siginfo_t info{};
    const int rc = ::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT);
    if (rc == 0 && info.si_pid == pid) return true;
    if (rc != 0 && errno != EINTR) return true;  // no such child: nothing left to wait for
    if (seconds >= 0 && SecondsSince(start) >= seconds) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(sleep_us));
    sleep_us = std::min(sleep_us * 2, 50000);
  }
}

}  // namespace

bool ProcessOptions::Check(std::string* why) const {
  if (argv.empty() || argv.front().empty()) {
    *why = "the command is empty";
    return false;
  }
  if (!(timeout_s > 0.0) || timeout_s > 604800.0) {
    *why = "timeout_s must be in (0, 604800]";
    return false;
  }
  if (log_path.empty()) {
    *why = "a log path is required";
    return false;
  }
  for (const auto& [key, value] : env) {
    if (key.empty() || key.find('=') != std::string::npos) {
      *why = "environment name '" + key + "' is empty or holds '='";
      return false;
    }
  }
  return true;
}

std::string ProcessResult::Failure() const {
  std::string why;
  if (!started) {
    why = "cannot start: " + start_error;
  } else if (timed_out) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "timed out after %.3g s (process group killed)",
                  wall_ms / 1000.0);
    why = buffer;
  } else if (signal != 0) {
    why = "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  } else if (exit_code != 0) {
    why = "exit status " + std::to_string(exit_code);
  } else {
    return "";
  }
  if (!log_tail.empty()) why += ": " + log_tail;
  return why;
}

ProcessResult RunProcess(const ProcessOptions& options) {
  ThrowIfInvalid(options, "external method");
  ProcessResult result;
  std::error_code ec;
  fs::create_directories(fs::path(options.log_path).parent_path(), ec);
  const int log_fd =
      ::open(options.log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (log_fd < 0) {
    throw OutputError(options.log_path,
                      std::string("cannot open the log: ") + std::strerror(errno));
  }

  // Environment: the caller's, with the method's names added or replaced.
  std::vector<std::string> env_strings;
  for (char** entry = environ; entry != nullptr && *entry != nullptr; ++entry) {
    const std::string text = *entry;
    const std::string name = text.substr(0, text.find('='));
    if (!options.env.count(name)) env_strings.push_back(text);
  }
  for (const auto& [name, value] : options.env) env_strings.push_back(name + "=" + value);
  std::vector<char*> envp;
  for (std::string& text : env_strings) envp.push_back(text.data());
  envp.push_back(nullptr);
  std::vector<std::string> args = options.argv;
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, log_fd, STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, log_fd, STDERR_FILENO);
  if (!options.cwd.empty()) posix_spawn_file_actions_addchdir_np(&actions, options.cwd.c_str());
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t no_signals, default_signals;
  sigemptyset(&no_signals);
  sigemptyset(&default_signals);
  for (int s : {SIGPIPE, SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGCHLD}) sigaddset(&default_signals, s);
  posix_spawnattr_setsigmask(&attributes, &no_signals);
  posix_spawnattr_setsigdefault(&attributes, &default_signals);
  posix_spawnattr_setpgroup(&attributes, 0);  // its own group: a timeout kills its children too
  posix_spawnattr_setflags(&attributes,
                           POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  pid_t pid = 0;
  const auto start = Clock::now();
  const int rc = ::posix_spawnp(&pid, argv[0], &actions, &attributes, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  ::close(log_fd);
  if (rc != 0) {
    result.start_error = "'" + options.argv[0] + "': " + std::strerror(rc);
    if (!options.cwd.empty()) result.start_error += " (working directory " + options.cwd + ")";
    return result;
  }
  result.started = true;
  if (!WaitExited(pid, options.timeout_s)) {
    result.timed_out = true;
    ::kill(-pid, SIGTERM);
    if (!WaitExited(pid, 2.0)) ::kill(-pid, SIGKILL);
  }
  WaitExited(pid, -1.0);
  ::kill(-pid, SIGKILL);  // whatever it left running in its group
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  result.wall_ms = SecondsSince(start) * 1000.0;
  if (WIFEXITED(status)) result.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) result.signal = WTERMSIG(status);
  result.log_tail = LogTail(options.log_path);
  return result;
}

bool IsExternalMethodObject(const json& method) {
  return method.is_object() &&
         (method.contains("command") || method.contains("results") || method.contains("python"));
}

std::vector<std::string> ExpandCommand(const json& command,
                                       const std::map<std::string, std::string>& values) {
  std::vector<std::string> out;
  for (const json& arg : command) {
    std::string text = arg.get<std::string>();
    for (const auto& [name, value] : values) {
      const std::string placeholder = "{" + name + "}";
      for (size_t at = text.find(placeholder); at != std::string::npos;
           at = text.find(placeholder, at + value.size())) {
        text.replace(at, placeholder.size(), value);
      }
    }
    out.push_back(text);
  }
  return out;
}

std::string InputExtension(const json& spec) {
  return "." + spec.at("input").at("format").get<std::string>();
}

std::string OutputExtension(const json& spec) {
  return "." + spec.at("output").at("format").get<std::string>();
}

void WriteMethodInput(const std::string& path, const cv::Mat& linear, const json& input) {
  WriteImageOptions options;
  options.overwrite = true;
  options.bit_depth = input.at("format") == "png" ? input.at("bits").get<int>() : 8;
  options.transfer = input.at("encoding") == "srgb" ? Transfer::kSrgb : Transfer::kLinear;
  WriteImage(path, linear, options);
}

cv::Mat ReadMethodOutput(const std::string& path, const std::string& encoding,
                         const cv::Mat& degraded) {
  ReadImageOptions options;
  options.transfer = encoding == "srgb" ? Transfer::kSrgb : Transfer::kLinear;
  return CheckMethodOutput(ReadImage(path, options), degraded, path);
}

cv::Mat CheckMethodOutput(const cv::Mat& image, const cv::Mat& degraded, const std::string& where) {
  const auto fail = [&](const std::string& problem) {
    return where.empty() ? Error(problem) : Error(where, problem);
  };
  if (image.empty()) throw fail("empty image");
  if (image.cols != degraded.cols || image.rows != degraded.rows) {
    throw fail("wrong size: " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
               ", the input is " + std::to_string(degraded.cols) + "x" +
               std::to_string(degraded.rows));
  }
  if (image.channels() != degraded.channels()) {
    throw fail("has " + std::to_string(image.channels()) + " channels, the input has " +
               std::to_string(degraded.channels()));
  }
  cv::Mat data;
  image.convertTo(data, CV_32F);
  size_t bad = 0;
  const size_t values = data.total() * static_cast<size_t>(data.channels());
  const cv::Mat flat = data.reshape(1, 1);
  const float* p = flat.ptr<float>(0);
  for (size_t i = 0; i < values; ++i) bad += !std::isfinite(p[i]);
  if (bad > 0) {
    throw fail(std::to_string(bad) + " non-finite values (NaN or inf) of " +
               std::to_string(values));
  }
  cv::min(cv::max(data, 0.0), 1.0, data);
  return data;
}

std::string FindOutputFile(const std::string& dir, const std::string& id) {
  std::vector<std::string> found;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path name = entry.path().filename();
    if (name.stem().string() == id && name.has_extension() && entry.is_regular_file()) {
      found.push_back(entry.path().string());
    }
  }
  if (found.size() > 1) {
    std::sort(found.begin(), found.end());
    throw Error(dir, "several outputs for item " + id + " (" + found[0] + ", " + found[1] + ")");
  }
  return found.empty() ? "" : found.front();
}

}  // namespace turbid
