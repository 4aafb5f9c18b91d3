#include "simulator/render_options.h"

#include <cmath>
#include <sstream>

#include "core/error.h"

namespace turbid {
namespace {

using nlohmann::json;

// The source every options message names ("render options: 'psf.forward_scatter': ..."); a
// caller reading a file prefixes the file's name.
const char kSource[] = "render options";

template <typename Options>
void CheckSection(const Options& options, const std::string& path) {
  std::string why;
  if (!options.Check(&why)) throw Error(std::string(kSource) + ": " + path + why);
}

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

// ---- the field tables: each key once, reading and ToJson from the same line ---------------------

const Fields<RevisedOptions>& RevisedFields() {
  using O = RevisedOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Array("beta_b_rgb_per_m", &O::beta_b_rgb_per_m, 3, "backscatter beta_B, R G B, 1/m")
          .Member("beta_b_gray_per_m", &O::beta_b_gray_per_m, "beta_B for gray images, 1/m")
          .Member("range_dependent", &O::range_dependent, "beta_D(r) = a exp(b r) + c exp(d r)")
          .Member("from_iop", &O::from_iop, "with water.iop: beta_D(r), beta_B(r) from spectra")
          .Array("a_rgb", &O::a_rgb, 3, "a per channel, 1/m")
          .Array("b_rgb", &O::b_rgb, 3, "b per channel, 1/m")
          .Array("c_rgb", &O::c_rgb, 3, "c per channel, 1/m")
          .Array("d_rgb", &O::d_rgb, 3, "d per channel, 1/m")
          .Member("a_gray", &O::a_gray, "a for gray images, 1/m")
          .Member("b_gray", &O::b_gray, "b for gray images, 1/m")
          .Member("c_gray", &O::c_gray, "c for gray images, 1/m")
          .Member("d_gray", &O::d_gray, "d for gray images, 1/m");
  return fields;
}

const Fields<UwcnnOptions>& UwcnnFields() {
  using O = UwcnnOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("type", &O::type, "Jerlov-based preset of N, or \"custom\"")
          .Array("n_rgb_per_m", &O::n_rgb_per_m, 3, "N per metre, R G B (type \"custom\")")
          .Member("n_gray_per_m", &O::n_gray_per_m, "N per metre for gray images")
          .Member("backlight_scale", &O::backlight_scale, "background light scale")
          .Member("backlight_exponent", &O::backlight_exponent, "background light exponent")
          .Member("max_distance_m", &O::max_distance_m, "ranges scaled to this, m; 0: as is")
          .Choice("domain", &O::domain,
                  {{"encoded", UwcnnDomain::kEncoded}, {"linear", UwcnnDomain::kLinear}},
                  "recipe on 8-bit sRGB codes (the scripts) or on linear light");
  return fields;
}

const Fields<WaterOptions>& WaterFields() {
  using O = WaterOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("type", &O::type, "Jerlov water type, or \"custom\"")
          .Array("beta_rgb_per_m", &O::beta_rgb_per_m, 3, "attenuation, R G B, 1/m")
          .Member("beta_gray_per_m", &O::beta_gray_per_m, "attenuation for gray images, 1/m")
          .Array("ambient_rgb", &O::ambient_rgb, 3, "ambient light E_A, R G B")
          .Member("ambient_gray", &O::ambient_gray, "E_A for gray images")
          .Member("backscatter", &O::backscatter, "add the ambient backscatter (1 - t) B_inf")
          .Array("backscatter_rgb", &O::backscatter_rgb, 3, "B_inf, R G B")
          .Member("backscatter_gray", &O::backscatter_gray, "B_inf for gray images")
          .Array("scattering_albedo_rgb", &O::scattering_albedo_rgb, 3,
                 "single-scattering albedo b/c, R G B (physical terms only)")
          .Member("scattering_albedo_gray", &O::scattering_albedo_gray,
                  "single-scattering albedo b/c for gray images")
          .Member("ambient_view_elevation_deg", &O::ambient_view_elevation_deg,
                  "ambient \"derived\": optical axis above the horizontal, degrees")
          .Custom(
              "phase", "object", "", "phase function (keys: section water.phase)",
              [](const json& v, O& out) {
                PhaseFunctionFields().Read(v, &out.phase, kSource, "water.phase");
                return std::string();
              },
              [](const O& in) { return PhaseFunctionFields().ToJson(in.phase); })
          .Member("iop", &O::iop, "\"\" or a Jerlov type or a CSV of a(lambda), b(lambda)")
          .Member("illuminant", &O::illuminant, "equal_energy, d65 or a CSV (with iop)")
          .Member("camera_sensitivity", &O::camera_sensitivity, "srgb or a CSV (with iop)");
  return fields;
}

const Fields<LightOptions>& LightFields() {
  using O = LightOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Array("position_in_camera_m", &O::position_in_camera_m, 3, "position, camera frame, m")
          .Array("axis_in_camera", &O::axis_in_camera, 3, "emission axis, camera frame")
          .Member("power", &O::power, "U0, image units * m^2")
          .Member("half_power_angle_deg", &O::half_power_angle_deg, "half-power angle, degrees")
          .Member("cutoff_angle_deg", &O::cutoff_angle_deg, "spot cut-off from the axis, degrees")
          .Array("color_rgb", &O::color_rgb, 3, "relative power per channel, R G B");
  return fields;
}

// light.lights: an array of light objects, each read with LightFields.
std::string ReadLights(const json& list, IrradianceOptions& out) {
  if (!list.is_array())
    return "expected an array of light objects, got " + fields_detail::ShownValue(list);
  out.lights.clear();
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string where = "light.lights[" + std::to_string(i) + "]";
    if (list[i].is_null()) throw Error(kSource, "'" + where + "' must be a JSON object, got null");
    LightOptions light;
    LightFields().Read(list[i], &light, kSource, where);
    CheckSection(light, where + ".");
    out.lights.push_back(light);
  }
  return "";
}

json WriteLights(const IrradianceOptions& in) {
  json lights = json::array();
  for (const LightOptions& l : in.lights) lights.push_back(LightFields().ToJson(l));
  return lights;
}

const Fields<IrradianceOptions>& IrradianceFields() {
  using O = IrradianceOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Custom("lights", "array of light objects", "", "the LEDs (0..16)", ReadLights,
                  WriteLights)
          .Choice("incidence", &O::incidence,
                  {{"lambertian", IncidenceModel::kLambertian},
                   {"paper_eq5", IncidenceModel::kPaperEq5}},
                  "incidence term: max(cos psi, 0) or the paper's 1 / cos psi")
          .Member("min_cos_incidence", &O::min_cos_incidence, "paper_eq5 guard on cos psi")
          .Member("min_distance_m", &O::min_distance_m, "light-to-surface distances clamped, m");
  return fields;
}

const Fields<PsfOptions>& PsfFields() {
  using O = PsfOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("enabled", &O::enabled, "false: no blur")
          .Choice("model", &O::model,
                  {{"paper", PsfModel::kPaper}, {"small_angle", PsfModel::kSmallAngle}},
                  "eq. 7's kernel, or ballistic + small-angle glow from the water's b and phase")
          .Member("glow_levels", &O::glow_levels, "small_angle: glow widths per image")
          .Member("optical_thickness", &O::optical_thickness, "optical thickness tau")
          .Member("forward_scatter", &O::forward_scatter, "forward-scatter parameter p")
          .Member("pixels_per_unit", &O::pixels_per_unit, "kernel scale, pixels per unit")
          .Member("tail_mass", &O::tail_mass, "kernel mass left outside the radius")
          .Member("max_radius_px", &O::max_radius_px, "kernel radius cap, pixels")
          .Member("delta_tolerance", &O::delta_tolerance, "below this the kernel is a delta")
          .Member("depth_dependent", &O::depth_dependent, "kernel width grows with range")
          .Member("reference_range_m", &O::reference_range_m, "range at which sigma(r) = sigma, m")
          .Member("depth_levels", &O::depth_levels, "kernels blended across the range span")
          .Member("turbidity_dependent", &O::turbidity_dependent, "p varies with turbidity")
          .Member("thickness_levels", &O::thickness_levels, "kernels across the thickness span");
  return fields;
}

const Fields<SnowOptions>& SnowFields() {
  using O = SnowOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("enabled", &O::enabled, "false: no marine snow")
          .Member("density_per_m3", &O::density_per_m3, "particles per cubic metre")
          .Member("near_m", &O::near_m, "nearest particle distance, m")
          .Member("far_m", &O::far_m, "farthest particle distance, m")
          .Member("size_min_m", &O::size_min_m, "smallest particle diameter, m")
          .Member("size_max_m", &O::size_max_m, "largest particle diameter, m")
          .Member("albedo_min", &O::albedo_min, "lowest particle albedo")
          .Member("albedo_max", &O::albedo_max, "highest particle albedo")
          .Member("blur_px", &O::blur_px, "particle blur, pixels")
          .String("mode", &O::mode, "per_frame (drawn per render) or world (live in the world)")
          .Array("camera_to_world", &O::camera_to_world, 12,
                 "world mode: camera-to-world [R | p], row-major, metres")
          .Number("time_s", &O::time_s, "world mode: time, s", NumberRange::Between(-1e6, 1e6))
          .Array("current_m_per_s", &O::current_m_per_s, 3,
                 "world mode: particle drift in the world, m/s", NumberRange::Between(-10, 10))
          .Unsigned("world_seed", &O::world_seed, "world mode: particle seed (0: the seed)");
  return fields;
}

const Fields<SensorNoiseOptions>& SensorFields() {
  using O = SensorNoiseOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("enabled", &O::enabled, "false: noise-free sensor")
          .Member("photons_at_white", &O::photons_at_white, "photo-electrons at image value 1")
          .Member("read_noise", &O::read_noise, "read noise, image units");
  return fields;
}

const Fields<CameraOutputOptions>& CameraFields() {
  using O = CameraOutputOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Member("bit_depth", &O::bit_depth, "8, 16 or 32 (float)")
          .Choice("encoding", &O::encoding,
                  {{"srgb", CameraEncoding::kSrgb}, {"linear", CameraEncoding::kLinear}},
                  "transfer curve before quantisation");
  return fields;
}

// A section of the options ("psf": {...}): read with its own table (messages name
// 'psf.forward_scatter'), then checked; `after` (the presets) runs last.
template <typename S>
void AddSection(Fields<RenderOptions>& fields, const std::string& name, S RenderOptions::*member,
                const Fields<S>& table, const std::string& doc,
                void (*after)(const json&, S&) = nullptr) {
  fields.Custom(
      name, "object", "", doc,
      [name, member, &table, after](const json& v, RenderOptions& o) -> std::string {
        if (v.is_null()) throw Error(kSource, "'" + name + "' must be a JSON object, got null");
        table.Read(v, &(o.*member), kSource, name);
        CheckSection(o.*member, name + ".");
        if (after) after(v, o.*member);
        return "";
      },
      [member, &table](const RenderOptions& o) { return table.ToJson(o.*member); });
}

void ApplyWaterPreset(const json& section, WaterOptions& water) {
  if (!water.iop.empty() && water.type == "custom") {
    // The IOPs give beta and the albedo: values written for them must repeat what they give.
    const WaterOptions derived = ResolveWater(water);
    for (const char* key : {"beta_rgb_per_m", "scattering_albedo_rgb"}) {
      const Rgb& mine = key[0] == 'b' ? water.beta_rgb_per_m : water.scattering_albedo_rgb;
      const Rgb& theirs = key[0] == 'b' ? derived.beta_rgb_per_m : derived.scattering_albedo_rgb;
      if (section.contains(key) && !SameRgb(mine, theirs))
        throw Error(std::string("render options: water.") + key + ": conflicts with water.iop");
    }
    for (const char* key : {"beta_gray_per_m", "scattering_albedo_gray"}) {
      const double mine = key[0] == 'b' ? water.beta_gray_per_m : water.scattering_albedo_gray;
      const double theirs =
          key[0] == 'b' ? derived.beta_gray_per_m : derived.scattering_albedo_gray;
      if (section.contains(key) && std::abs(mine - theirs) > 1e-9)
        throw Error(std::string("render options: water.") + key + ": conflicts with water.iop");
    }
    water = derived;
    return;
  }
  ApplyPreset(section, "water", "beta", ResolveWater,
              {"beta_rgb_per_m", &WaterOptions::beta_rgb_per_m},
              {"beta_gray_per_m", &WaterOptions::beta_gray_per_m}, water);
}

void ApplyUwcnnPreset(const json& section, UwcnnOptions& uwcnn) {
  ApplyPreset(section, "uwcnn", "N", ResolveUwcnn, {"n_rgb_per_m", &UwcnnOptions::n_rgb_per_m},
              {"n_gray_per_m", &UwcnnOptions::n_gray_per_m}, uwcnn);
}

std::string ReadSeed(const json& s, RenderOptions& o) {
  // Parsed text gives non-negative integers as unsigned, but a json built in code may hold a
  // signed one; negative ones and floats (also integers beyond 2^64 - 1) are refused.
  return fields_detail::UnsignedProblem(s, &o.seed);
}

const Fields<RenderOptions>& OptionsFields() {
  static const Fields<RenderOptions> fields = [] {
    Fields<RenderOptions> f;
    f.Choice("model", &RenderOptions::model,
             {{"paper", ImageModel::kPaper},
              {"revised", ImageModel::kRevised},
              {"uwcnn", ImageModel::kUwcnn}},
             "image-formation model");
    f.Choice("veil", &RenderOptions::veil,
             {{"paper", VeilModel::kPaper}, {"single_scatter", VeilModel::kSingleScatter}},
             "lights' veil: eq. 2's (1 - t) E_L, or single scattering along the view ray");
    f.Choice("ambient", &RenderOptions::ambient,
             {{"typed", AmbientModel::kTyped}, {"derived", AmbientModel::kDerived}},
             "ambient backscatter B_inf: water.backscatter_*, or from E_A, b, c and the phase");
    AddSection(f, "revised", &RenderOptions::revised, RevisedFields(), "model \"revised\"");
    AddSection(f, "uwcnn", &RenderOptions::uwcnn, UwcnnFields(), "model \"uwcnn\"",
               ApplyUwcnnPreset);
    AddSection(f, "water", &RenderOptions::water, WaterFields(), "water", ApplyWaterPreset);
    AddSection(f, "light", &RenderOptions::light, IrradianceFields(), "artificial light");
    AddSection(f, "psf", &RenderOptions::psf, PsfFields(), "forward-scatter PSF");
    AddSection(f, "snow", &RenderOptions::snow, SnowFields(), "marine snow");
    AddSection(f, "sensor", &RenderOptions::sensor, SensorFields(), "sensor noise");
    AddSection(f, "camera", &RenderOptions::camera, CameraFields(), "output coding");
    f.Custom("seed", "integer", "in [0, 2^64 - 1]", "seeds snow and sensor noise", ReadSeed,
             [](const RenderOptions& o) { return json(o.seed); });
    return f;
  }();
  return fields;
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

RenderOptions RenderOptionsFromJson(const json& j) {
  RenderOptions o;
  if (j.is_null()) throw Error(kSource, "the top level must be a JSON object, got null");
  OptionsFields().Read(j, &o, kSource);
  return o;
}

RenderOptions ResolvePresets(const RenderOptions& options) {
  RenderOptions o = options;
  std::string why;
  if ((o.water.type != "custom" || !o.water.iop.empty()) && o.water.Check(&why))
    o.water = ResolveWater(o.water);
  if (o.uwcnn.type != "custom" && o.uwcnn.Check(&why)) o.uwcnn = ResolveUwcnn(o.uwcnn);
  return o;
}

json RenderOptionsToJson(const RenderOptions& options) {
  // A Jerlov type writes the preset's betas, so the JSON reads back without a conflict.
  return ResolvedRenderOptionsToJson(ResolvePresets(options));
}

json ResolvedRenderOptionsToJson(const RenderOptions& o) {
  json out = OptionsFields().ToJson(o);
  // The active model's own section only (the others are unused and left out).
  if (o.model != ImageModel::kRevised) out.erase("revised");
  if (o.model != ImageModel::kUwcnn) out.erase("uwcnn");
  return out;
}

const std::vector<RenderSection>& RenderSections() {
  static const std::vector<RenderSection> sections = [] {
    std::vector<RenderSection> out;
    auto add = [&out](const char* name, const auto& table) { out.push_back({name, table.Info()}); };
    add("revised", RevisedFields());
    add("uwcnn", UwcnnFields());
    add("water", WaterFields());
    add("water.phase", PhaseFunctionFields());
    add("light", IrradianceFields());
    add("light.lights[]", LightFields());
    add("psf", PsfFields());
    add("snow", SnowFields());
    add("sensor", SensorFields());
    add("camera", CameraFields());
    add("", OptionsFields());
    return out;
  }();
  return sections;
}

std::string RenderPlan::ToText() const {
  std::string text = "render plan:\n";
  for (const std::string& s : steps) text += "  do:   " + s + "\n";
  for (const std::string& s : skipped) text += "  skip: " + s + "\n";
  return text;
}

json RenderPlan::ToJson() const { return {{"steps", steps}, {"skipped", skipped}}; }

}  // namespace turbid
