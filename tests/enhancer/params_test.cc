// enhancer/params.h: a method's parameters read and listed through its one field table.
#include "enhancer/params.h"

#include <gtest/gtest.h>

#include "enhancer/registry.h"
#include "scenes/builtin.h"
#include "simulator/render.h"

namespace turbid {
namespace {

using nlohmann::json;

struct ToyOptions {
  int patch_size = 15;
  double omega = 0.95;
  bool refine = true;
  bool Check(std::string* why) const {
    if (patch_size < 1 || patch_size % 2 == 0) {
      *why = "patch_size must be odd and >= 1, got " + std::to_string(patch_size);
      return false;
    }
    return true;
  }
};

const Fields<ToyOptions>& ToyFields() {
  static const Fields<ToyOptions> fields =
      Fields<ToyOptions>()
          .Integer("patch_size", &ToyOptions::patch_size, "window side, pixels, odd >= 1")
          .Tag(static_cast<int>(SizeBound::kWindow))
          .Number("omega", &ToyOptions::omega, "fraction of haze removed, (0,1]")
          .Boolean("refine", &ToyOptions::refine, "refine the transmission");
  return fields;
}

std::string ErrorOf(const json& params) {
  try {
    ReadMethodParams("toy", params, ToyFields());
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(MethodParams, ReadAppliesOverridesAndKeepsDefaults) {
  const ToyOptions o = ReadMethodParams("toy", json{{"omega", 0.5}}, ToyFields());
  EXPECT_EQ(o.omega, 0.5);
  EXPECT_EQ(o.patch_size, 15);
  EXPECT_TRUE(o.refine);
  EXPECT_EQ(ReadMethodParams("toy", json(nullptr), ToyFields()).omega, 0.95);
  ToyOptions start;
  start.patch_size = 7;
  EXPECT_EQ(ReadMethodParams("toy", json::object(), ToyFields(), start).patch_size, 7);
}

TEST(MethodParams, ErrorsNameTheMethodAndTheParameter) {
  EXPECT_EQ(ErrorOf(json{{"omega", "x"}}), "toy: parameter 'omega': expected a number, got \"x\"");
  EXPECT_EQ(ErrorOf(json{{"patch_size", 2.5}}),
            "toy: parameter 'patch_size': expected an integer, got 2.5");
  EXPECT_EQ(ErrorOf(json{{"omgea", 1}}),
            "toy: unknown parameter 'omgea' (known: patch_size, omega, refine)");
  EXPECT_EQ(ErrorOf(json{{"patch_size", 4}}), "toy: patch_size must be odd and >= 1, got 4");
  EXPECT_EQ(ErrorOf(json::array()), "toy: parameters must be a JSON object, got []");
}

TEST(MethodParams, ListedFromTheSameTable) {
  const std::vector<MethodParam> params = MethodParamsOf(ToyFields());
  ASSERT_EQ(params.size(), 3u);
  EXPECT_EQ(params[0].name, "patch_size");
  EXPECT_EQ(params[0].default_value, 15);
  EXPECT_EQ(params[0].bound, SizeBound::kWindow);
  EXPECT_EQ(params[1].bound, SizeBound::kNone);
  EXPECT_EQ(params[2].doc, "refine the transmission");
}

// Every registered method reads exactly the parameters it lists (one table drives both): naming
// each listed parameter with its listed default gives the same bytes as naming none, and a key it
// does not list is refused naming the method and the key.
TEST(MethodParams, EveryMethodReadsWhatItLists) {
  BuiltinSceneOptions so;
  so.scale = 0.08;
  const Scene scene = MakeBuiltinScene("seafloor", so);
  RenderOptions ro;
  ro.seed = 3;
  const RenderResult rendered = Render(ro, scene);
  EnhanceInput input;
  input.image = rendered.image;
  input.scene = &scene;
  input.sidecar = &rendered.sidecar;
  int methods = 0;
  for (const MethodInfo& m : ListMethods()) {
    json defaults = json::object();
    for (const MethodParam& p : m.params) defaults[p.name] = p.default_value;
    ASSERT_EQ(defaults.size(), m.params.size()) << m.name << " lists a parameter twice";
    const cv::Mat plain = Enhance(m.name, json::object(), input);
    const cv::Mat named = Enhance(m.name, defaults, input);
    ASSERT_EQ(plain.size(), named.size()) << m.name;
    EXPECT_EQ(cv::norm(plain, named, cv::NORM_INF), 0.0) << m.name;
    try {
      Enhance(m.name, json{{"zz_not_a_parameter", 1}}, input);
      ADD_FAILURE() << m.name << " accepted an unknown parameter";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(m.name + ": unknown parameter 'zz_not_a_parameter'"),
                std::string::npos)
          << e.what();
    }
    ++methods;
  }
  EXPECT_GE(methods, 12);
}

}  // namespace
}  // namespace turbid
