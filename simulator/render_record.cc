#include "simulator/render_record.h"

#include <cmath>
#include <limits>
#include <set>

#include "core/error.h"
#include "core/fields.h"
#include "core/json_io.h"

namespace turbid {
namespace {

using fields_detail::ShownValue;
using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The sidecar's kinds of values beyond the field tables' own. JSON writes a non-finite double as
// null, so null reads back as a given value (NaN unless said).
template <typename T>
void NullableNumber(Fields<T>& f, std::string key, double T::*m, std::string doc,
                    double if_null = kNaN) {
  f.Custom(
      std::move(key), "number or null", "", std::move(doc),
      [m, if_null](const json& v, T& out) -> std::string {
        if (v.is_null()) {
          out.*m = if_null;
          return "";
        }
        if (!v.is_number()) return "expected a number, got " + ShownValue(v);
        out.*m = v.get<double>();
        return "";
      },
      [m](const T& in) { return json(in.*m); });
}

std::string NumbersProblem(const json& v, std::vector<double>* out) {
  if (!v.is_array()) return "expected an array of numbers, got " + ShownValue(v);
  out->clear();
  for (const json& e : v) {
    if (!e.is_number() && !e.is_null()) return "must be an array of numbers";
    out->push_back(e.is_null() ? kNaN : e.get<double>());
  }
  return "";
}

template <typename T>
void Numbers(Fields<T>& f, std::string key, std::vector<double> T::*m, std::string doc) {
  f.Custom(
      std::move(key), "array of numbers", "", std::move(doc),
      [m](const json& v, T& out) { return NumbersProblem(v, &(out.*m)); },
      [m](const T& in) { return json(in.*m); });
}

// null (the sidecar's "not used") is nullopt.
template <typename T>
void OptionalNumbers(Fields<T>& f, std::string key, std::optional<std::vector<double>> T::*m,
                     std::string doc) {
  f.Custom(
      std::move(key), "array of numbers or null", "", std::move(doc),
      [m](const json& v, T& out) -> std::string {
        if (v.is_null()) {
          out.*m = std::nullopt;
          return "";
        }
        std::vector<double> values;
        const std::string problem = NumbersProblem(v, &values);
        if (problem.empty()) out.*m = std::move(values);
        return problem;
      },
      [m](const T& in) { return (in.*m) ? json(*(in.*m)) : json(); });
}

template <typename T, typename E>
void Strings(Fields<T>& f, std::string key, std::vector<E> T::*m, std::string doc) {
  f.Custom(
      std::move(key), "array of strings", "", std::move(doc),
      [m](const json& v, T& out) -> std::string {
        if (!v.is_array()) return "expected an array of strings, got " + ShownValue(v);
        (out.*m).clear();
        for (const json& e : v) {
          if (!e.is_string()) return "must be an array of strings";
          (out.*m).push_back(e.get<std::string>());
        }
        return "";
      },
      [m](const T& in) { return json(in.*m); });
}

std::string NonNegativeProblem(const json& v, int64_t* out) {
  const std::optional<int64_t> value = JsonInteger(v, 0, std::numeric_limits<int64_t>::max());
  if (!value) return "expected an integer >= 0, got " + ShownValue(v);
  *out = *value;
  return "";
}

template <typename T>
void NonNegative(Fields<T>& f, std::string key, int T::*m, std::string doc) {
  f.Integer(std::move(key), m, std::move(doc), 0, std::numeric_limits<int>::max());
}

using Record = RenderRecord;
using Scene_ = RenderRecord::SceneInfo;

const Fields<Scene_>& CameraFields() {
  static const Fields<Scene_> fields = [] {
    Fields<Scene_> f;
    NullableNumber(f, "fx", &Scene_::fx, "focal length x, pixels");
    NullableNumber(f, "fy", &Scene_::fy, "focal length y, pixels");
    NullableNumber(f, "cx", &Scene_::cx, "principal point x, pixels");
    NullableNumber(f, "cy", &Scene_::cy, "principal point y, pixels");
    return f;
  }();
  return fields;
}

const Fields<Scene_>& SceneFields() {
  static const Fields<Scene_> fields = [] {
    Fields<Scene_> f;
    f.String("name", &Scene_::name, "scene name");
    NonNegative(f, "width", &Scene_::width, "pixels");
    NonNegative(f, "height", &Scene_::height, "pixels");
    NonNegative(f, "channels", &Scene_::channels, "1 or 3");
    f.Inline("camera", CameraFields(), "pinhole intrinsics {fx, fy, cx, cy}, pixels");
    f.Custom(
        "input_hashes", "object", "", "input file -> sha256",
        [](const json& v, Scene_& out) -> std::string {
          if (!v.is_object()) return "expected an object, got " + ShownValue(v);
          for (auto it = v.begin(); it != v.end(); ++it) {
            if (!it.value().is_string()) return "'" + it.key() + "' must be a string";
            out.input_hashes[it.key()] = it.value().get<std::string>();
          }
          return "";
        },
        [](const Scene_& in) { return json(in.input_hashes); });
    f.Custom(
        "spec", "string", "", "the spec the scene was loaded from",
        [](const json& v, Scene_& out) -> std::string {
          if (!v.is_string()) return "expected a string, got " + ShownValue(v);
          out.spec = v.get<std::string>();
          return "";
        },
        [](const Scene_& in) { return in.spec ? json(*in.spec) : json(); });
    f.Custom(
        "builtin_scale", "number", "", "the built-in scene's scale",
        [](const json& v, Scene_& out) -> std::string {
          if (!v.is_number()) return "expected a number, got " + ShownValue(v);
          out.builtin_scale = v.get<double>();
          return "";
        },
        [](const Scene_& in) { return in.builtin_scale ? json(*in.builtin_scale) : json(); });
    return f;
  }();
  return fields;
}

using Turbidity = RenderRecord::Turbidity;
using Derived = RenderRecord::Derived;
using Psf = RenderRecord::Derived::Psf;

const Fields<Turbidity>& TurbidityFields() {
  static const Fields<Turbidity> fields = [] {
    Fields<Turbidity> f;
    f.Unsigned("levels", &Turbidity::levels, "levels of the turbidity-dependent PSF")
        .Boolean("exact", &Turbidity::exact, "one level per distinct thickness");
    Numbers(f, "thickness", &Turbidity::thickness, "each level's optical thickness");
    f.Custom(
        "radius_px", "array of integers", "", "each level's kernel radius, pixels",
        [](const json& v, Turbidity& out) -> std::string {
          if (!v.is_array()) return "expected an array of integers, got " + ShownValue(v);
          out.radius_px.clear();
          for (const json& e : v) {
            const std::optional<int64_t> r = JsonInteger(e, 0, std::numeric_limits<int>::max());
            if (!r) return "must be an array of non-negative integers";
            out.radius_px.push_back(static_cast<int>(*r));
          }
          return "";
        },
        [](const Turbidity& in) { return json(in.radius_px); });
    return f;
  }();
  return fields;
}

const Fields<Psf>& PsfFields() {
  static const Fields<Psf> fields = [] {
    Fields<Psf> f;
    NullableNumber(f, "p", &Psf::p, "p = sqrt(T)");
    NullableNumber(f, "sigma_px", &Psf::sigma_px, "Gaussian width, pixels");
    NullableNumber(f, "scale_a_px", &Psf::scale_a_px, "the kernel's scale a, pixels");
    NonNegative(f, "radius_px", &Psf::radius_px, "truncation radius, pixels");
    NullableNumber(f, "tail_mass_outside", &Psf::tail_mass_outside, "mass outside the radius");
    f.Boolean("is_delta", &Psf::is_delta, "the kernel is a delta")
        .Boolean("separable", &Psf::separable, "applied as two 1-D passes")
        .OptionalObject("turbidity", &Psf::turbidity, TurbidityFields(),
                        "the turbidity-dependent PSF's levels (null: not used)");
    return f;
  }();
  return fields;
}

const Fields<Derived>& RangeFields() {
  static const Fields<Derived> fields = [] {
    Fields<Derived> f;
    NullableNumber(f, "min", &Derived::range_min_m, "nearest valid range, metres",
                   std::numeric_limits<double>::infinity());
    NullableNumber(f, "max", &Derived::range_max_m, "farthest valid range, metres");
    return f;
  }();
  return fields;
}

const Fields<Derived>& SnowFields() {
  static const Fields<Derived> fields = [] {
    Fields<Derived> f;
    NonNegative(f, "particles", &Derived::snow_particles, "particles drawn");
    NonNegative(f, "visible", &Derived::snow_visible, "particles in view");
    return f;
  }();
  return fields;
}

const Fields<Derived>& DerivedFields() {
  static const Fields<Derived> fields = [] {
    Fields<Derived> f;
    f.String("channel_order", &Derived::channel_order, "\"BGR\" or \"gray\"")
        .String("model", &Derived::model, "the image model");
    Numbers(f, "beta_per_m", &Derived::beta_per_m, "beta per channel, 1/m");
    OptionalNumbers(f, "beta_b_per_m", &Derived::beta_b_per_m, "beta^B (model revised)");
    OptionalNumbers(f, "backscatter", &Derived::backscatter, "B_inf when the term is on");
    Numbers(f, "ambient", &Derived::ambient, "E_A per channel");
    Numbers(f, "lambertian_order_m", &Derived::lambertian_order_m, "one per light");
    f.Inline("range_m", RangeFields(), "valid range {min, max}, metres");
    NullableNumber(f, "valid_depth_fraction", &Derived::valid_depth_fraction,
                   "share of pixels with valid depth");
    f.Object("psf", &Derived::psf, PsfFields(), "the PSF's derived values");
    f.Inline("snow", SnowFields(), "marine snow {particles, visible}");
    return f;
  }();
  return fields;
}

const Fields<RenderPlan>& PlanFields() {
  static const Fields<RenderPlan> fields = [] {
    Fields<RenderPlan> f;
    Strings(f, "steps", &RenderPlan::steps, "what the render did, in order");
    Strings(f, "skipped", &RenderPlan::skipped, "what it skipped, and why");
    return f;
  }();
  return fields;
}

const Fields<Record::Item>& ItemFields() {
  static const Fields<Record::Item> fields = [] {
    Fields<Record::Item> f;
    f.Custom(
        "index", "integer", ">= 0", "generate's item index",
        [](const json& v, Record::Item& out) { return NonNegativeProblem(v, &out.index); },
        [](const Record::Item& in) { return json(in.index); });
    f.String("id", &Record::Item::id, "generate's item id");
    return f;
  }();
  return fields;
}

// The top level. "options" goes through RenderOptionsFromJson (its own tables); "outputs" maps
// roles to file names, with the PSF map's peak as a number.
const Fields<Record>& RecordFields() {
  static const Fields<Record> fields = [] {
    Fields<Record> f;
    f.String("tool", &Record::tool, "\"turbid render\"")
        .String("version", &Record::version, "TURBID_VERSION of the build that rendered")
        .Object("scene", &Record::scene, SceneFields(), "the scene rendered")
        .Unsigned("seed", &Record::seed, "the render's seed")
        .Custom(
            "options", "object", "",
            "every render option used, presets resolved (read by RenderOptionsFromJson)",
            [](const json&, Record&) { return std::string(); },
            [](const Record& in) {
              return in.options ? ResolvedRenderOptionsToJson(*in.options) : json();
            })
        .Object("derived", &Record::derived, DerivedFields(), "values the render derived")
        .Object("plan", &Record::plan, PlanFields(), "the render plan")
        .String("encoding", &Record::encoding, "how the image file's values are coded")
        .Custom(
            "outputs", "object", "", "files written: role -> file name; psf_peak: a number",
            [](const json& v, Record& out) -> std::string {
              if (!v.is_object()) return "expected an object, got " + ShownValue(v);
              for (auto it = v.begin(); it != v.end(); ++it) {
                if (it.key() == "psf_peak") {
                  if (!it.value().is_number()) return "'psf_peak' must be a number";
                  out.psf_peak = it.value().get<double>();
                } else if (!it.value().is_string()) {
                  return "'" + it.key() + "' expected a string, got " + ShownValue(it.value());
                } else {
                  out.outputs[it.key()] = it.value().get<std::string>();
                }
              }
              return "";
            },
            [](const Record& in) {
              json files = json::object();
              for (const auto& [role, file] : in.outputs) files[role] = file;
              if (in.psf_peak) files["psf_peak"] = *in.psf_peak;
              return files;
            })
        .OptionalObject("item", &Record::item, ItemFields(), "generate's item");
    return f;
  }();
  return fields;
}

}  // namespace

json RenderRecord::ToJson() const {
  json out = RecordFields().ToJson(*this);
  // Keys the tools set only when set.
  if (!options) out.erase("options");
  if (outputs.empty() && !psf_peak) out.erase("outputs");
  if (!item) out.erase("item");
  if (!scene.spec) out["scene"].erase("spec");
  if (!scene.builtin_scale) out["scene"].erase("builtin_scale");
  return out;
}

RenderRecord RenderRecord::FromJson(const json& j, const std::string& source) {
  RenderRecord r;
  const std::string where = source + ": sidecar";
  RecordFields().Read(j, &r, where);
  if (const auto o = j.find("options"); o != j.end()) {
    try {
      r.options = RenderOptionsFromJson(*o);
    } catch (const Error& e) {
      throw Error(source, e.what());  // "render options: <key path>: <problem>"
    }
  }
  return r;
}

}  // namespace turbid
