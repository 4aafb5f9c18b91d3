#include "core/atomic_file.h"
#include "tools/cli/cli.h"

int main(int argc, char** argv) {
  // Ctrl-C or a scheduler's SIGTERM during a write leaves no hidden temporary files behind.
  turbid::RemoveTemporaryFilesOnSignal();
  return turbid::RunCli(argc, argv);
}
