// Which camera encoding (scenes/camera_encoding.h) an image file's values carry, as its producer
// recorded it: a `turbid render` sidecar ("encoding"; older sidecars without it were linear), a
// `turbid generate` manifest row ("encoding"), or the scene.json `turbid scene` writes beside its
// image.png ("color"). `turbid score` and `turbid enhance` use it to decode their inputs and to warn
// when images with different encodings are compared. docs/model.md ("Camera").
#pragma once

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

namespace turbid {

struct KnownEncoding {
  std::string name;    // "srgb" or "linear"
  std::string source;  // where it was read, for messages (a file path)
};

// The encoding a render sidecar records for its image; nullopt when the JSON is not one.
std::optional<std::string> SidecarEncoding(const nlohmann::json& sidecar);

// The encoding recorded next to an image file: "<stem>.json" (a render sidecar) or "scene.json"
// in the same folder naming this file as its image. nullopt when nothing says.
std::optional<KnownEncoding> EncodingBeside(const std::string& image_path);

// One line on stderr, "warning: <what> ... (<sources>)", when both are known and differ;
// returns whether it warned.
bool WarnOnEncodingMismatch(const std::string& command, const std::string& a_name,
                            const std::optional<KnownEncoding>& a, const std::string& b_name,
                            const std::optional<KnownEncoding>& b);

}  // namespace turbid
