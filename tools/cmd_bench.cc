// PLACEHOLDER: replaced by the module owner.
#include "tools/cli.h"

namespace turbid {

void AddBenchCommand(CLI::App& /*app*/) {}

}  // namespace turbid
