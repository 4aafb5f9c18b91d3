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

// Each subcommand family adds itself to the app; defined in tools/cmd_<family>.cc.
void AddSceneCommand(CLI::App& app);
void AddRenderCommands(CLI::App& app);   // render, generate
void AddEnhanceCommand(CLI::App& app);
void AddScoreCommand(CLI::App& app);
void AddHarnessCommands(CLI::App& app);  // sweep, merge, regress, report
void AddBenchCommand(CLI::App& app);

}  // namespace turbid
