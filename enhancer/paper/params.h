// Internal to enhancer/paper/: the JSON binding shared by the registry entries (params.cc).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "enhancer/blocks/clahe.h"
#include "enhancer/method.h"
#include "enhancer/paper/simplified.h"

namespace turbid::paper_internal {

// Binds the CLAHE keys `prefix`tiles_x ... onto `c`; the distribution as a name into `dist`.
void BindClahe(ParamBinder& b, const std::string& prefix, ClaheOptions* c, std::string* dist);
// The CLAHE keys' MethodParam entries with the defaults of `c`.
std::vector<MethodParam> ClahePar(const std::string& prefix, const ClaheOptions& c);
// Strict binding of `simplified`'s parameters; throws Error naming the key.
SimplifiedOptions BindSimplified(const nlohmann::json& params);

}  // namespace turbid::paper_internal
