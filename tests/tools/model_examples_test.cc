// The generate example configs (scenes/experiments/examples/, one per image-formation model) parse,
// expand to the items they promise and render with the model they name.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <nlohmann/json.hpp>

#include "scenes/builtin.h"
#include "simulator/render.h"
#include "tools/harness/generate.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;

nlohmann::json ReadExample(const std::string& name) {
  // CMake compiles with absolute paths: the repository root is three levels above this file.
  const fs::path path = fs::path(__FILE__).parent_path().parent_path().parent_path() /
                        "scenes/experiments/examples" / name;
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  return nlohmann::json::parse(in);
}

TEST(ModelExamples, EachConfigExpandsAndRendersItsModel) {
  struct Case {
    const char* file;
    const char* model;
    size_t items;
  };
  BuiltinSceneOptions small;
  small.scale = 0.05;
  const Scene scene = MakeBuiltinScene("room", small);
  for (const Case& c : {Case{"paper.json", "paper", 3 * 3 * 2}, Case{"revised.json", "revised", 3 * 2 * 2},
                        Case{"uwcnn.json", "uwcnn", 2 * 10 * 2},
                        Case{"uwcnn_constant_b.json", "uwcnn", 2 * 10 * 1}}) {
    const GenerateConfig config = ParseGenerateConfig(ReadExample(c.file), c.file);
    std::vector<std::string> names;
    for (size_t i = 0; i < config.scene_specs.size(); ++i) names.push_back("s" + std::to_string(i));
    const std::vector<GenerateItem> items = ExpandGenerateItems(config, names);
    ASSERT_EQ(items.size(), c.items) << c.file;
    for (const GenerateItem& item : items) ASSERT_EQ(item.params["model"], c.model) << c.file;
    const RenderResult r = Render(RenderOptionsFromJson(items.back().params), scene);
    EXPECT_EQ(r.sidecar.ToJson()["derived"]["model"], c.model) << c.file;
    EXPECT_EQ(r.sidecar.ToJson()["encoding"], "srgb") << c.file;
  }
  // The UWCNN example draws every Jerlov type and distances within the recipe's range.
  const GenerateConfig uwcnn = ParseGenerateConfig(ReadExample("uwcnn.json"), "uwcnn.json");
  const auto items = ExpandGenerateItems(uwcnn, {"a", "b"});
  std::set<std::string> types;
  for (const GenerateItem& item : items) {
    types.insert(item.params["uwcnn"]["type"].get<std::string>());
    const double d = item.params["uwcnn"]["max_distance_m"].get<double>();
    EXPECT_GE(d, 0.5);
    EXPECT_LE(d, 15.0);
    const double b = item.params["uwcnn"]["backlight_exponent"].get<double>();
    EXPECT_GE(b, 3.0);
    EXPECT_LE(b, 5.0);
  }
  EXPECT_EQ(types.size(), 10u);
}

}  // namespace
}  // namespace turbid
