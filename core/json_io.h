// The one strict reading of JSON that users hand to turbid (experiment, scene and generate files,
// render parameters and --set / --param values, sidecars, manifests, journals, tolerance files,
// Python's params strings). Beyond RFC 8259 syntax it refuses, while parsing and before anything
// recurses over the document (docs/formats.md, "JSON"):
//   - nesting deeper than kMaxJsonDepth arrays/objects (a document of 10^5 levels would overflow
//     the stack of every recursive walk: copy, compare, dump, the option readers);
//   - a key that appears twice in one object (RFC 8259 leaves the meaning open; nlohmann keeps the
//     last one silently);
//   - a number outside the range of a double (1e999).
// Every error is one line naming the source (a file, or a flag such as "--set 'k=v'"):
//   "<source>: invalid JSON: <problem>".
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "core/error.h"

namespace turbid {

// Deepest nesting of arrays and objects accepted: the top-level value counts as level 1. turbid's
// own files nest at most 6 levels.
inline constexpr int kMaxJsonDepth = 64;

// Error from ParseJson: what() is "<source>: invalid JSON: <problem>"; problem() alone lets line-
// based readers (journals, manifests) phrase their own line.
class JsonError : public Error {
 public:
  JsonError(const std::string& source, const std::string& problem)
      : Error(source, "invalid JSON: " + problem), problem_(problem) {}
  const std::string& problem() const { return problem_; }
  // True for a document that is JSON syntax but is refused (too deep, duplicate key, number out
  // of range); false for a syntax error.
  bool refused = false;

 private:
  std::string problem_;
};

// Parses `text` strictly. Throws JsonError naming `source`.
nlohmann::json ParseJson(std::string_view text, const std::string& source);

// For values that are JSON when they parse and a bare string otherwise (--set k=v, --param k=v):
// std::nullopt for a syntax error; throws JsonError for JSON that is refused (too deep, duplicate
// key, number out of range).
std::optional<nlohmann::json> ParseJsonIfValid(std::string_view text, const std::string& source);

// Reads and parses a JSON file (a regular file: core/input_file.h). Throws Error naming `path`.
nlohmann::json ReadJsonFile(const std::string& path);

}  // namespace turbid

namespace turbid {

// The integer a JSON value holds, when it is an integral number in [lo, hi]; std::nullopt for
// anything else (a string, null, a fraction, a number out of range). nlohmann's get<int>() casts a
// float such as 1e300 to int, which is undefined behaviour: every integer a user file holds is
// read through this.
std::optional<int64_t> JsonInteger(const nlohmann::json& value, int64_t lo, int64_t hi);
// The same for unsigned 64-bit values (seeds): a non-negative integral number up to 2^64 - 1.
std::optional<uint64_t> JsonUnsigned(const nlohmann::json& value);

}  // namespace turbid
