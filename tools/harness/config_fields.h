// Field-table pieces for the harness's config files (experiment files, generate configs): keys
// whose absence means something (an optional value), raw JSON kept for a later, semantic pass (a
// grid, a sampler tree, render options) with its JSON type checked here, and lists of strings.
// Each key is still declared once, in its file's table (core/fields.h); these only add the kinds
// the option structs of the library do not need.
#ifndef TURBID_TOOLS_HARNESS_CONFIG_FIELDS_H_
#define TURBID_TOOLS_HARNESS_CONFIG_FIELDS_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/fields.h"

namespace turbid::config_fields {

using Json = nlohmann::json;

// The JSON type a raw value must have.
enum class Shape { kAny, kObject, kArray };

inline std::string ShapeProblem(const Json& v, Shape shape) {
  if (shape == Shape::kObject && !v.is_object())
    return "expected an object, got " + fields_detail::ShownValue(v);
  if (shape == Shape::kArray && !v.is_array())
    return "expected an array, got " + fields_detail::ShownValue(v);
  return "";
}

inline const char* ShapeName(Shape shape) {
  return shape == Shape::kObject ? "object" : shape == Shape::kArray ? "array" : "any JSON";
}

// A JSON value kept as written (its meaning is read by the caller); null when absent.
template <typename T>
void Raw(Fields<T>& f, std::string key, Json T::*member, Shape shape, std::string doc) {
  f.Custom(
      std::move(key), ShapeName(shape), "", std::move(doc),
      [member, shape](const Json& v, T& out) {
        std::string problem = ShapeProblem(v, shape);
        if (problem.empty()) out.*member = v;
        return problem;
      },
      [member](const T& in) { return in.*member; });
}

// Optional values: nullopt when the key is absent, written as null.
template <typename T, typename V, typename Problem>
void Optional(Fields<T>& f, std::string key, std::string type, std::string range, std::string doc,
              std::optional<V> T::*member, Problem problem) {
  f.Custom(
      std::move(key), std::move(type), std::move(range), std::move(doc),
      [member, problem](const Json& v, T& out) -> std::string {
        V value{};
        std::string text = problem(v, &value);
        if (text.empty()) out.*member = std::move(value);
        return text;
      },
      [member](const T& in) -> Json {
        if (!(in.*member)) return nullptr;
        return Json(*(in.*member));
      });
}

template <typename T>
void OptionalString(Fields<T>& f, std::string key, std::optional<std::string> T::*member,
                    std::string doc) {
  Optional(f, std::move(key), "string", "", std::move(doc), member,
           [](const Json& v, std::string* out) { return fields_detail::StringProblem(v, out); });
}

template <typename T>
void OptionalNumber(Fields<T>& f, std::string key, std::optional<double> T::*member,
                    std::string doc, NumberRange range) {
  Optional(
      f, std::move(key), "number", range.Text(), std::move(doc), member,
      [range](const Json& v, double* out) { return fields_detail::NumberProblem(v, range, out); });
}

template <typename T>
void OptionalInteger(Fields<T>& f, std::string key, std::optional<int64_t> T::*member,
                     std::string doc, int64_t lo, int64_t hi) {
  Optional(f, std::move(key), "integer", fields_detail::IntegerRangeText(lo, hi), std::move(doc),
           member, [lo, hi](const Json& v, int64_t* out) {
             return fields_detail::IntegerProblem(v, lo, hi, out);
           });
}

template <typename T>
void OptionalUnsigned(Fields<T>& f, std::string key, std::optional<uint64_t> T::*member,
                      std::string doc) {
  Optional(f, std::move(key), "integer", "in [0, 2^64 - 1]", std::move(doc), member,
           [](const Json& v, uint64_t* out) { return fields_detail::UnsignedProblem(v, out); });
}

template <typename T>
void OptionalBoolean(Fields<T>& f, std::string key, std::optional<bool> T::*member,
                     std::string doc) {
  Optional(f, std::move(key), "boolean", "", std::move(doc), member,
           [](const Json& v, bool* out) { return fields_detail::BooleanProblem(v, out); });
}

// An array of strings; nullopt when absent.
template <typename T>
void OptionalStrings(Fields<T>& f, std::string key,
                     std::optional<std::vector<std::string>> T::*member, std::string doc) {
  Optional(f, std::move(key), "array of strings", "", std::move(doc), member,
           [](const Json& v, std::vector<std::string>* out) -> std::string {
             if (!v.is_array())
               return "expected an array of strings, got " + fields_detail::ShownValue(v);
             for (size_t i = 0; i < v.size(); ++i) {
               if (!v[i].is_string())
                 return "[" + std::to_string(i) + "]: expected a string, got " +
                        fields_detail::ShownValue(v[i]);
               out->push_back(v[i].get<std::string>());
             }
             return "";
           });
}

// A block of seeded random draws, the same three keys in an experiment's "samples" and a
// generate config's "random": draws per grid point, their seed (absent: the file's seed) and
// {path: distribution} (read by param_tree.h's FlattenSamplers).
struct DrawKeys {
  std::optional<int64_t> count;
  std::optional<uint64_t> seed;
  Json params;
};

inline const Fields<DrawKeys>& DrawKeyFields() {
  static const Fields<DrawKeys> fields = [] {
    Fields<DrawKeys> f;
    OptionalInteger(f, "count", &DrawKeys::count, "draws per grid point", 1, 1000000);
    OptionalUnsigned(f, "seed", &DrawKeys::seed, "the draws' seed");
    Raw(f, "params", &DrawKeys::params, Shape::kObject, "{path: distribution}");
    return f;
  }();
  return fields;
}

}  // namespace turbid::config_fields

#endif  // TURBID_TOOLS_HARNESS_CONFIG_FIELDS_H_
