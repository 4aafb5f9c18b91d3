// The `seathru` method's registry entry (gathered by enhancer/registry.cc).
#pragma once

#include <vector>

#include "enhancer/method.h"

namespace turbid {

std::vector<MethodEntry> SeathruMethodEntries();

}  // namespace turbid
