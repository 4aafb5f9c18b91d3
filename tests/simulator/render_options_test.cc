// The render options' field tables (simulator/render_options.cc): every section reads back what
// it writes, every key a table lists is accepted, and an unknown key is refused with its dotted
// name.
#include "simulator/render_options.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/error.h"

namespace turbid {
namespace {

using nlohmann::json;

// `object` placed where section `name` lives in the options JSON.
json Wrap(const std::string& name, const json& object) {
  if (name.empty()) return object;
  if (name == "light.lights[]") return {{"light", {{"lights", json::array({object})}}}};
  const size_t dot = name.find('.');  // a nested object such as "water.phase"
  if (dot != std::string::npos) return {{name.substr(0, dot), {{name.substr(dot + 1), object}}}};
  return {{name, object}};
}

// The dotted name messages give a key of section `name`.
std::string Dotted(const std::string& name, const std::string& key) {
  if (name.empty()) return key;
  if (name == "light.lights[]") return "light.lights[0]." + key;
  return name + "." + key;
}

// "water.phase" -> "water/phase" (a JSON pointer's path).
std::string Slashed(std::string name) {
  std::replace(name.begin(), name.end(), '.', '/');
  return name;
}

std::string ErrorOf(const json& j) {
  try {
    RenderOptionsFromJson(j);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

RenderOptions WithModel(ImageModel model) {
  RenderOptions o;
  o.model = model;
  return o;
}

TEST(RenderOptions, EverySectionReadsBackWhatItWrites) {
  for (ImageModel model : {ImageModel::kPaper, ImageModel::kRevised, ImageModel::kUwcnn}) {
    const json all = RenderOptionsToJson(WithModel(model));
    EXPECT_EQ(RenderOptionsToJson(RenderOptionsFromJson(all)), all);
    for (auto it = all.begin(); it != all.end(); ++it) {
      // One section alone (with the model that writes it) reads back to the same section.
      json one = {{it.key(), it.value()}, {"model", all["model"]}};
      EXPECT_EQ(RenderOptionsToJson(RenderOptionsFromJson(one))[it.key()], it.value()) << it.key();
    }
  }
  // Non-default values in every section survive too.
  RenderOptions o = WithModel(ImageModel::kRevised);
  o.water.type = "5C";
  o.revised.range_dependent = true;
  o.revised.b_rgb = {-0.1, -0.2, -0.3};
  o.light.lights.push_back(LightOptions{});
  o.light.lights[1].axis_in_camera = {0.1, 0.0, 1.0};
  o.light.incidence = IncidenceModel::kPaperEq5;
  o.psf.depth_levels = 9;
  o.snow.enabled = false;
  o.sensor.read_noise = 0.02;
  o.camera.bit_depth = 16;
  o.camera.encoding = CameraEncoding::kLinear;
  o.seed = 18446744073709551615u;
  const json j = RenderOptionsToJson(o);
  EXPECT_EQ(RenderOptionsToJson(RenderOptionsFromJson(j)), j);
  EXPECT_EQ(j["seed"].get<uint64_t>(), o.seed);
}

TEST(RenderOptions, TablesListEveryKeyTheJsonHas) {
  const json all = RenderOptionsToJson(WithModel(ImageModel::kRevised));
  const json uwcnn = RenderOptionsToJson(WithModel(ImageModel::kUwcnn));
  for (const RenderSection& section : RenderSections()) {
    json written = section.name.empty()               ? all
                   : section.name == "light.lights[]" ? all["light"]["lights"][0]
                   : section.name == "uwcnn"          ? uwcnn["uwcnn"]
                                             : all[json::json_pointer("/" + Slashed(section.name))];
    if (section.name.empty()) written["uwcnn"] = uwcnn["uwcnn"];
    std::vector<std::string> keys;
    for (const FieldInfo& f : section.fields) keys.push_back(f.key);
    std::vector<std::string> json_keys;
    for (auto it = written.begin(); it != written.end(); ++it) json_keys.push_back(it.key());
    std::sort(keys.begin(), keys.end());
    EXPECT_EQ(keys, json_keys) << "section '" << section.name << "'";
  }
}

TEST(RenderOptions, EveryListedKeyIsAcceptedAndAnUnknownOneRefused) {
  ASSERT_GE(RenderSections().size(), 10u);
  for (const RenderSection& section : RenderSections()) {
    json defaults = json::object();
    for (const FieldInfo& f : section.fields) {
      EXPECT_FALSE(f.doc.empty()) << Dotted(section.name, f.key);
      EXPECT_NO_THROW(RenderOptionsFromJson(Wrap(section.name, {{f.key, f.default_value}})))
          << Dotted(section.name, f.key);
      defaults[f.key] = f.default_value;
    }
    EXPECT_NO_THROW(RenderOptionsFromJson(Wrap(section.name, defaults))) << section.name;
    const std::string unknown = ErrorOf(Wrap(section.name, {{"no_such_key", 1}}));
    EXPECT_EQ(unknown.rfind("render options: unknown key '" + Dotted(section.name, "no_such_key") +
                                "' (known: ",
                            0),
              0u)
        << unknown;
  }
}

TEST(RenderOptions, WrongTypesNameTheDottedKey) {
  EXPECT_EQ(ErrorOf({{"psf", {{"max_radius_px", 2.5}}}}),
            "render options: 'psf.max_radius_px': expected an integer, got 2.5");
  EXPECT_EQ(ErrorOf({{"psf", {{"max_radius_px", 10000000000}}}}),
            "render options: 'psf.max_radius_px': must be in [-2147483648, 2147483647], got "
            "10000000000");
  EXPECT_EQ(ErrorOf({{"water", {{"ambient_rgb", {1, "x", 3}}}}}),
            "render options: 'water.ambient_rgb': [1]: expected a number, got \"x\"");
  EXPECT_EQ(ErrorOf({{"light", {{"lights", {{{"power", true}}}}}}}),
            "render options: 'light.lights[0].power': expected a number, got true");
  EXPECT_EQ(ErrorOf({{"light", {{"lights", 3}}}}),
            "render options: 'light.lights': expected an array of light objects, got 3");
  EXPECT_EQ(ErrorOf({{"snow", nullptr}}), "render options: 'snow' must be a JSON object, got null");
  EXPECT_EQ(ErrorOf({{"camera", {{"encoding", "gamma"}}}}),
            "render options: 'camera.encoding': expected one of srgb, linear, got \"gamma\"");
  EXPECT_EQ(ErrorOf({{"model", "fog"}}),
            "render options: 'model': expected one of paper, revised, uwcnn, got \"fog\"");
  EXPECT_EQ(ErrorOf({{"seed", 1.5}}),
            "render options: 'seed': must be an integer in [0, 18446744073709551615], got 1.5");
  // Value checks (the sections' Check) keep their wording.
  EXPECT_EQ(ErrorOf({{"camera", {{"bit_depth", 12}}}}),
            "render options: camera.bit_depth: must be 8, 16 or 32 (float)");
  EXPECT_EQ(ErrorOf(nullptr), "render options: the top level must be a JSON object, got null");
}

}  // namespace
}  // namespace turbid
