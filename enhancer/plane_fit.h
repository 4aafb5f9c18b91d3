// Temporary forwarding header (issue 29): moved to enhancer/blocks/plane_fit.h. Kept only until the
// includes in enhancer/paper_methods.*, baselines* and registry.cc (split by another branch) follow.
#pragma once
#include "enhancer/blocks/plane_fit.h"  // IWYU pragma: export
