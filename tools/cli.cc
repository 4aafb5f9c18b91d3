#include "tools/cli.h"

#include <exception>
#include <iostream>

#include "scenes/error.h"
#include "turbid_version.h"

namespace turbid {

int RunCli(int argc, const char* const* argv) {
  CLI::App app{"turbid: underwater image degradation simulator, enhancers, metrics and sweeps"};
  app.set_version_flag("--version", std::string("turbid ") + TURBID_VERSION);
  app.require_subcommand(1);
  AddSceneCommand(app);
  AddRenderCommands(app);
  AddEnhanceCommand(app);
  AddScoreCommand(app);
  AddHarnessCommands(app);
  AddBenchLauncher(app);
  return RunApp(app, argc, argv);
}

int RunApp(CLI::App& app, int argc, const char* const* argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version are "successes"; every real usage error exits 2 (docs/cli.md),
    // not CLI11's own numbering.
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  } catch (const ExitStatus& e) {
    return e.code;
  } catch (const Error& e) {
    std::cerr << "turbid: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "turbid: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

int RunCli(const std::vector<std::string>& args) {
  std::vector<const char*> argv;
  argv.reserve(args.size());
  for (const std::string& arg : args) argv.push_back(arg.c_str());
  return RunCli(static_cast<int>(argv.size()), argv.data());
}

}  // namespace turbid
