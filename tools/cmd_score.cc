// PLACEHOLDER: replaced by the module owner.
#include "tools/cli.h"

namespace turbid {

void AddScoreCommand(CLI::App& /*app*/) {}

}  // namespace turbid
