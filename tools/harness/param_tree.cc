#include "tools/harness/param_tree.h"

#include <utility>
#include <vector>

#include "core/error.h"
#include "core/safe_name.h"
#include "tools/harness/generate.h"

namespace turbid {

using json = nlohmann::json;

bool IsDistributionSpec(const json& value) {
  return value.is_object() && value.size() == 1 && value.begin().value().is_array();
}

namespace {

void FlattenInto(const json& node, const std::string& prefix, const std::string& file,
                 const std::string& what, json* out) {
  for (auto it = node.begin(); it != node.end(); ++it) {
    if (it.key().empty())
      throw Error(file,
                  what + (prefix.empty() ? "" : "." + PrintableName(prefix)) + ": an empty key");
    const std::string path = prefix.empty() ? it.key() : prefix + "." + it.key();
    const json& value = it.value();
    if (value.is_object() && !IsDistributionSpec(value)) {
      if (value.empty())
        throw Error(file, what + "." + PrintableName(path) +
                              ": an empty object (a distribution or parameters under it)");
      FlattenInto(value, path, file, what, out);
      continue;
    }
    if (!value.is_object())
      throw Error(file, what + "." + PrintableName(path) +
                            " must be a distribution {\"uniform\"|\"log_uniform\"|"
                            "\"int_uniform\": [lo, hi]} or {\"choice\": [values...]}, or an "
                            "object of them");
    if (out->contains(path))
      throw Error(
          file, what + "." + PrintableName(path) + " is given twice (as a dotted path and nested)");
    (*out)[path] = value;
  }
}

}  // namespace

json FlattenSamplers(const json& tree, const std::string& file, const std::string& what) {
  if (!tree.is_object())
    throw Error(file, what + " must be an object {path: distribution} (paths dotted or nested)");
  json out = json::object();
  FlattenInto(tree, "", file, what, &out);
  return out;
}

json ExpandDottedKeys(json params, const std::string& what) {
  if (!params.is_object()) throw Error(what + ": parameters must be a JSON object");
  std::vector<std::pair<std::string, json>> dotted;
  for (auto it = params.begin(); it != params.end(); ++it)
    if (it.key().find('.') != std::string::npos) dotted.emplace_back(it.key(), it.value());
  for (const auto& [key, value] : dotted) {
    params.erase(key);
    MergeRenderParam(params, key, value);
  }
  return params;
}

void MergeRenderParam(json& params, const std::string& path, const json& value) {
  if (!value.is_object() || value.empty()) {
    SetRenderParam(params, path, value);
    return;
  }
  for (auto it = value.begin(); it != value.end(); ++it)
    MergeRenderParam(params, path + "." + it.key(), it.value());
}

}  // namespace turbid
