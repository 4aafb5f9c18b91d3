// PLACEHOLDER: replaced by the module owner.
#include "tools/cli.h"

namespace turbid {

void AddSceneCommand(CLI::App& /*app*/) {}

}  // namespace turbid
