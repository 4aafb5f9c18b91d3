// The `turbid` command line as a library: main() is a thin wrapper over RunCli so that every
// subcommand can be driven from tests.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "core/error.h"

namespace turbid {

// Parses argv, runs the chosen subcommand, returns the process exit status. turbid::Error and
// other exceptions (std::bad_alloc: "out of memory while running 'turbid CMD'", cv::Exception: the
// OpenCV function and check that failed) are caught here, printed as one line
// "turbid: error: <message>" on stderr, and turned into exit status 1 (2 for usage errors and bad
// option values, also one line). Every option's value is checked before any command runs: numeric
// options take only plain decimal numbers in their type's range (not '', '0.3x', '0x10', 'nan' or
// out-of-range integers, which CLI11 would read as 0, a prefix or a saturated value), and no option
// takes an empty value.
int RunCli(int argc, const char* const* argv);
int RunCli(const std::vector<std::string>& args);  // args[0] is the program name

// RunCli's parsing and error handling for any app (turbid, turbid_bench).
int RunApp(CLI::App& app, int argc, const char* const* argv);

// Marks an option whose value is a file or folder: an empty value is refused as
// "empty path given for NAME" (instead of meaning "not given", or ": file not found").
CLI::Option* PathOption(CLI::Option* option);

// CLI::Range that also refuses what CLI11 would misread ('', '1.5' for an integer, '0x10', 'nan').
CLI::Option* InRange(CLI::Option* option, double lo, double hi);

// `text` as a finite decimal number (the check numeric options get), else UsageError naming
// `name`; for options that split their value themselves ("R,G,B").
double ParseDecimalOption(const std::string& name, const std::string& text);

// A bad value on the command line (exit status 2, like CLI11's own usage errors).
struct UsageError : Error {
  using Error::Error;
};

// Thrown by a subcommand that ends with a non-zero exit status and has printed its message.
struct ExitStatus {
  int code;
};

// Each subcommand family adds itself to the app; defined in tools/cmd_<family>.cc.
void AddSceneCommand(CLI::App& app);
void AddSequenceCommand(CLI::App& app);  // tools/cli/cmd_sequence.cc
void AddRenderCommand(CLI::App& app);
void AddWaterCommand(CLI::App& app);
void AddGenerateCommand(CLI::App& app);  // also in tools/cli/cmd_render.cc
void AddEnhanceCommand(CLI::App& app);
void AddScoreCommand(CLI::App& app);
void AddHarnessCommands(CLI::App& app);  // sweep, merge, regress, report
// `turbid bench` runs the turbid_bench executable beside turbid with the arguments that follow
// `bench` (tools/bench/bench_launcher.cc): only that executable links Google Benchmark and the
// OpenCV contrib peers. AddBenchCommand (tools/bench/cmd_bench.cc) is the real command, in
// turbid_bench.
inline constexpr const char* kBenchDescription =
    "time the speed goals: ours against the peer (OpenCV) in one process";
inline constexpr const char* kBenchExecutable = "turbid_bench";
void AddBenchLauncher(CLI::App& app);
void AddBenchCommand(CLI::App& app);

}  // namespace turbid
