// External enhancement methods in a sweep: a user's program run as a child process (one process
// per batch of items, or one per image), or a folder of precomputed results. Experiment-file
// schema and the failure rules: docs/experiments.md, "External methods".
//
// Processes are started with posix_spawnp (no shell) in their own process group, with stdin from
// /dev/null and stdout + stderr to a log file; a timeout kills the whole group. External methods
// see only the degraded image (they are never privileged).
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <map>
#include <string>
#include <vector>

namespace turbid {

// One child process: what to run, where, with which environment and time limit.
struct ProcessOptions {
  std::vector<std::string> argv;  // argv[0] is looked up in PATH when it has no '/'
  std::string cwd;                // working directory ("" = the caller's)
  std::map<std::string, std::string> env;  // added to (or replacing in) the caller's environment
  double timeout_s = 600.0;       // wall-clock limit in (0, 604800]; the process group is killed
  std::string log_path;           // stdout and stderr go here (truncated); required
  bool Check(std::string* why) const;
};

struct ProcessResult {
  bool started = false;    // false: the program could not be started (start_error says why)
  std::string start_error;
  bool timed_out = false;  // killed by the timeout
  int exit_code = -1;      // when it exited normally
  int signal = 0;          // when a signal ended it
  double wall_ms = 0.0;    // from start to exit
  // One line: "" when it started, exited 0 and did not time out; otherwise what went wrong, with
  // the log's last non-empty line.
  std::string Failure() const;
  std::string log_tail;  // the last non-empty line of the log (at most 300 characters)
};

// Runs the process to completion (or to its timeout: SIGTERM to the group, SIGKILL 2 s later).
// Any process left in the group when the main process exits is killed too. Thread-safe.
ProcessResult RunProcess(const ProcessOptions& options);

// The resolved external-method spec, i.e. what experiment.json records:
//   {"kind": "command", "command": [...], "batch": bool, "batch_size": n,
//    "input": {"format", "bits", "encoding"}, "output": {"format", "encoding"},
//    "timeout_s": s, "cwd": "...", "env": {...}}
//   {"kind": "results", "results": "path/{id}.png", "encoding": "srgb" | "linear"}
//   {"kind": "python", "python": KEY, "batch": bool, ["batch_size": n,] "encoding": "linear" |
//    "srgb"}: a callable passed to turbid.sweep(..., methods={KEY: f}) by the Python package
//    (python/src/module.cc); the CLI cannot run it (HarnessRunner refuses it up front)
// Parses the method object of an experiment file (keys other than name/label); throws
// Error(problem) (the caller adds the file and the method).
nlohmann::json ParseExternalMethodSpec(const nlohmann::json& method);
// Whether an experiment method object describes an external method ("command", "results" or
// "python").
bool IsExternalMethodObject(const nlohmann::json& method);

// Replaces {input_dir}, {output_dir}, {input}, {output} and {id} in every argument.
std::vector<std::string> ExpandCommand(const nlohmann::json& command,
                                       const std::map<std::string, std::string>& values);

// Writes a linear [0, 1] image as a method input in the spec's "input" format and encoding.
void WriteMethodInput(const std::string& path, const cv::Mat& linear, const nlohmann::json& input);
// File extension (with the dot) of the spec's input / output format.
std::string InputExtension(const nlohmann::json& spec);
std::string OutputExtension(const nlohmann::json& spec);

// Reads a method output and checks it against the degraded image it was made from: same size and
// channel count, every value finite. Integer files are decoded with `encoding` ("srgb" or
// "linear"), float files (PFM, EXR, float TIFF) are taken as linear; values are clipped to [0, 1].
// Throws Error("<path>: <reason>").
cv::Mat ReadMethodOutput(const std::string& path, const std::string& encoding,
                         const cv::Mat& degraded);

// The checks of ReadMethodOutput on an image already in memory (any depth; integer images are not
// rescaled): size and channels as `degraded`, every value finite; returns float32 clipped to
// [0, 1]. Throws Error("<where>: <reason>"), or Error("<reason>") when `where` is empty.
cv::Mat CheckMethodOutput(const cv::Mat& image, const cv::Mat& degraded, const std::string& where);

// The file in `dir` named "<id>.<extension>" (any extension ReadImage reads); "" when none.
// Throws Error when several match.
std::string FindOutputFile(const std::string& dir, const std::string& id);

}  // namespace turbid
