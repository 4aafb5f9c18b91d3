#include "simulator/render_record.h"

#include <cmath>
#include <limits>
#include <set>

#include "core/error.h"

namespace turbid {
namespace {

using nlohmann::json;

// An object of the sidecar being read: each key is taken once, what is left is unknown.
class Section {
 public:
  Section(const json& j, std::string path, const std::string& source)
      : j_(j), path_(std::move(path)), source_(source) {
    if (!j_.is_object()) Fail(path_.empty() ? "top level" : path_, "must be an object");
  }

  // Throws for a key no Take asked for.
  void RejectUnknown() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!taken_.count(it.key())) Fail(Key(it.key()), "unknown key");
  }

  const json* Find(const std::string& key) {
    taken_.insert(key);
    auto it = j_.find(key);
    return it == j_.end() ? nullptr : &*it;
  }

  void Take(const std::string& key, std::string& field) {
    if (const json* v = Find(key)) {
      if (!v->is_string()) Fail(Key(key), "must be a string");
      field = v->get<std::string>();
    }
  }
  void Take(const std::string& key, bool& field) {
    if (const json* v = Find(key)) {
      if (!v->is_boolean()) Fail(Key(key), "must be true or false");
      field = v->get<bool>();
    }
  }
  // JSON writes a non-finite double as null: null reads back as `if_null`.
  void Take(const std::string& key, double& field,
            double if_null = std::numeric_limits<double>::quiet_NaN()) {
    if (const json* v = Find(key)) field = Number(*v, Key(key), if_null);
  }
  template <typename Int>
  void TakeInteger(const std::string& key, Int& field) {
    if (const json* v = Find(key)) field = Integer<Int>(*v, Key(key));
  }
  void Take(const std::string& key, int& field) { TakeInteger(key, field); }
  void Take(const std::string& key, int64_t& field) { TakeInteger(key, field); }
  void Take(const std::string& key, uint64_t& field) { TakeInteger(key, field); }
  void Take(const std::string& key, std::vector<double>& field) {
    if (const json* v = Find(key)) field = Numbers(*v, Key(key));
  }
  // null (the sidecar's "not used") leaves nullopt.
  void Take(const std::string& key, std::optional<std::vector<double>>& field) {
    if (const json* v = Find(key); v && !v->is_null()) field = Numbers(*v, Key(key));
  }
  void Take(const std::string& key, std::vector<int>& field) {
    if (const json* v = Find(key)) {
      if (!v->is_array()) Fail(Key(key), "must be an array of integers");
      field.clear();
      for (const json& e : *v) field.push_back(Integer<int>(e, Key(key)));
    }
  }
  void Take(const std::string& key, std::vector<std::string>& field) {
    if (const json* v = Find(key)) {
      if (!v->is_array()) Fail(Key(key), "must be an array of strings");
      field.clear();
      for (const json& e : *v) {
        if (!e.is_string()) Fail(Key(key), "must be an array of strings");
        field.push_back(e.get<std::string>());
      }
    }
  }

  // A nested object (nullptr when absent); `allow_null`: null counts as absent.
  std::optional<Section> Sub(const std::string& key, bool allow_null = false) {
    const json* v = Find(key);
    if (!v || (allow_null && v->is_null())) return std::nullopt;
    return Section(*v, Key(key), source_);
  }

  std::string Key(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const {
    throw Error(source_, "sidecar: " + key + ": " + problem);
  }
  const json& value() const { return j_; }

 private:
  double Number(const json& v, const std::string& key, double if_null) const {
    if (v.is_null()) return if_null;
    if (!v.is_number()) Fail(key, "must be a number");
    return v.get<double>();
  }
  std::vector<double> Numbers(const json& v, const std::string& key) const {
    if (!v.is_array()) Fail(key, "must be an array of numbers");
    std::vector<double> out;
    for (const json& e : v) {
      if (!e.is_number() && !e.is_null()) Fail(key, "must be an array of numbers");
      out.push_back(Number(e, key, std::numeric_limits<double>::quiet_NaN()));
    }
    return out;
  }
  template <typename Int>
  Int Integer(const json& v, const std::string& key) const {
    const bool fits =
        v.is_number_unsigned()
            ? v.get<uint64_t>() <= static_cast<uint64_t>(std::numeric_limits<Int>::max())
            : v.is_number_integer() && v.get<int64_t>() >= 0 &&
                  static_cast<uint64_t>(v.get<int64_t>()) <=
                      static_cast<uint64_t>(std::numeric_limits<Int>::max());
    if (!fits) Fail(key, "must be a non-negative integer");
    return v.is_number_unsigned() ? static_cast<Int>(v.get<uint64_t>())
                                  : static_cast<Int>(v.get<int64_t>());
  }

  const json& j_;
  std::string path_;
  const std::string& source_;
  std::set<std::string> taken_;
};

json OptionalArray(const std::optional<std::vector<double>>& v) { return v ? json(*v) : json(); }

json TurbidityToJson(const std::optional<RenderRecord::Turbidity>& t) {
  if (!t) return json();
  return {{"levels", t->levels},
          {"exact", t->exact},
          {"thickness", t->thickness},
          {"radius_px", t->radius_px}};
}

json DerivedToJson(const RenderRecord::Derived& d) {
  return {{"channel_order", d.channel_order},
          {"model", d.model},
          {"beta_per_m", d.beta_per_m},
          {"beta_b_per_m", OptionalArray(d.beta_b_per_m)},
          {"backscatter", OptionalArray(d.backscatter)},
          {"ambient", d.ambient},
          {"lambertian_order_m", d.lambertian_order_m},
          {"range_m", {{"min", d.range_min_m}, {"max", d.range_max_m}}},
          {"valid_depth_fraction", d.valid_depth_fraction},
          {"psf",
           {{"p", d.psf.p},
            {"sigma_px", d.psf.sigma_px},
            {"scale_a_px", d.psf.scale_a_px},
            {"radius_px", d.psf.radius_px},
            {"tail_mass_outside", d.psf.tail_mass_outside},
            {"is_delta", d.psf.is_delta},
            {"separable", d.psf.separable},
            {"turbidity", TurbidityToJson(d.psf.turbidity)}}},
          {"snow", {{"particles", d.snow_particles}, {"visible", d.snow_visible}}}};
}

json SceneToJson(const RenderRecord::SceneInfo& s) {
  json hashes = json::object();
  for (const auto& [path, hash] : s.input_hashes) hashes[path] = hash;
  json out = {{"name", s.name},
              {"width", s.width},
              {"height", s.height},
              {"channels", s.channels},
              {"camera", {{"fx", s.fx}, {"fy", s.fy}, {"cx", s.cx}, {"cy", s.cy}}},
              {"input_hashes", hashes}};
  if (s.spec) out["spec"] = *s.spec;
  if (s.builtin_scale) out["builtin_scale"] = *s.builtin_scale;
  return out;
}

void ReadScene(Section s, RenderRecord::SceneInfo* scene) {
  s.Take("name", scene->name);
  s.Take("width", scene->width);
  s.Take("height", scene->height);
  s.Take("channels", scene->channels);
  if (auto c = s.Sub("camera")) {
    c->Take("fx", scene->fx);
    c->Take("fy", scene->fy);
    c->Take("cx", scene->cx);
    c->Take("cy", scene->cy);
    c->RejectUnknown();
  }
  if (auto h = s.Sub("input_hashes")) {
    for (auto it = h->value().begin(); it != h->value().end(); ++it)
      h->Take(it.key(), scene->input_hashes[it.key()]);
  }
  if (s.Find("spec")) s.Take("spec", scene->spec.emplace());
  if (s.Find("builtin_scale")) s.Take("builtin_scale", scene->builtin_scale.emplace());
  s.RejectUnknown();
}

void ReadPsf(Section s, RenderRecord::Derived::Psf* psf) {
  s.Take("p", psf->p);
  s.Take("sigma_px", psf->sigma_px);
  s.Take("scale_a_px", psf->scale_a_px);
  s.Take("radius_px", psf->radius_px);
  s.Take("tail_mass_outside", psf->tail_mass_outside);
  s.Take("is_delta", psf->is_delta);
  s.Take("separable", psf->separable);
  if (auto t = s.Sub("turbidity", true)) {
    // Assigned, not emplace()d: clang 14 caches is_constructible<Turbidity> as false while
    // RenderRecord (which holds the optional) is being defined, before the nested type's default
    // member initializers are parsed, and then refuses emplace() with no arguments.
    psf->turbidity = RenderRecord::Turbidity{};
    RenderRecord::Turbidity& turbidity = *psf->turbidity;
    t->Take("levels", turbidity.levels);
    t->Take("exact", turbidity.exact);
    t->Take("thickness", turbidity.thickness);
    t->Take("radius_px", turbidity.radius_px);
    t->RejectUnknown();
  }
  s.RejectUnknown();
}

void ReadDerived(Section s, RenderRecord::Derived* d) {
  s.Take("channel_order", d->channel_order);
  s.Take("model", d->model);
  s.Take("beta_per_m", d->beta_per_m);
  s.Take("beta_b_per_m", d->beta_b_per_m);
  s.Take("backscatter", d->backscatter);
  s.Take("ambient", d->ambient);
  s.Take("lambertian_order_m", d->lambertian_order_m);
  if (auto r = s.Sub("range_m")) {
    r->Take("min", d->range_min_m, std::numeric_limits<double>::infinity());
    r->Take("max", d->range_max_m);
    r->RejectUnknown();
  }
  s.Take("valid_depth_fraction", d->valid_depth_fraction);
  if (auto p = s.Sub("psf")) ReadPsf(*p, &d->psf);
  if (auto snow = s.Sub("snow")) {
    snow->Take("particles", d->snow_particles);
    snow->Take("visible", d->snow_visible);
    snow->RejectUnknown();
  }
  s.RejectUnknown();
}

void ReadOutputs(Section s, RenderRecord* r) {
  for (auto it = s.value().begin(); it != s.value().end(); ++it) {
    if (it.key() == "psf_peak")
      s.Take("psf_peak", r->psf_peak.emplace());
    else
      s.Take(it.key(), r->outputs[it.key()]);
  }
}

}  // namespace

json RenderRecord::ToJson() const {
  json out = {
      {"tool", tool},
      {"version", version},
      {"scene", SceneToJson(scene)},
      {"seed", seed},
      {"derived", DerivedToJson(derived)},
      {"plan", plan.ToJson()},
      // How the image file's values are coded (what `turbid score` and `enhance` read).
      {"encoding", encoding},
  };
  if (options) out["options"] = ResolvedRenderOptionsToJson(*options);
  if (!outputs.empty() || psf_peak) {
    json files = json::object();
    for (const auto& [role, file] : outputs) files[role] = file;
    if (psf_peak) files["psf_peak"] = *psf_peak;
    out["outputs"] = files;
  }
  if (item) out["item"] = {{"index", item->index}, {"id", item->id}};
  return out;
}

RenderRecord RenderRecord::FromJson(const json& j, const std::string& source) {
  RenderRecord r;
  Section top(j, "", source);
  top.Take("tool", r.tool);
  top.Take("version", r.version);
  if (auto s = top.Sub("scene")) ReadScene(*s, &r.scene);
  top.Take("seed", r.seed);
  if (const json* o = top.Find("options")) {
    try {
      r.options = RenderOptionsFromJson(*o);
    } catch (const Error& e) {
      throw Error(source, e.what());  // "render options: <key path>: <problem>"
    }
  }
  if (auto d = top.Sub("derived")) ReadDerived(*d, &r.derived);
  if (auto p = top.Sub("plan")) {
    p->Take("steps", r.plan.steps);
    p->Take("skipped", r.plan.skipped);
    p->RejectUnknown();
  }
  top.Take("encoding", r.encoding);
  if (auto o = top.Sub("outputs")) ReadOutputs(*o, &r);
  if (auto i = top.Sub("item")) {
    r.item = Item{};  // not emplace(): as for the turbidity above (clang 14)
    Item& item = *r.item;
    i->Take("index", item.index);
    i->Take("id", item.id);
    i->RejectUnknown();
  }
  top.RejectUnknown();
  return r;
}

}  // namespace turbid
