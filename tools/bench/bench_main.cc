// turbid_bench: the `turbid bench` command (cmd_bench.cc) as its own executable, which turbid runs
// for `turbid bench ARGS` as `turbid_bench ARGS` (tools/bench/bench_launcher.cc).
#include <vector>

#include "core/atomic_file.h"
#include "tools/cli/cli.h"

int main(int argc, char** argv) {
  turbid::RemoveTemporaryFilesOnSignal();
  CLI::App app{"turbid: underwater image degradation simulator, enhancers, metrics and sweeps"};
  app.require_subcommand(1);
  turbid::AddBenchCommand(app);
  // Parsed as `turbid bench ARGS`.
  std::vector<const char*> args{argc > 0 ? argv[0] : "turbid", "bench"};
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  return turbid::RunApp(app, static_cast<int>(args.size()), args.data());
}
