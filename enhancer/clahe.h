// Temporary forwarding header (issue 29): moved to enhancer/blocks/clahe.h. Kept only until the
// includes in enhancer/paper_methods.*, baselines* and registry.cc (split by another branch) follow.
#pragma once
#include "enhancer/blocks/clahe.h"  // IWYU pragma: export
