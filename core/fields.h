// The one field table (docs/architecture.md, "Field tables"). An options struct declares each of
// its JSON keys once — key, member, doc, type and range — and that one declaration drives:
//   - the strict reader: an unknown key, a wrong type or a value out of range is one line naming
//     the source (a file or a flag) and the key: "<source>: '<where>.<key>': <problem>";
//   - ToJson (the same keys, the same order, the values of a given struct);
//   - the help and docs text (Info: key, type, range, default, doc).
// Integers are read through JsonInteger (core/json_io.h): a fraction, a string or 1e300 is refused,
// never cast.
//
//   const Fields<ClaheOptions>& ClaheFields() {
//     static const Fields<ClaheOptions> fields = Fields<ClaheOptions>()
//         .Integer("tiles_x", &ClaheOptions::tiles_x, "tiles along x", 2, 1024)
//         .Number("clip_limit", &ClaheOptions::clip_limit, "clip limit", NumberRange::Between(0,
//         1));
//     return fields;
//   }
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"

namespace turbid {

// The values a number field accepts: finite, within [min, max] (either end may be open).
struct NumberRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;
  bool max_open = false;

  static NumberRange Any() { return {}; }
  static NumberRange AtLeast(double v) { return {v, Inf(), false, false}; }
  static NumberRange Above(double v) { return {v, Inf(), true, false}; }
  static NumberRange Between(double lo, double hi) { return {lo, hi, false, false}; }
  // (lo, hi]
  static NumberRange AboveUpTo(double lo, double hi) { return {lo, hi, true, false}; }

  bool Contains(double v) const;
  // "", ">= 0", "> 0", "in [0, 1]", "in (0, 1]", "<= 3"
  std::string Text() const;

 private:
  static double Inf() { return std::numeric_limits<double>::infinity(); }
};

// One key as help and docs show it.
struct FieldInfo {
  std::string key;
  std::string type;   // "number", "integer", "boolean", "string", "one of: a, b", ...
  std::string range;  // "" or ">= 0", "in [2, 1024]"
  nlohmann::json default_value;
  std::string doc;
  int tag = 0;  // a label the caller gives (Fields::Tag), e.g. the enhancer's SizeBound
};

namespace fields_detail {
// The problem with a value for a number / integer / ... field, "" when it is acceptable.
std::string NumberProblem(const nlohmann::json& v, const NumberRange& range, double* out);
std::string IntegerProblem(const nlohmann::json& v, int64_t lo, int64_t hi, int64_t* out);
std::string UnsignedProblem(const nlohmann::json& v, uint64_t* out);
std::string BooleanProblem(const nlohmann::json& v, bool* out);
std::string StringProblem(const nlohmann::json& v, std::string* out);
std::string ArrayProblem(const nlohmann::json& v, size_t size, const NumberRange& range,
                         std::vector<double>* out);
std::string IntegerRangeText(int64_t lo, int64_t hi);
// A value as messages show it: JSON text, invalid UTF-8 replaced, cut to 60 characters.
std::string ShownValue(const nlohmann::json& v);
std::string Quoted(const std::string& noun, const std::string& where, const std::string& key);
[[noreturn]] void ThrowUnknownKey(const std::string& source, const std::string& noun,
                                  const std::string& where, const std::string& key,
                                  const std::vector<std::string>& known);
[[noreturn]] void ThrowNotAnObject(const std::string& source, const std::string& where,
                                   const nlohmann::json& value);
}  // namespace fields_detail

template <typename T>
class Fields {
 public:
  using Json = nlohmann::json;
  // Reads `value` into the struct; returns the problem ("" when read). The key is named by the
  // caller.
  using Reader = std::function<std::string(const Json& value, T& out)>;
  using Writer = std::function<Json(const T& in)>;

  // Reads a JSON object under the field's key, naming its own keys' problems from `where` (the
  // field's path, "scene.camera") and `source`; throws Error.
  using ObjectReader = std::function<void(const Json& value, T& out, const std::string& source,
                                          const std::string& where, const std::string& noun)>;

  struct Field {
    FieldInfo info;  // default_value left null here; Info() fills it from a struct
    Reader read;
    Writer write;
    ObjectReader read_object;  // set for Object / OptionalObject fields (read is then unused)
  };

  Fields& Number(std::string key, double T::*member, std::string doc,
                 NumberRange range = NumberRange::Any()) {
    return Add(
        std::move(key), "number", range.Text(), std::move(doc),
        [member, range](const Json& v, T& out) {
          return fields_detail::NumberProblem(v, range, &(out.*member));
        },
        [member](const T& in) { return Json(in.*member); });
  }
  Fields& Integer(std::string key, int T::*member, std::string doc,
                  int64_t lo = std::numeric_limits<int>::min(),
                  int64_t hi = std::numeric_limits<int>::max()) {
    return Add(
        std::move(key), "integer", fields_detail::IntegerRangeText(lo, hi), std::move(doc),
        [member, lo, hi](const Json& v, T& out) {
          int64_t value = 0;
          std::string problem = fields_detail::IntegerProblem(v, lo, hi, &value);
          if (problem.empty()) out.*member = static_cast<int>(value);
          return problem;
        },
        [member](const T& in) { return Json(in.*member); });
  }
  // An unsigned 64-bit integer (seeds): 0 to 2^64 - 1.
  Fields& Unsigned(std::string key, uint64_t T::*member, std::string doc) {
    return Add(
        std::move(key), "integer", "in [0, 2^64 - 1]", std::move(doc),
        [member](const Json& v, T& out) {
          return fields_detail::UnsignedProblem(v, &(out.*member));
        },
        [member](const T& in) { return Json(in.*member); });
  }
  Fields& Boolean(std::string key, bool T::*member, std::string doc) {
    return Add(
        std::move(key), "boolean", "", std::move(doc),
        [member](const Json& v, T& out) {
          return fields_detail::BooleanProblem(v, &(out.*member));
        },
        [member](const T& in) { return Json(in.*member); });
  }
  Fields& String(std::string key, std::string T::*member, std::string doc) {
    return Add(
        std::move(key), "string", "", std::move(doc),
        [member](const Json& v, T& out) { return fields_detail::StringProblem(v, &(out.*member)); },
        [member](const T& in) { return Json(in.*member); });
  }
  // A fixed number of numbers in a member with operator[] (std::array<double, N>, cv::Vec3d):
  // a JSON array of exactly `size` finite numbers, each within `range`.
  template <typename A>
  Fields& Array(std::string key, A T::*member, size_t size, std::string doc,
                NumberRange range = NumberRange::Any()) {
    return Add(
        std::move(key), "array of " + std::to_string(size) + " numbers", range.Text(),
        std::move(doc),
        [member, size, range](const Json& v, T& out) {
          std::vector<double> values;
          std::string problem = fields_detail::ArrayProblem(v, size, range, &values);
          for (size_t i = 0; i < values.size(); ++i) (out.*member)[i] = values[i];
          return problem;
        },
        [member, size](const T& in) {
          Json values = Json::array();
          for (size_t i = 0; i < size; ++i) values.push_back((in.*member)[i]);
          return values;
        });
  }
  // One of a fixed set of names, each standing for a value of E (an enum, usually).
  template <typename E>
  Fields& Choice(std::string key, E T::*member, std::vector<std::pair<std::string, E>> names,
                 std::string doc) {
    std::string list;
    for (const auto& [name, value] : names) list += (list.empty() ? "" : ", ") + name;
    return Add(
        std::move(key), "one of: " + list, "", std::move(doc),
        [member, names, list](const Json& v, T& out) -> std::string {
          if (v.is_string()) {
            for (const auto& [name, value] : names) {
              if (v.get_ref<const std::string&>() == name) {
                out.*member = value;
                return "";
              }
            }
          }
          return "expected one of " + list + ", got " + fields_detail::ShownValue(v);
        },
        [member, names](const T& in) -> Json {
          for (const auto& [name, value] : names) {
            if (in.*member == value) return name;
          }
          return nullptr;
        });
  }
  // The fields of a member struct, under `prefix` + their own keys (flat: "clahe_" + "bins").
  template <typename S>
  Fields& Nested(const std::string& prefix, S T::*member, const Fields<S>& sub) {
    for (const typename Fields<S>::Field& f : sub.fields()) {
      FieldInfo info = f.info;
      info.key = prefix + info.key;
      ObjectReader read_object;
      if (f.read_object) {
        read_object = [member, r = f.read_object](const Json& v, T& out, const std::string& source,
                                                  const std::string& where,
                                                  const std::string& noun) {
          r(v, out.*member, source, where, noun);
        };
      }
      Reader read;
      if (f.read) {
        read = [member, r = f.read](const Json& v, T& out) { return r(v, out.*member); };
      }
      fields_.push_back(Field{std::move(info), std::move(read),
                              [member, write = f.write](const T& in) { return write(in.*member); },
                              std::move(read_object)});
    }
    return *this;
  }
  // A JSON object under `key`, read by `sub` into the member: its keys' errors name the whole
  // path ("'scene.camera.fz'"); written as that object.
  template <typename S>
  Fields& Object(std::string key, S T::*member, const Fields<S>& sub, std::string doc) {
    const Fields<S>* table = &sub;
    Add(std::move(key), "object", "", std::move(doc), nullptr,
        [member, table](const T& in) { return table->ToJson(in.*member); });
    fields_.back().read_object = [member, table](const Json& v, T& out, const std::string& source,
                                                 const std::string& where,
                                                 const std::string& noun) {
      table->Read(v, &(out.*member), source, where, noun);
    };
    return *this;
  }
  // A JSON object under `key` whose keys are more members of T itself (a sidecar's "camera"
  // object of fx, fy, cx, cy in the scene's struct), read and written by `sub`.
  Fields& Inline(std::string key, const Fields<T>& sub, std::string doc) {
    const Fields<T>* table = &sub;
    Add(std::move(key), "object", "", std::move(doc), nullptr,
        [table](const T& in) { return table->ToJson(in); });
    fields_.back().read_object = [table](const Json& v, T& out, const std::string& source,
                                         const std::string& where, const std::string& noun) {
      table->Read(v, &out, source, where, noun);
    };
    return *this;
  }
  // The same for an optional member: null (or absent) is nullopt, written as null.
  template <typename S>
  Fields& OptionalObject(std::string key, std::optional<S> T::*member, const Fields<S>& sub,
                         std::string doc) {
    const Fields<S>* table = &sub;
    Add(std::move(key), "object or null", "", std::move(doc), nullptr,
        [member, table](const T& in) -> Json {
          return (in.*member) ? table->ToJson(*(in.*member)) : Json();
        });
    fields_.back().read_object = [member, table](const Json& v, T& out, const std::string& source,
                                                 const std::string& where,
                                                 const std::string& noun) {
      if (v.is_null()) {
        out.*member = std::nullopt;
        return;
      }
      // Assigned, not emplace()d: clang 14 may judge S not default-constructible while the
      // enclosing type is being defined.
      out.*member = S{};
      table->Read(v, &*(out.*member), source, where, noun);
    };
    return *this;
  }
  // The kind taken from the member's type: double -> Number (any finite value), int -> Integer,
  // bool -> Boolean, std::string -> String, uint64_t -> Unsigned.
  Fields& Member(std::string key, double T::*member, std::string doc) {
    return Number(std::move(key), member, std::move(doc));
  }
  Fields& Member(std::string key, int T::*member, std::string doc) {
    return Integer(std::move(key), member, std::move(doc));
  }
  Fields& Member(std::string key, bool T::*member, std::string doc) {
    return Boolean(std::move(key), member, std::move(doc));
  }
  Fields& Member(std::string key, std::string T::*member, std::string doc) {
    return String(std::move(key), member, std::move(doc));
  }
  Fields& Member(std::string key, uint64_t T::*member, std::string doc) {
    return Unsigned(std::move(key), member, std::move(doc));
  }
  // Labels the field declared last with `tag` (FieldInfo::tag), e.g. how an image bounds it.
  Fields& Tag(int tag) {
    if (fields_.empty()) throw std::logic_error("Fields::Tag before any field");
    fields_.back().info.tag = tag;
    return *this;
  }
  // A field with its own reading and writing (vectors, presets, ...).
  Fields& Custom(std::string key, std::string type, std::string range, std::string doc, Reader read,
                 Writer write) {
    return Add(std::move(key), std::move(type), std::move(range), std::move(doc), std::move(read),
               std::move(write));
  }

  // Reads every key of `object` (a JSON object; null reads nothing) into *out; absent keys keep
  // *out's values. Throws Error "<source>: '<where>.<key>': <problem>" for a wrong type or range,
  // "<source>: unknown key '<where>.<key>' (known: ...)" for a key no field declares. `noun`
  // names the keys in messages ("parameter": "dcp: parameter 'omega': ...", "dcp: unknown
  // parameter 'x' (known: ...)").
  void Read(const Json& object, T* out, const std::string& source, const std::string& where = "",
            const std::string& noun = "key") const {
    if (object.is_null()) return;
    if (!object.is_object()) fields_detail::ThrowNotAnObject(source, where, object);
    for (auto it = object.begin(); it != object.end(); ++it) {
      const Field* field = Find(it.key());
      if (field == nullptr) fields_detail::ThrowUnknownKey(source, noun, where, it.key(), Keys());
      if (field->read_object) {
        field->read_object(it.value(), *out, source,
                           where.empty() ? it.key() : where + "." + it.key(), noun);
        continue;
      }
      const std::string problem = field->read(it.value(), *out);
      if (!problem.empty()) {
        const std::string named = noun == "key" ? "" : noun;
        throw Error(source, fields_detail::Quoted(named, where, it.key()) + ": " + problem);
      }
    }
  }
  // Every field's value in `in`, in declaration order.
  Json ToJson(const T& in) const {
    Json out = Json::object();
    for (const Field& f : fields_) out[f.info.key] = f.write(in);
    return out;
  }
  // Help and docs rows; defaults taken from `defaults`.
  std::vector<FieldInfo> Info(const T& defaults = T{}) const {
    std::vector<FieldInfo> rows;
    for (const Field& f : fields_) {
      FieldInfo row = f.info;
      row.default_value = f.write(defaults);
      rows.push_back(std::move(row));
    }
    return rows;
  }
  std::vector<std::string> Keys() const {
    std::vector<std::string> keys;
    for (const Field& f : fields_) keys.push_back(f.info.key);
    return keys;
  }
  const Field* Find(const std::string& key) const {
    for (const Field& f : fields_) {
      if (f.info.key == key) return &f;
    }
    return nullptr;
  }
  const std::vector<Field>& fields() const { return fields_; }

 private:
  Fields& Add(std::string key, std::string type, std::string range, std::string doc, Reader read,
              Writer write) {
    if (Find(key) != nullptr) throw std::logic_error("Fields: key '" + key + "' declared twice");
    fields_.push_back(Field{
        FieldInfo{std::move(key), std::move(type), std::move(range), nullptr, std::move(doc), 0},
        std::move(read), std::move(write), nullptr});
    return *this;
  }

  std::vector<Field> fields_;
};

// A Markdown table of fields (docs): | key | type | default | doc |.
std::string FieldsMarkdown(const std::vector<FieldInfo>& rows);

}  // namespace turbid
