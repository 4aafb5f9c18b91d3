#include "simulator/render_options.h"

#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "core/error.h"

namespace turbid {
namespace {

using nlohmann::json;

// ---- strict JSON reading ------------------------------------------------------------------------

void RequireObject(const json& j, const std::string& path) {
  if (!j.is_object())
    throw Error("render options: " + (path.empty() ? "top level" : path) + ": must be an object");
}

void RejectUnknown(const json& j, const std::string& path, const std::set<std::string>& allowed) {
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!allowed.count(it.key()))
      throw Error("render options: " + path + it.key() + ": unknown key");
}

void Read(const json& j, const std::string& key, const std::string& path, double& field) {
  if (!j.contains(key)) return;
  const json& v = j.at(key);
  if (!v.is_number()) throw Error("render options: " + path + key + ": must be a number");
  field = v.get<double>();
  if (!std::isfinite(field)) throw Error("render options: " + path + key + ": must be finite");
}

void Read(const json& j, const std::string& key, const std::string& path, int& field) {
  if (!j.contains(key)) return;
  const json& v = j.at(key);
  if (!v.is_number_integer()) throw Error("render options: " + path + key + ": must be an integer");
  const int64_t value = v.get<int64_t>();
  if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max())
    throw Error("render options: " + path + key + ": out of range");
  field = static_cast<int>(value);
}

void Read(const json& j, const std::string& key, const std::string& path, bool& field) {
  if (!j.contains(key)) return;
  const json& v = j.at(key);
  if (!v.is_boolean()) throw Error("render options: " + path + key + ": must be true or false");
  field = v.get<bool>();
}

void Read(const json& j, const std::string& key, const std::string& path, std::string& field) {
  if (!j.contains(key)) return;
  const json& v = j.at(key);
  if (!v.is_string()) throw Error("render options: " + path + key + ": must be a string");
  field = v.get<std::string>();
}

template <typename Array>
void ReadTriple(const json& j, const std::string& key, const std::string& path, Array& field) {
  if (!j.contains(key)) return;
  const json& v = j.at(key);
  if (!v.is_array() || v.size() != 3)
    throw Error("render options: " + path + key + ": must be an array of 3 numbers");
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number())
      throw Error("render options: " + path + key + ": must be an array of 3 numbers");
    field[i] = v[i].get<double>();
    if (!std::isfinite(field[i])) throw Error("render options: " + path + key + ": must be finite");
  }
}

template <typename Options>
void CheckSection(const Options& options, const std::string& path) {
  std::string why;
  if (!options.Check(&why)) throw Error("render options: " + path + why);
}

json Triple(const Rgb& v) { return json::array({v[0], v[1], v[2]}); }
json Triple(const cv::Vec3d& v) { return json::array({v[0], v[1], v[2]}); }

bool SameRgb(const Rgb& a, const Rgb& b) {
  for (int i = 0; i < 3; ++i)
    if (std::abs(a[i] - b[i]) > 1e-9) return false;
  return true;
}

// A field a preset sets: its key and member.
template <typename Options, typename Value>
struct PresetField {
  const char* key;
  Value Options::*member;
};

// The one path of the presets (water.type, uwcnn.type): a section whose `type` names a preset
// becomes the preset (resolve), and the values it gives for the preset's own fields must repeat
// the preset's (a sidecar does); anything else would be silently overridden.
template <typename Options>
void ApplyPreset(const json& section, const std::string& name, const std::string& what,
                 Options (*resolve)(const Options&), PresetField<Options, Rgb> rgb,
                 PresetField<Options, double> gray, Options& options) {
  if (options.type == "custom") return;
  const Options preset = resolve(options);
  const bool rgb_conflict =
      section.contains(rgb.key) && !SameRgb(options.*rgb.member, preset.*rgb.member);
  const bool gray_conflict =
      section.contains(gray.key) && std::abs(options.*gray.member - preset.*gray.member) > 1e-9;
  if (rgb_conflict || gray_conflict)
    throw Error("render options: " + name + "." + (rgb_conflict ? rgb.key : gray.key) +
                ": conflicts with " + name + ".type '" + options.type +
                "' (use type \"custom\" to set " + what + ")");
  options = preset;
}

}  // namespace

// ---- options ------------------------------------------------------------------------------------

bool CameraOutputOptions::Check(std::string* why) const {
  if (bit_depth == 8 || bit_depth == 16 || bit_depth == 32) return true;
  if (why) *why = "bit_depth: must be 8, 16 or 32 (float)";
  return false;
}

MapSelection MapSelection::FromList(const std::string& list) {
  MapSelection maps;
  std::stringstream stream(list);
  std::string name;
  while (std::getline(stream, name, ',')) {
    if (name.empty()) continue;
    if (name == "transmission")
      maps.transmission = true;
    else if (name == "light")
      maps.light = true;
    else if (name == "veil")
      maps.veil = true;
    else if (name == "psf")
      maps.psf = true;
    else if (name == "noise")
      maps.noise = true;
    else
      throw Error("--maps: unknown map '" + name + "' (transmission, light, veil, psf, noise)");
  }
  return maps;
}

bool RenderOptions::Check(std::string* why) const {
  auto section = [&](const auto& options, const std::string& name) {
    std::string inner;
    if (options.Check(&inner)) return true;
    if (why) *why = name + "." + inner;
    return false;
  };
  return section(revised, "revised") && section(uwcnn, "uwcnn") && section(water, "water") &&
         section(light, "light") && section(psf, "psf") && section(snow, "snow") &&
         section(sensor, "sensor") && section(camera, "camera");
}

namespace {

void ReadRevisedSection(const json& v, RenderOptions& o) {
  const std::string p = "revised.";
  RequireObject(v, "revised");
  RejectUnknown(v, p,
                {"beta_b_rgb_per_m", "beta_b_gray_per_m", "range_dependent", "a_rgb", "b_rgb",
                 "c_rgb", "d_rgb", "a_gray", "b_gray", "c_gray", "d_gray"});
  ReadTriple(v, "beta_b_rgb_per_m", p, o.revised.beta_b_rgb_per_m);
  Read(v, "beta_b_gray_per_m", p, o.revised.beta_b_gray_per_m);
  Read(v, "range_dependent", p, o.revised.range_dependent);
  ReadTriple(v, "a_rgb", p, o.revised.a_rgb);
  ReadTriple(v, "b_rgb", p, o.revised.b_rgb);
  ReadTriple(v, "c_rgb", p, o.revised.c_rgb);
  ReadTriple(v, "d_rgb", p, o.revised.d_rgb);
  Read(v, "a_gray", p, o.revised.a_gray);
  Read(v, "b_gray", p, o.revised.b_gray);
  Read(v, "c_gray", p, o.revised.c_gray);
  Read(v, "d_gray", p, o.revised.d_gray);
  CheckSection(o.revised, p);
}

void ReadUwcnnSection(const json& v, RenderOptions& o) {
  const std::string p = "uwcnn.";
  RequireObject(v, "uwcnn");
  RejectUnknown(v, p,
                {"type", "n_rgb_per_m", "n_gray_per_m", "backlight_scale", "backlight_exponent",
                 "max_distance_m"});
  Read(v, "type", p, o.uwcnn.type);
  ReadTriple(v, "n_rgb_per_m", p, o.uwcnn.n_rgb_per_m);
  Read(v, "n_gray_per_m", p, o.uwcnn.n_gray_per_m);
  Read(v, "backlight_scale", p, o.uwcnn.backlight_scale);
  Read(v, "backlight_exponent", p, o.uwcnn.backlight_exponent);
  Read(v, "max_distance_m", p, o.uwcnn.max_distance_m);
  CheckSection(o.uwcnn, p);
  ApplyPreset(v, "uwcnn", "N", ResolveUwcnn, {"n_rgb_per_m", &UwcnnOptions::n_rgb_per_m},
              {"n_gray_per_m", &UwcnnOptions::n_gray_per_m}, o.uwcnn);
}

void ReadSeed(const json& s, RenderOptions& o) {
  // Parsed text gives non-negative integers as unsigned, but a json built in code may hold a
  // signed one; negative ones and floats (also integers beyond 2^64 - 1) are refused.
  if (!s.is_number_unsigned() && !(s.is_number_integer() && s.get<int64_t>() >= 0))
    throw Error("render options: seed: must be an integer in [0, 18446744073709551615]");
  o.seed = s.get<uint64_t>();
}

void ReadWaterSection(const json& w, RenderOptions& o) {
  const std::string p = "water.";
  RequireObject(w, "water");
  RejectUnknown(w, p,
                {"type", "beta_rgb_per_m", "beta_gray_per_m", "ambient_rgb", "ambient_gray",
                 "backscatter", "backscatter_rgb", "backscatter_gray"});
  Read(w, "type", p, o.water.type);
  ReadTriple(w, "beta_rgb_per_m", p, o.water.beta_rgb_per_m);
  Read(w, "beta_gray_per_m", p, o.water.beta_gray_per_m);
  ReadTriple(w, "ambient_rgb", p, o.water.ambient_rgb);
  Read(w, "ambient_gray", p, o.water.ambient_gray);
  Read(w, "backscatter", p, o.water.backscatter);
  ReadTriple(w, "backscatter_rgb", p, o.water.backscatter_rgb);
  Read(w, "backscatter_gray", p, o.water.backscatter_gray);
  CheckSection(o.water, p);
  ApplyPreset(w, "water", "beta", ResolveWater, {"beta_rgb_per_m", &WaterOptions::beta_rgb_per_m},
              {"beta_gray_per_m", &WaterOptions::beta_gray_per_m}, o.water);
}

void ReadLightSection(const json& l, RenderOptions& o) {
  const std::string p = "light.";
  RequireObject(l, "light");
  RejectUnknown(l, p, {"lights", "incidence", "min_cos_incidence", "min_distance_m"});
  if (l.contains("lights")) {
    const json& list = l.at("lights");
    if (!list.is_array()) throw Error("render options: light.lights: must be an array");
    o.light.lights.clear();
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string lp = p + "lights[" + std::to_string(i) + "].";
      RequireObject(list[i], lp.substr(0, lp.size() - 1));
      RejectUnknown(
          list[i], lp,
          {"position_in_camera_m", "axis_in_camera", "power", "half_power_angle_deg", "color_rgb"});
      LightOptions light;
      ReadTriple(list[i], "position_in_camera_m", lp, light.position_in_camera_m);
      ReadTriple(list[i], "axis_in_camera", lp, light.axis_in_camera);
      Read(list[i], "power", lp, light.power);
      Read(list[i], "half_power_angle_deg", lp, light.half_power_angle_deg);
      ReadTriple(list[i], "color_rgb", lp, light.color_rgb);
      CheckSection(light, lp);
      o.light.lights.push_back(light);
    }
  }
  if (l.contains("incidence")) {
    std::string name;
    Read(l, "incidence", p, name);
    if (name != "lambertian" && name != "paper_eq5")
      throw Error("render options: light.incidence: unknown model '" + name +
                  "' (lambertian, paper_eq5)");
    o.light.incidence = IncidenceModelFromName(name);
  }
  Read(l, "min_cos_incidence", p, o.light.min_cos_incidence);
  Read(l, "min_distance_m", p, o.light.min_distance_m);
  CheckSection(o.light, p);
}

void ReadPsfSection(const json& s, RenderOptions& o) {
  const std::string p = "psf.";
  RequireObject(s, "psf");
  RejectUnknown(s, p,
                {"enabled", "optical_thickness", "forward_scatter", "pixels_per_unit", "tail_mass",
                 "max_radius_px", "delta_tolerance", "depth_dependent", "reference_range_m",
                 "depth_levels", "turbidity_dependent", "thickness_levels"});
  Read(s, "enabled", p, o.psf.enabled);
  Read(s, "optical_thickness", p, o.psf.optical_thickness);
  Read(s, "forward_scatter", p, o.psf.forward_scatter);
  Read(s, "pixels_per_unit", p, o.psf.pixels_per_unit);
  Read(s, "tail_mass", p, o.psf.tail_mass);
  Read(s, "max_radius_px", p, o.psf.max_radius_px);
  Read(s, "delta_tolerance", p, o.psf.delta_tolerance);
  Read(s, "depth_dependent", p, o.psf.depth_dependent);
  Read(s, "reference_range_m", p, o.psf.reference_range_m);
  Read(s, "depth_levels", p, o.psf.depth_levels);
  Read(s, "turbidity_dependent", p, o.psf.turbidity_dependent);
  Read(s, "thickness_levels", p, o.psf.thickness_levels);
  CheckSection(o.psf, p);
}

void ReadSnowSection(const json& s, RenderOptions& o) {
  const std::string p = "snow.";
  RequireObject(s, "snow");
  RejectUnknown(s, p,
                {"enabled", "density_per_m3", "near_m", "far_m", "size_min_m", "size_max_m",
                 "albedo_min", "albedo_max", "blur_px"});
  Read(s, "enabled", p, o.snow.enabled);
  Read(s, "density_per_m3", p, o.snow.density_per_m3);
  Read(s, "near_m", p, o.snow.near_m);
  Read(s, "far_m", p, o.snow.far_m);
  Read(s, "size_min_m", p, o.snow.size_min_m);
  Read(s, "size_max_m", p, o.snow.size_max_m);
  Read(s, "albedo_min", p, o.snow.albedo_min);
  Read(s, "albedo_max", p, o.snow.albedo_max);
  Read(s, "blur_px", p, o.snow.blur_px);
  CheckSection(o.snow, p);
}

void ReadSensorSection(const json& s, RenderOptions& o) {
  const std::string p = "sensor.";
  RequireObject(s, "sensor");
  RejectUnknown(s, p, {"enabled", "photons_at_white", "read_noise"});
  Read(s, "enabled", p, o.sensor.enabled);
  Read(s, "photons_at_white", p, o.sensor.photons_at_white);
  Read(s, "read_noise", p, o.sensor.read_noise);
  CheckSection(o.sensor, p);
}

void ReadCameraSection(const json& s, RenderOptions& o) {
  const std::string p = "camera.";
  RequireObject(s, "camera");
  RejectUnknown(s, p, {"bit_depth", "encoding"});
  Read(s, "bit_depth", p, o.camera.bit_depth);
  if (s.contains("encoding")) {
    std::string name;
    Read(s, "encoding", p, name);
    o.camera.encoding = CameraEncodingFromName(name, "render options: camera.encoding");
  }
  CheckSection(o.camera, p);
}

}  // namespace

RenderOptions RenderOptionsFromJson(const json& j) {
  RenderOptions o;
  RequireObject(j, "");
  RejectUnknown(
      j, "",
      {"model", "revised", "uwcnn", "water", "light", "psf", "snow", "sensor", "camera", "seed"});
  if (j.contains("model")) {
    std::string name;
    Read(j, "model", "", name);
    o.model = ImageModelFromName(name);
  }
  if (j.contains("revised")) ReadRevisedSection(j.at("revised"), o);
  if (j.contains("uwcnn")) ReadUwcnnSection(j.at("uwcnn"), o);
  if (j.contains("seed")) ReadSeed(j.at("seed"), o);
  if (j.contains("water")) ReadWaterSection(j.at("water"), o);
  if (j.contains("light")) ReadLightSection(j.at("light"), o);
  if (j.contains("psf")) ReadPsfSection(j.at("psf"), o);
  if (j.contains("snow")) ReadSnowSection(j.at("snow"), o);
  if (j.contains("sensor")) ReadSensorSection(j.at("sensor"), o);
  if (j.contains("camera")) ReadCameraSection(j.at("camera"), o);
  return o;
}

RenderOptions ResolvePresets(const RenderOptions& options) {
  RenderOptions o = options;
  std::string why;
  if (o.water.type != "custom" && o.water.Check(&why)) o.water = ResolveWater(o.water);
  if (o.uwcnn.type != "custom" && o.uwcnn.Check(&why)) o.uwcnn = ResolveUwcnn(o.uwcnn);
  return o;
}

json RenderOptionsToJson(const RenderOptions& options) {
  // A Jerlov type writes the preset's betas, so the JSON reads back without a conflict.
  return ResolvedRenderOptionsToJson(ResolvePresets(options));
}

json ResolvedRenderOptionsToJson(const RenderOptions& o) {
  json lights = json::array();
  for (const LightOptions& l : o.light.lights)
    lights.push_back({{"position_in_camera_m", Triple(l.position_in_camera_m)},
                      {"axis_in_camera", Triple(l.axis_in_camera)},
                      {"power", l.power},
                      {"half_power_angle_deg", l.half_power_angle_deg},
                      {"color_rgb", Triple(l.color_rgb)}});
  json out = {
      {"model", ImageModelName(o.model)},
      {"water",
       {{"type", o.water.type},
        {"beta_rgb_per_m", Triple(o.water.beta_rgb_per_m)},
        {"beta_gray_per_m", o.water.beta_gray_per_m},
        {"ambient_rgb", Triple(o.water.ambient_rgb)},
        {"ambient_gray", o.water.ambient_gray},
        {"backscatter", o.water.backscatter},
        {"backscatter_rgb", Triple(o.water.backscatter_rgb)},
        {"backscatter_gray", o.water.backscatter_gray}}},
      {"light",
       {{"lights", lights},
        {"incidence", IncidenceModelName(o.light.incidence)},
        {"min_cos_incidence", o.light.min_cos_incidence},
        {"min_distance_m", o.light.min_distance_m}}},
      {"psf",
       {{"enabled", o.psf.enabled},
        {"optical_thickness", o.psf.optical_thickness},
        {"forward_scatter", o.psf.forward_scatter},
        {"pixels_per_unit", o.psf.pixels_per_unit},
        {"tail_mass", o.psf.tail_mass},
        {"max_radius_px", o.psf.max_radius_px},
        {"delta_tolerance", o.psf.delta_tolerance},
        {"depth_dependent", o.psf.depth_dependent},
        {"reference_range_m", o.psf.reference_range_m},
        {"depth_levels", o.psf.depth_levels},
        {"turbidity_dependent", o.psf.turbidity_dependent},
        {"thickness_levels", o.psf.thickness_levels}}},
      {"snow",
       {{"enabled", o.snow.enabled},
        {"density_per_m3", o.snow.density_per_m3},
        {"near_m", o.snow.near_m},
        {"far_m", o.snow.far_m},
        {"size_min_m", o.snow.size_min_m},
        {"size_max_m", o.snow.size_max_m},
        {"albedo_min", o.snow.albedo_min},
        {"albedo_max", o.snow.albedo_max},
        {"blur_px", o.snow.blur_px}}},
      {"sensor",
       {{"enabled", o.sensor.enabled},
        {"photons_at_white", o.sensor.photons_at_white},
        {"read_noise", o.sensor.read_noise}}},
      {"camera",
       {{"bit_depth", o.camera.bit_depth}, {"encoding", CameraEncodingName(o.camera.encoding)}}},
      {"seed", o.seed},
  };
  // The active model's own section (the others are unused and left out).
  if (o.model == ImageModel::kRevised)
    out["revised"] = {{"beta_b_rgb_per_m", Triple(o.revised.beta_b_rgb_per_m)},
                      {"beta_b_gray_per_m", o.revised.beta_b_gray_per_m},
                      {"range_dependent", o.revised.range_dependent},
                      {"a_rgb", Triple(o.revised.a_rgb)},
                      {"b_rgb", Triple(o.revised.b_rgb)},
                      {"c_rgb", Triple(o.revised.c_rgb)},
                      {"d_rgb", Triple(o.revised.d_rgb)},
                      {"a_gray", o.revised.a_gray},
                      {"b_gray", o.revised.b_gray},
                      {"c_gray", o.revised.c_gray},
                      {"d_gray", o.revised.d_gray}};
  if (o.model == ImageModel::kUwcnn)
    out["uwcnn"] = {{"type", o.uwcnn.type},
                    {"n_rgb_per_m", Triple(o.uwcnn.n_rgb_per_m)},
                    {"n_gray_per_m", o.uwcnn.n_gray_per_m},
                    {"backlight_scale", o.uwcnn.backlight_scale},
                    {"backlight_exponent", o.uwcnn.backlight_exponent},
                    {"max_distance_m", o.uwcnn.max_distance_m}};
  return out;
}

std::string RenderPlan::ToText() const {
  std::string text = "render plan:\n";
  for (const std::string& s : steps) text += "  do:   " + s + "\n";
  for (const std::string& s : skipped) text += "  skip: " + s + "\n";
  return text;
}

json RenderPlan::ToJson() const { return {{"steps", steps}, {"skipped", skipped}}; }

}  // namespace turbid
