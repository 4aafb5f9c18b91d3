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

const std::set<std::string>& CommandKeys() {
  static const std::set<std::string> keys = {"name",  "label",  "command",   "batch", "batch_size",
                                             "input", "output", "timeout_s", "cwd",   "env"};
  return keys;
}

void CheckObjectKeys(const json& object, const std::set<std::string>& allowed,
                     const std::string& where) {
  for (const auto& [key, value] : object.items()) {
    if (!allowed.count(key)) {
      std::string list;
      for (const std::string& name : allowed) list += (list.empty() ? "" : ", ") + name;
      throw Error("unknown key '" + key + "' in " + where + " (allowed: " + list + ")");
    }
  }
}

bool IsFloatFormat(const std::string& format) { return format == "pfm" || format == "exr"; }

std::string ParseEncoding(const json& value, const std::string& where) {
  if (!value.is_string() || (value != "srgb" && value != "linear")) {
    throw Error(where + " must be \"srgb\" or \"linear\", got " + value.dump());
  }
  return value.get<std::string>();
}

std::string ParseFormat(const json& value, const std::string& where) {
  if (!value.is_string() || (value != "png" && value != "pfm" && value != "exr")) {
    throw Error(where + " must be \"png\", \"pfm\" or \"exr\", got " + value.dump());
  }
  return value.get<std::string>();
}

bool CommandHas(const json& command, const std::string& placeholder) {
  for (const json& arg : command) {
    if (arg.get<std::string>().find(placeholder) != std::string::npos) return true;
  }
  return false;
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

namespace {

// "batch" and "batch_size" of a command or Python method.
void ParseBatch(const json& method, bool* batch, int* batch_size) {
  *batch = false;
  if (method.contains("batch")) {
    if (!method["batch"].is_boolean()) throw Error("'batch' must be true or false");
    *batch = method["batch"].get<bool>();
  }
  *batch_size = 32;
  if (method.contains("batch_size")) {
    const json& value = method["batch_size"];
    if (!*batch) throw Error("'batch_size' applies to \"batch\": true methods only");
    if (!value.is_number_integer() || value.get<int64_t>() < 1 || value.get<int64_t>() > 100000) {
      throw Error("'batch_size' must be an integer in [1, 100000]");
    }
    *batch_size = value.get<int>();
  }
}

json ParsePythonMethod(const json& method) {
  CheckObjectKeys(method, {"name", "label", "python", "batch", "batch_size", "encoding"},
                  "a Python method");
  const json& key = method["python"];
  if (!key.is_string() || key.get<std::string>().empty()) {
    throw Error("'python' must be the key of the callable in turbid.sweep(..., methods={...})");
  }
  bool batch = false;
  int batch_size = 32;
  ParseBatch(method, &batch, &batch_size);
  json spec = {
      {"kind", "python"},
      {"python", key},
      {"batch", batch},
      {"encoding", method.contains("encoding") ? ParseEncoding(method["encoding"], "'encoding'")
                                               : std::string("linear")}};
  if (batch) spec["batch_size"] = batch_size;
  return spec;
}

json ParseResultsMethod(const json& method) {
  CheckObjectKeys(method, {"name", "label", "results", "encoding"}, "a results method");
  const json& pattern = method["results"];
  if (!pattern.is_string() || pattern.get<std::string>().find("{id}") == std::string::npos) {
    throw Error("'results' must be a path pattern holding {id}, e.g. \"results/x/{id}.png\"");
  }
  return {{"kind", "results"},
          {"results", pattern},
          {"encoding", method.contains("encoding") ? ParseEncoding(method["encoding"], "'encoding'")
                                                   : std::string("srgb")}};
}

// "command": a non-empty array of strings naming a program.
const json& ParseCommandArray(const json& method) {
  const json& command = method["command"];
  if (!command.is_array() || command.empty()) {
    throw Error("'command' must be a non-empty array of strings (the program and its arguments)");
  }
  for (const json& arg : command) {
    if (!arg.is_string()) throw Error("'command' arguments must be strings, got " + arg.dump());
  }
  if (command[0].get<std::string>().empty()) throw Error("'command' names no program");
  return command;
}

// A per-image command names {input} and {output}; a batch command {input_dir} and {output_dir}.
void CheckPlaceholders(const json& command, bool batch) {
  const char* need_a = batch ? "{input_dir}" : "{input}";
  const char* need_b = batch ? "{output_dir}" : "{output}";
  const char* wrong_a = batch ? "{input}" : "{input_dir}";
  const char* wrong_b = batch ? "{output}" : "{output_dir}";
  for (const char* wrong : {wrong_a, wrong_b}) {
    if (CommandHas(command, wrong)) {
      throw Error(std::string("'command' holds ") + wrong + ", which " +
                  (batch ? "needs \"batch\": false" : "needs \"batch\": true"));
    }
  }
  for (const char* need : {need_a, need_b}) {
    if (!CommandHas(command, need)) {
      throw Error(std::string("'command' must contain ") + need +
                  (batch ? " (\"batch\": true: one process per batch of items)"
                         : " (\"batch\": false: one process per image)"));
    }
  }
}

// "input": the files the command reads {format, bits, encoding}.
json ParseInputSpec(const json& method) {
  json input = {{"format", "png"}, {"bits", 8}, {"encoding", "srgb"}};
  if (!method.contains("input")) return input;
  const json& spec = method["input"];
  if (!spec.is_object()) throw Error("'input' must be an object {format, bits, encoding}");
  CheckObjectKeys(spec, {"format", "bits", "encoding"}, "'input'");
  if (spec.contains("format")) input["format"] = ParseFormat(spec["format"], "'input.format'");
  const bool is_float = IsFloatFormat(input["format"]);
  input["bits"] = is_float ? 32 : 8;
  input["encoding"] = is_float ? "linear" : "srgb";
  if (spec.contains("bits")) {
    const json& bits = spec["bits"];
    const bool ok = bits.is_number_integer() && (is_float ? bits == 32 : (bits == 8 || bits == 16));
    if (!ok) {
      throw Error(std::string("'input.bits' must be ") + (is_float ? "32" : "8 or 16") + " for " +
                  input["format"].get<std::string>() + ", got " + bits.dump());
    }
    input["bits"] = bits;
  }
  if (spec.contains("encoding")) {
    input["encoding"] = ParseEncoding(spec["encoding"], "'input.encoding'");
    if (is_float && input["encoding"] != "linear") {
      throw Error("'input.encoding' of a float format (pfm, exr) must be \"linear\"");
    }
  }
  return input;
}

// "output": the files the command writes {format, encoding}. The output encoding applies to
// integer files only (float files are linear); by default the method answers in the encoding it
// was given.
json ParseOutputSpec(const json& method, const json& input) {
  json output = {{"format", input["format"]},
                 {"encoding", IsFloatFormat(input["format"]) ? "srgb" : input["encoding"]}};
  if (method.contains("output")) {
    const json& spec = method["output"];
    if (!spec.is_object()) throw Error("'output' must be an object {format, encoding}");
    CheckObjectKeys(spec, {"format", "encoding"}, "'output'");
    if (spec.contains("format")) output["format"] = ParseFormat(spec["format"], "'output.format'");
    if (spec.contains("encoding")) {
      output["encoding"] = ParseEncoding(spec["encoding"], "'output.encoding'");
    }
  }
  return output;
}

// "timeout_s", "cwd" and "env" of a command, into `spec`.
void ParseProcessKeys(const json& method, json* spec) {
  double timeout_s = 600.0;
  if (method.contains("timeout_s")) {
    const json& value = method["timeout_s"];
    if (!value.is_number() || !(value.get<double>() > 0.0) || value.get<double>() > 604800.0) {
      throw Error("'timeout_s' must be a number of seconds in (0, 604800]");
    }
    timeout_s = value.get<double>();
  }
  std::string cwd = ".";
  if (method.contains("cwd")) {
    if (!method["cwd"].is_string() || method["cwd"].get<std::string>().empty()) {
      throw Error("'cwd' must be a non-empty path string");
    }
    cwd = method["cwd"].get<std::string>();
  }
  json env = json::object();
  if (method.contains("env")) {
    if (!method["env"].is_object()) throw Error("'env' must be an object {NAME: \"value\"}");
    for (const auto& [name, value] : method["env"].items()) {
      if (name.empty() || name.find('=') != std::string::npos) {
        throw Error("'env' name '" + name + "' is empty or holds '='");
      }
      if (!value.is_string()) throw Error("'env' value of " + name + " must be a string");
      env[name] = value;
    }
  }
  (*spec)["timeout_s"] = timeout_s;
  (*spec)["cwd"] = cwd;
  (*spec)["env"] = env;
}

json ParseCommandMethod(const json& method) {
  CheckObjectKeys(method, CommandKeys(), "an external method");
  const json& command = ParseCommandArray(method);
  bool batch = false;
  int batch_size = 32;
  ParseBatch(method, &batch, &batch_size);
  CheckPlaceholders(command, batch);
  const json input = ParseInputSpec(method);
  const json output = ParseOutputSpec(method, input);
  json spec = {{"kind", "command"},
               {"command", command},
               {"batch", batch},
               {"input", input},
               {"output", output}};
  ParseProcessKeys(method, &spec);
  if (batch) spec["batch_size"] = batch_size;
  return spec;
}

}  // namespace

json ParseExternalMethodSpec(const json& method) {
  const int kinds = static_cast<int>(method.contains("command")) +
                    static_cast<int>(method.contains("results")) +
                    static_cast<int>(method.contains("python"));
  if (kinds > 1) {
    throw Error(
        "give one of 'command' (a program to run), 'results' (precomputed files) or 'python' (a "
        "callable passed to turbid.sweep)");
  }
  if (method.contains("python")) return ParsePythonMethod(method);
  if (method.contains("results")) return ParseResultsMethod(method);
  return ParseCommandMethod(method);
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
