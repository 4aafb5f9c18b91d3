#include "scenes/json_io.h"

#include <unordered_set>
#include <vector>

#include "scenes/input_file.h"

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
