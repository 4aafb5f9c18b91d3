// Temporary forwarding header (issue 29): moved to enhancer/oracle/oracle.h. Kept only until the
// include in enhancer/registry.cc (rewritten by another branch) follows.
#pragma once
#include "enhancer/oracle/oracle.h"  // IWYU pragma: export
