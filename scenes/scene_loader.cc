#include "scenes/scene_loader.h"

#include <cmath>
#include <filesystem>

#include "scenes/builtin.h"
#include "core/error.h"

namespace turbid {
namespace fs = std::filesystem;

namespace {
constexpr const char* kBuiltinPrefix = "builtin:";

bool IsBuiltinName(const std::string& name) {
  for (const std::string& n : BuiltinSceneNames())
    if (n == name) return true;
  return false;
}
}  // namespace

bool LoadSceneOptions::Check(std::string* why) const {
  if (!std::isfinite(builtin_scale) || builtin_scale <= 0.0 || builtin_scale > 1.0) {
    if (why) *why = "builtin_scale must be in (0, 1]";
    return false;
  }
  return true;
}

bool IsBuiltinSpec(const std::string& spec) {
  if (spec.rfind(kBuiltinPrefix, 0) == 0) return true;
  std::error_code ec;
  return IsBuiltinName(spec) && !fs::exists(spec, ec);
}

std::string BuiltinSpecName(const std::string& spec) {
  return spec.rfind(kBuiltinPrefix, 0) == 0 ? spec.substr(std::string(kBuiltinPrefix).size())
                                            : spec;
}

Scene LoadScene(const std::string& spec, const LoadSceneOptions& options) {
  ThrowIfInvalid(options, "scene " + spec);
  if (IsBuiltinSpec(spec)) {
    const std::string name = BuiltinSpecName(spec);
    BuiltinSceneOptions builtin;
    builtin.scale = options.builtin_scale;
    return MakeBuiltinScene(name, builtin);
  }
  return LoadSceneFile(spec);
}

}  // namespace turbid
