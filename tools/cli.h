// The `turbid` command line as a library: main() is a thin wrapper over RunCli so that every
// subcommand can be driven from tests.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace turbid {

// Parses argv, runs the chosen subcommand, returns the process exit status. turbid::Error and
// other exceptions are caught here, printed as one line "turbid: error: <message>" on stderr, and
// turned into exit status 1 (2 for usage errors).
int RunCli(int argc, const char* const* argv);
int RunCli(const std::vector<std::string>& args);  // args[0] is the program name

// RunCli's parsing and error handling for any app (turbid, turbid_bench).
int RunApp(CLI::App& app, int argc, const char* const* argv);

// Thrown by a subcommand that ends with a non-zero exit status and has printed its message.
struct ExitStatus {
  int code;
};

// Each subcommand family adds itself to the app; defined in tools/cmd_<family>.cc.
void AddSceneCommand(CLI::App& app);
void AddRenderCommands(CLI::App& app);   // render, generate
void AddEnhanceCommand(CLI::App& app);
void AddScoreCommand(CLI::App& app);
void AddHarnessCommands(CLI::App& app);  // sweep, merge, regress, report
// `turbid bench` runs the turbid_bench executable beside turbid with the arguments that follow
// `bench` (tools/bench_launcher.cc): only that executable links Google Benchmark and the OpenCV
// contrib peers. AddBenchCommand (tools/cmd_bench.cc) is the real command, in turbid_bench.
inline constexpr const char* kBenchDescription =
    "time the speed goals: ours against the peer (OpenCV) in one process";
inline constexpr const char* kBenchExecutable = "turbid_bench";
void AddBenchLauncher(CLI::App& app);
void AddBenchCommand(CLI::App& app);

}  // namespace turbid
