// RenderRecord: the typed record a render leaves; its ToJson is the sidecar and FromJson reads it
// back strictly (unknown keys, wrong types) while accepting what older sidecars left out.
#include "simulator/render_record.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "scenes/builtin.h"
#include "simulator/render.h"

namespace turbid {
namespace {

using nlohmann::json;

std::string ErrorOf(const json& j) {
  try {
    RenderRecord::FromJson(j, "s.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(RenderRecord, SidecarReadsBackToTheSameJson) {
  const Scene scene = MakeBuiltinScene("seafloor", {0.05});
  for (const char* params : {R"({})", R"({"water": {"type": "C3", "backscatter": true}})",
                             R"({"model": "uwcnn", "uwcnn": {"type": "5C"}})",
                             R"({"model": "revised", "revised": {"range_dependent": true}})",
                             R"({"psf": {"turbidity_dependent": true}})"}) {
    RenderRecord record = Render(RenderOptionsFromJson(json::parse(params)), scene).sidecar;
    record.scene.spec = "builtin:seafloor";
    record.scene.builtin_scale = 0.05;
    record.outputs = {{"image", "x.png"}};
    record.psf_peak = 0.5;
    record.item = RenderRecord::Item{3, "seafloor_000003"};
    const json written = record.ToJson();
    EXPECT_EQ(RenderRecord::FromJson(written, "s.json").ToJson(), written) << params;
    EXPECT_EQ(written["options"]["seed"], 0) << params;
  }
}

TEST(RenderRecord, MissingKeysKeepDefaults) {
  // An older sidecar: no model, encoding, turbidity or spec.
  const RenderRecord r = RenderRecord::FromJson(json::parse(R"({"tool": "turbid render", "seed": 4,
                      "scene": {"name": "x", "width": 4, "height": 3, "channels": 1,
                                "camera": {"fx": 5, "fy": 5, "cx": 1.5, "cy": 1}},
                      "derived": {"range_m": {"min": null, "max": 0}, "beta_b_per_m": null}})"),
                                                "old.json");
  EXPECT_EQ(r.seed, 4u);
  EXPECT_FALSE(r.options.has_value());
  EXPECT_FALSE(r.scene.spec.has_value());
  EXPECT_EQ(r.scene.fx, 5.0);
  EXPECT_TRUE(std::isinf(r.derived.range_min_m));
  EXPECT_FALSE(r.derived.beta_b_per_m.has_value());
  EXPECT_EQ(r.encoding, "");
  EXPECT_NO_THROW(RenderRecord::FromJson(json::object(), "empty.json"));
}

TEST(RenderRecord, UnknownKeysAndWrongTypesAreOneLineErrors) {
  // Read through the field tables (core/fields.h): the key's whole path, the known keys.
  EXPECT_EQ(ErrorOf({{"bogus", 1}}).rfind("s.json: sidecar: unknown key 'bogus' (known: tool, ", 0),
            0u);
  EXPECT_EQ(ErrorOf({{"scene", {{"camera", {{"fz", 1}}}}}}),
            "s.json: sidecar: unknown key 'scene.camera.fz' (known: fx, fy, cx, cy)");
  EXPECT_EQ(ErrorOf({{"scene", {{"width", "4"}}}}),
            "s.json: sidecar: 'scene.width': expected an integer, got \"4\"");
  EXPECT_EQ(ErrorOf({{"scene", {{"width", -1}}}}),
            "s.json: sidecar: 'scene.width': must be >= 0, got -1");
  EXPECT_EQ(ErrorOf({{"derived", {{"psf", {{"is_delta", 1}}}}}}),
            "s.json: sidecar: 'derived.psf.is_delta': expected true or false, got 1");
  EXPECT_EQ(ErrorOf({{"derived", {{"psf", {{"turbidity", {{"levels", 2}, {"x", 1}}}}}}}})
                .rfind("s.json: sidecar: unknown key 'derived.psf.turbidity.x'", 0),
            0u);
  EXPECT_EQ(ErrorOf({{"derived", {{"range_m", {{"min", "near"}}}}}}),
            "s.json: sidecar: 'derived.range_m.min': expected a number, got \"near\"");
  EXPECT_EQ(ErrorOf({{"outputs", {{"image", 3}}}}),
            "s.json: sidecar: 'outputs': 'image' expected a string, got 3");
  EXPECT_EQ(ErrorOf(json::array()),
            "s.json: sidecar: the top level must be a JSON object, got []");
  const std::string options = ErrorOf({{"options", {{"psf", {{"forward_scatter", 5.0}}}}}});
  EXPECT_EQ(options.rfind("s.json: render options: psf.forward_scatter", 0), 0u) << options;
}

}  // namespace
}  // namespace turbid
