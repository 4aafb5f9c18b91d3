#include "core/fields.h"

#include <cmath>
#include <sstream>

#include "core/json_io.h"

namespace turbid {
namespace {

std::string Format(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  std::string text = s.str();
  // Shortest form that reads back: try fewer digits first.
  for (int digits = 1; digits < 17; ++digits) {
    std::ostringstream t;
    t.precision(digits);
    t << v;
    if (std::stod(t.str()) == v) return t.str();
  }
  return text;
}

// A value as an error message shows it: its JSON text, cut to 60 characters (a value may be a
// megabyte array).
std::string Shown(const nlohmann::json& v) {
  // Invalid UTF-8 in a string is shown as U+FFFD, not thrown (nlohmann's dump would).
  std::string text = v.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return text;
}

}  // namespace

std::string fields_detail::ShownValue(const nlohmann::json& v) { return Shown(v); }

bool NumberRange::Contains(double v) const {
  if (!std::isfinite(v)) return false;
  if (min_open ? !(v > min) : !(v >= min)) return false;
  if (max_open ? !(v < max) : !(v <= max)) return false;
  return true;
}

std::string NumberRange::Text() const {
  const bool has_min = std::isfinite(min);
  const bool has_max = std::isfinite(max);
  if (has_min && has_max) {
    return std::string("in ") + (min_open ? "(" : "[") + Format(min) + ", " + Format(max) +
           (max_open ? ")" : "]");
  }
  if (has_min) return (min_open ? "> " : ">= ") + Format(min);
  if (has_max) return (max_open ? "< " : "<= ") + Format(max);
  return "";
}

std::string FieldsMarkdown(const std::vector<FieldInfo>& rows) {
  std::string out = "| key | type | default | meaning |\n|---|---|---|---|\n";
  for (const FieldInfo& row : rows) {
    std::string type = row.type;
    if (!row.range.empty()) type += ", " + row.range;
    out += "| `" + row.key + "` | " + type + " | `" + row.default_value.dump() + "` | " + row.doc +
           " |\n";
  }
  return out;
}

namespace fields_detail {

std::string NumberProblem(const nlohmann::json& v, const NumberRange& range, double* out) {
  if (!v.is_number()) return "expected a number, got " + Shown(v);
  const double value = v.get<double>();
  if (!std::isfinite(value)) return "must be finite";
  if (!range.Contains(value)) return "must be " + range.Text() + ", got " + Shown(v);
  *out = value;
  return "";
}

std::string IntegerRangeText(int64_t lo, int64_t hi) {
  const bool has_lo = lo > std::numeric_limits<int>::min();
  const bool has_hi = hi < std::numeric_limits<int>::max();
  if (has_lo && has_hi) return "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (has_lo) return ">= " + std::to_string(lo);
  if (has_hi) return "<= " + std::to_string(hi);
  return "";
}

std::string IntegerProblem(const nlohmann::json& v, int64_t lo, int64_t hi, int64_t* out) {
  if (!v.is_number()) return "expected an integer, got " + Shown(v);
  const std::optional<int64_t> value =
      JsonInteger(v, std::numeric_limits<int64_t>::min(), std::numeric_limits<int64_t>::max());
  if (!value) return "expected an integer, got " + Shown(v);
  if (*value < lo || *value > hi) {
    // The full int range has no text of its own (IntegerRangeText gives "" for help).
    const std::string range = IntegerRangeText(lo, hi);
    return "must be " +
           (range.empty() ? "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]" : range) +
           ", got " + Shown(v);
  }
  *out = *value;
  return "";
}

std::string UnsignedProblem(const nlohmann::json& v, uint64_t* out) {
  const std::optional<uint64_t> value = JsonUnsigned(v);
  if (!value) return "must be an integer in [0, 18446744073709551615], got " + Shown(v);
  *out = *value;
  return "";
}

std::string BooleanProblem(const nlohmann::json& v, bool* out) {
  if (!v.is_boolean()) return "expected true or false, got " + Shown(v);
  *out = v.get<bool>();
  return "";
}

std::string StringProblem(const nlohmann::json& v, std::string* out) {
  if (!v.is_string()) return "expected a string, got " + Shown(v);
  *out = v.get<std::string>();
  return "";
}

std::string ArrayProblem(const nlohmann::json& v, size_t size, const NumberRange& range,
                         std::vector<double>* out) {
  if (!v.is_array() || v.size() != size)
    return "expected an array of " + std::to_string(size) + " numbers, got " + Shown(v);
  std::vector<double> values(size);
  for (size_t i = 0; i < size; ++i) {
    std::string problem = NumberProblem(v[i], range, &values[i]);
    if (!problem.empty()) return "[" + std::to_string(i) + "]: " + problem;
  }
  *out = std::move(values);
  return "";
}

std::string Quoted(const std::string& noun, const std::string& where, const std::string& key) {
  return (noun.empty() ? "" : noun + " ") + "'" + (where.empty() ? key : where + "." + key) + "'";
}

void ThrowUnknownKey(const std::string& source, const std::string& noun, const std::string& where,
                     const std::string& key, const std::vector<std::string>& known) {
  std::string list;
  for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
  throw Error(source, "unknown " + Quoted(noun, where, key) +
                          " (known: " + (list.empty() ? "none" : list) + ")");
}

void ThrowNotAnObject(const std::string& source, const std::string& where,
                      const nlohmann::json& value) {
  throw Error(source, (where.empty() ? std::string("the top level") : "'" + where + "'") +
                          " must be a JSON object, got " + Shown(value));
}

}  // namespace fields_detail
}  // namespace turbid
