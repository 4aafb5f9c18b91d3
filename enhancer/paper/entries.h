// Registry entries of the paper's methods (enhancer/registry.cc reads them).
#pragma once

#include <vector>

namespace turbid {

struct MethodEntry;

// Registry entries for full, full_literal, full_matched, full_physical and simplified.
std::vector<MethodEntry> PaperMethodEntries();

}  // namespace turbid
