// PLACEHOLDER: replaced by the module owner.
#include "tools/cli.h"

namespace turbid {

void AddRenderCommands(CLI::App& /*app*/) {}

}  // namespace turbid
