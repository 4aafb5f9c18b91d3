// Registry entries of the baselines (enhancer/registry.cc reads them).
#pragma once

#include <vector>

#include "enhancer/method.h"

namespace turbid {

// Registry entries for clahe, dcp, udcp, cap, tarel and fusion (parameters bound strictly from
// JSON onto the Options of enhancer/baselines/*.h; defaults come from the structs).
std::vector<MethodEntry> BaselineMethodEntries();

}  // namespace turbid
