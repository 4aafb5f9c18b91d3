// Resource limits: inputs whose size would exhaust memory are refused before anything is allocated,
// with one line that names the limit and how to raise it (docs/reliability.md, "Limits").
//
//   TURBID_MAX_PIXELS  pixels per image any decoder, dataset adapter or depth reader accepts
//                      (width x height from the file's header), default 100,000,000 (a float RGB
//                      image of that size holds 1.2 GB); at most 2^31 - 1.
//   TURBID_MAX_ITEMS   items per sweep (scenes x conditions), per generate run (scenes x grid x
//                      samples) and frames per multi-frame dataset, default 1,000,000.
//
// Header-only so that the on-demand plugins (scenes/plugin/) apply the same limits.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/error.h"

namespace turbid {

inline constexpr int64_t kDefaultMaxPixels = 100'000'000;
inline constexpr int64_t kDefaultMaxItems = 1'000'000;
// The side length no decoder goes beyond whatever the limits say (int indexing, OpenCV's own
// decoder limit); not configurable.
inline constexpr int64_t kMaxImageSide = int64_t{1} << 20;

// The value of a limit's environment variable, or `fallback` when unset or empty. Throws Error for
// a value that is not an integer in [1, 2^31 - 1].
inline int64_t LimitFromEnvironment(const char* variable, int64_t fallback) {
  const char* text = std::getenv(variable);
  if (text == nullptr || *text == '\0') return fallback;
  char* end = nullptr;
  const long long value = std::strtoll(text, &end, 10);
  if (end == text || *end != '\0' || value < 1 || value > 2147483647LL)
    throw Error(std::string(variable) + "='" + text +
                "' is not an integer in [1, 2147483647] (default " + std::to_string(fallback) +
                ")");
  return value;
}

inline int64_t MaxPixels() { return LimitFromEnvironment("TURBID_MAX_PIXELS", kDefaultMaxPixels); }
inline int64_t MaxItems() { return LimitFromEnvironment("TURBID_MAX_ITEMS", kDefaultMaxItems); }

// "" when a width x height image may be decoded; otherwise the one-line reason (without the file).
inline std::string ImageSizeProblem(int64_t width, int64_t height) {
  if (width < 1 || height < 1)
    return "bad image size " + std::to_string(width) + "x" + std::to_string(height);
  const int64_t limit = MaxPixels();
  // Both sides are below 2^31 when they reach here from a header parser; saturate anyway.
  const bool over = width > limit || height > limit || width * height > limit;
  if (over)
    return "image size " + std::to_string(width) + "x" + std::to_string(height) +
           " exceeds the limit of " + std::to_string(limit) +
           " pixels per image (raise it with the environment variable TURBID_MAX_PIXELS)";
  if (width > kMaxImageSide || height > kMaxImageSide)
    return "image size " + std::to_string(width) + "x" + std::to_string(height) +
           " exceeds the largest side turbid decodes (" + std::to_string(kMaxImageSide) + ")";
  return "";
}

// Throws Error("<path>: <reason>") unless ImageSizeProblem(width, height) is empty.
inline void CheckImageSize(const std::string& path, int64_t width, int64_t height) {
  const std::string problem = ImageSizeProblem(width, height);
  if (!problem.empty()) throw Error(path, problem);
}

// Throws Error("<source>: <what> has N items, more than the limit ...") when count > MaxItems().
// `count` saturates: callers multiply factors with SaturatingProduct.
inline void CheckItemCount(const std::string& source, const std::string& what, int64_t count) {
  const int64_t limit = MaxItems();
  if (count > limit)
    throw Error(source,
                what + " has " +
                    (count == INT64_MAX ? std::string("more than 9.2e18") : std::to_string(count)) +
                    " items, more than the limit of " + std::to_string(limit) +
                    " (raise it with the environment variable TURBID_MAX_ITEMS)");
}

// a * b, saturating at INT64_MAX (factors >= 0).
inline int64_t SaturatingProduct(int64_t a, int64_t b) {
  if (a == 0 || b == 0) return 0;
  if (a > INT64_MAX / b) return INT64_MAX;
  return a * b;
}

}  // namespace turbid
