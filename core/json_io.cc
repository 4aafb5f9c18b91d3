#include "core/json_io.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_set>
#include <vector>

#include "core/input_file.h"

namespace turbid {
namespace {

using nlohmann::json;

// nlohmann's message without its "[json.exception.parse_error.101] " tag.
std::string Untagged(const std::string& what) {
  const size_t cut = what.find("] ");
  return what.rfind("[json.exception.", 0) == 0 && cut != std::string::npos ? what.substr(cut + 2)
                                                                            : what;
}

JsonError Refused(const std::string& source, const std::string& problem) {
  JsonError error(source, problem);
  error.refused = true;
  return error;
}

// Parser callback state: one key set per open object, indexed by its depth (0: the top level).
// The callback runs for every event while the parser builds the document (no recursion: nlohmann's
// parser keeps an explicit stack), so a document is refused before anything walks it.
class StrictChecker {
 public:
  explicit StrictChecker(const std::string& source) : source_(source) {}

  bool operator()(int depth, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        if (depth >= kMaxJsonDepth)
          throw Refused(source_, "nested deeper than " + std::to_string(kMaxJsonDepth) +
                                     " levels of arrays and objects");
        if (event == json::parse_event_t::object_start) {
          if (keys_.size() <= static_cast<size_t>(depth)) keys_.resize(depth + 1);
          keys_[depth].clear();
        }
        break;
      case json::parse_event_t::key: {
        // The key's object sits at depth - 1 (depth counts the containers already open).
        auto& seen = keys_.at(static_cast<size_t>(depth - 1));
        const std::string& key = parsed.get_ref<const std::string&>();
        if (!seen.insert(key).second)
          throw Refused(source_, "duplicate key '" + key + "' in one object");
        break;
      }
      default:
        break;
    }
    return true;
  }

 private:
  std::string source_;
  std::vector<std::unordered_set<std::string>> keys_;
};

json Parse(std::string_view text, const std::string& source) {
  StrictChecker checker(source);
  try {
    return json::parse(text.begin(), text.end(),
                       [&checker](int depth, json::parse_event_t event, json& parsed) {
                         return checker(depth, event, parsed);
                       });
  } catch (const json::out_of_range& e) {  // 406: a number beyond a double (1e999)
    std::string problem = Untagged(e.what());
    const size_t quote = problem.find('\'');
    if (problem.find("number overflow") != std::string::npos && quote != std::string::npos)
      problem = "number out of range " + problem.substr(quote);
    throw Refused(source, problem);
  } catch (const json::exception& e) {
    throw JsonError(source, Untagged(e.what()));
  }
}

}  // namespace

json ParseJson(std::string_view text, const std::string& source) { return Parse(text, source); }

std::optional<json> ParseJsonIfValid(std::string_view text, const std::string& source) {
  try {
    return Parse(text, source);
  } catch (const JsonError& e) {
    if (e.refused) throw;
    return std::nullopt;
  }
}

json ReadJsonFile(const std::string& path) { return Parse(ReadInputFile(path), path); }

}  // namespace turbid

namespace turbid {

std::optional<int64_t> JsonInteger(const nlohmann::json& value, int64_t lo, int64_t hi) {
  int64_t v = 0;
  if (value.is_number_unsigned()) {
    const uint64_t u = value.get<uint64_t>();
    if (u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) return std::nullopt;
    v = static_cast<int64_t>(u);
  } else if (value.is_number_integer()) {
    v = value.get<int64_t>();
  } else if (value.is_number_float()) {
    // 3.0 is accepted as 3 (JSON does not distinguish); the range check comes before the cast.
    const double d = value.get<double>();
    if (!(d >= -9.2e18 && d <= 9.2e18) || d != std::trunc(d)) return std::nullopt;
    v = static_cast<int64_t>(d);
  } else {
    return std::nullopt;
  }
  if (v < lo || v > hi) return std::nullopt;
  return v;
}

std::optional<uint64_t> JsonUnsigned(const nlohmann::json& value) {
  if (value.is_number_unsigned()) return value.get<uint64_t>();
  if (value.is_number_integer()) {
    const int64_t v = value.get<int64_t>();
    if (v < 0) return std::nullopt;
    return static_cast<uint64_t>(v);
  }
  if (value.is_number_float()) {
    const double d = value.get<double>();
    if (!(d >= 0.0 && d < 1.8e19) || d != std::trunc(d)) return std::nullopt;
    return static_cast<uint64_t>(d);
  }
  return std::nullopt;
}

}  // namespace turbid
