// PLACEHOLDER: replaced by the module owner.
#include "tools/cli.h"

namespace turbid {

void AddHarnessCommands(CLI::App& /*app*/) {}

}  // namespace turbid
