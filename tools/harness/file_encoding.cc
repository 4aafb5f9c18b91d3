#include "tools/harness/file_encoding.h"

#include <filesystem>
#include <fstream>
#include <iostream>

#include "core/json_io.h"

namespace turbid {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::optional<json> ReadJsonQuietly(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  try {
    json j = ReadJsonFile(path.string());
    if (j.is_object()) return j;
  } catch (const Error&) {  // unreadable or invalid: no sidecar
  }
  return std::nullopt;
}

bool IsEncodingName(const json& v) {
  return v.is_string() && (v.get<std::string>() == "srgb" || v.get<std::string>() == "linear");
}

}  // namespace

std::optional<std::string> SidecarEncoding(const json& sidecar) {
  if (!sidecar.is_object()) return std::nullopt;
  if (sidecar.contains("encoding") && IsEncodingName(sidecar["encoding"]))
    return sidecar["encoding"].get<std::string>();
  // Sidecars written before camera.encoding existed: integer outputs were coded linearly.
  if (sidecar.contains("options") && sidecar["options"].is_object() &&
      sidecar["options"].contains("camera"))
    return std::string("linear");
  return std::nullopt;
}

std::optional<KnownEncoding> EncodingBeside(const std::string& image_path) {
  const fs::path image(image_path);
  const fs::path sidecar = image.parent_path() / (image.stem().string() + ".json");
  if (auto j = ReadJsonQuietly(sidecar)) {
    if (auto name = SidecarEncoding(*j)) return KnownEncoding{*name, sidecar.string()};
  }
  const fs::path scene = image.parent_path() / "scene.json";
  if (auto j = ReadJsonQuietly(scene)) {
    if (j->value("image", std::string()) == image.filename().string() && j->contains("color") &&
        IsEncodingName((*j)["color"]))
      return KnownEncoding{(*j)["color"].get<std::string>(), scene.string()};
  }
  return std::nullopt;
}

bool WarnOnEncodingMismatch(const std::string& command, const std::string& a_name,
                            const std::optional<KnownEncoding>& a, const std::string& b_name,
                            const std::optional<KnownEncoding>& b) {
  if (!a || !b || a->name == b->name) return false;
  std::cerr << command << ": warning: " << a_name << " is " << a->name << "-coded (" << a->source
            << ") but " << b_name << " is " << b->name << "-coded (" << b->source
            << "): the values compared are coded differently\n";
  return true;
}

}  // namespace turbid
