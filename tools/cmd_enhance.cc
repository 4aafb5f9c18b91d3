// PLACEHOLDER: replaced by the module owner.
#include "tools/cli.h"

namespace turbid {

void AddEnhanceCommand(CLI::App& /*app*/) {}

}  // namespace turbid
