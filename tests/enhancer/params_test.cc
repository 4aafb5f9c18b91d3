// enhancer/params.h: a method's parameters read and listed through its one field table.
#include "enhancer/params.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

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

// docs/method-parameters.md is generated from the methods' field tables (the listing `turbid
// enhance --list` prints): this test fails when it is stale and rewrites it when
// TURBID_UPDATE_DOCS=1 is set.
std::string ParameterDocs() {
  std::ostringstream out;
  out << "# Method parameters\n\n"
      << "Generated from each method's field table (`enhancer/params.h`, `core/fields.h`) by\n"
      << "`tests/enhancer/params_test.cc` (`TURBID_UPDATE_DOCS=1 ctest -R "
         "MethodParams.DocsTableIsCurrent`\nrewrites it); the same rows as `turbid enhance "
         "--list` and `turbid.methods()`. Sizes marked\n*window*, *radius* or *per axis* are "
         "bounded by the image ([methods.md](methods.md)).\n";
  for (const MethodInfo& m : ListMethods()) {
    out << "\n## `" << m.name << "`\n\n" << m.summary << ".\n\n";
    if (m.params.empty()) {
      out << "No parameters.\n";
      continue;
    }
    out << "| parameter | default | meaning |\n|---|---|---|\n";
    for (const MethodParam& p : m.params) {
      const char* bound = p.bound == SizeBound::kWindow    ? " *(window)*"
                          : p.bound == SizeBound::kRadius  ? " *(radius)*"
                          : p.bound == SizeBound::kPerAxis ? " *(per axis)*"
                                                           : "";
      std::string doc = p.doc;
      for (size_t at = doc.find('|'); at != std::string::npos; at = doc.find('|', at + 2))
        doc.replace(at, 1, "\\|");
      out << "| `" << p.name << "` | `" << p.default_value.dump() << "` | " << doc << bound
          << " |\n";
    }
  }
  return out.str();
}

TEST(MethodParams, DocsTableIsCurrent) {
  const std::filesystem::path path =
      std::filesystem::path(__FILE__).parent_path().parent_path().parent_path() / "docs" /
      "method-parameters.md";
  const std::string expected = ParameterDocs();
  const char* update = std::getenv("TURBID_UPDATE_DOCS");
  if (update != nullptr && std::string(update) == "1") {
    std::ofstream(path, std::ios::binary) << expected;
  }
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), expected) << path
                                  << " is stale: rerun with TURBID_UPDATE_DOCS=1 to regenerate it";
}

}  // namespace
}  // namespace turbid
