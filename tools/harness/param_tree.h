// Dotted paths and nested objects as one spelling of render parameters (issue 33 item 3): the one
// place that turns {"water": {"type": X}} and {"water.type": X} into the same thing, for
// generate's "base" and "random.params", a sweep's "render" and "samples.params", `--set` and the
// Python package (render params, turbid.data's samplers).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace turbid {

// True for a sampler spec ({"uniform"|"log_uniform"|"int_uniform": [lo, hi]},
// {"choice": [...]}): an object with one key whose value is an array (an unknown distribution
// name is a spec too, so that ParseDistribution names it).
bool IsDistributionSpec(const nlohmann::json& value);

// A tree of samplers as {dotted path: distribution}: nested objects are walked until a
// distribution spec (IsDistributionSpec); keys may themselves be dotted ("water.type",
// {"water": {"type": ...}} and {"water": {"type": ...}, "psf.forward_scatter": ...} mix freely).
// The result's key order is the dotted paths' (so both spellings draw alike). Throws
// Error(file, what + ...) for a path given twice, an empty object, or a leaf that is not an
// object (a constant where a distribution belongs).
nlohmann::json FlattenSamplers(const nlohmann::json& tree, const std::string& file,
                               const std::string& what);

// Render parameters with dotted keys ("water.type": X) set into the nested objects (through
// SetRenderParam: "light.lights.0.power" starts from the default light list); nested keys kept.
// Throws Error(what + ": ...") when `params` is not an object.
nlohmann::json ExpandDottedKeys(nlohmann::json params, const std::string& what);

// Sets `value` at `path` merging objects: an object value sets each of its leaves (a nested
// object is merged into what is there, not replacing it); anything else is SetRenderParam.
void MergeRenderParam(nlohmann::json& params, const std::string& path, const nlohmann::json& value);

}  // namespace turbid
