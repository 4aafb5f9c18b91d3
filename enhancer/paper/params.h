// Internal to enhancer/paper/: the parameters of `full` (and its variants) and `simplified`, each
// declared once in a field table (core/fields.h, enhancer/params.h) that reads them strictly and
// lists them with their defaults (params.cc).
#pragma once

#include <nlohmann/json.hpp>

#include "core/fields.h"
#include "enhancer/blocks/clahe.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/simplified.h"

namespace turbid::paper_internal {

// The CLAHE keys (under the prefix "clahe_" in both methods).
const Fields<ClaheOptions>& ClaheFields();
// Every key of `full` and its variants (the variant sets the defaults: FullVariantDefaults).
const Fields<FullOptions>& FullFields();
const Fields<SimplifiedOptions>& SimplifiedFields();
// Strict reading of `simplified`'s parameters; throws Error naming the key.
SimplifiedOptions BindSimplified(const nlohmann::json& params);

}  // namespace turbid::paper_internal
