// Temporary forwarding header (issue 29): moved to enhancer/blocks/linear_upsample.h. Kept only until the
// includes in enhancer/paper_methods.*, baselines* and registry.cc (split by another branch) follow.
#pragma once
#include "enhancer/blocks/linear_upsample.h"  // IWYU pragma: export
