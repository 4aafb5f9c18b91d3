#include <gtest/gtest.h>

#include <set>

#include "enhancer/baselines/dcp.h"
#include "enhancer/baselines/registry.h"
#include "core/error.h"
#include "tests/enhancer/baselines_test_images.h"

namespace turbid {
namespace {

const MethodEntry& Entry(const std::string& name) {
  static const std::vector<MethodEntry> entries = BaselineMethodEntries();
  for (const MethodEntry& e : entries) {
    if (e.info.name == name) return e;
  }
  throw std::runtime_error("no entry " + name);
}

TEST(BaselinesRegistry, ListsTheSixBaselinesWithDocumentedParams) {
  std::set<std::string> names;
  for (const MethodEntry& e : BaselineMethodEntries()) {
    names.insert(e.info.name);
    EXPECT_FALSE(e.info.summary.empty()) << e.info.name;
    EXPECT_FALSE(e.info.source.empty()) << e.info.name;
    EXPECT_FALSE(e.info.needs_geometry);
    EXPECT_FALSE(e.info.needs_sidecar);
    EXPECT_FALSE(e.info.params.empty());
    for (const MethodParam& p : e.info.params) EXPECT_FALSE(p.doc.empty()) << p.name;
  }
  EXPECT_EQ(names, (std::set<std::string>{"clahe", "dcp", "udcp", "cap", "tarel", "fusion"}));
}

TEST(BaselinesRegistry, DefaultsComeFromTheOptionsStructs) {
  const auto find = [](const MethodEntry& e, const std::string& key) {
    for (const MethodParam& p : e.info.params) {
      if (p.name == key) return p.default_value;
    }
    return nlohmann::json();
  };
  EXPECT_EQ(find(Entry("dcp"), "omega"), DcpOptions{}.omega);
  EXPECT_EQ(find(Entry("dcp"), "patch_size"), 15);
  EXPECT_EQ(find(Entry("cap"), "theta2"), -0.780245);
  EXPECT_EQ(find(Entry("tarel"), "sv"), 11);
  EXPECT_EQ(find(Entry("fusion"), "clahe_clip_limit"), 0.01);
  EXPECT_EQ(find(Entry("clahe"), "tiles_x"), 8);
}

TEST(BaselinesRegistry, OverridesBindStrictly) {
  const cv::Mat image =
      baselines_test::DarkPriorTexture(16, 16, false) * 0.5 + cv::Scalar::all(0.3);
  EnhanceInput input;
  input.image = image;
  // An override reaches the options: matches a direct call.
  DcpOptions options;
  options.omega = 0.7;
  options.guided_radius = 4;
  const cv::Mat via_registry =
      Entry("dcp").run(nlohmann::json{{"omega", 0.7}, {"guided_radius", 4}}, input);
  EXPECT_EQ(cv::norm(via_registry, DarkChannelPrior(options, image), cv::NORM_INF), 0.0);
  // Unknown keys, wrong types and values failing Check are one-line errors naming the method.
  EXPECT_THROW(Entry("dcp").run(nlohmann::json{{"omgea", 0.7}}, input), Error);
  EXPECT_THROW(Entry("cap").run(nlohmann::json{{"beta", "one"}}, input), Error);
  EXPECT_THROW(Entry("tarel").run(nlohmann::json{{"sv", 4}}, input), Error);
  EXPECT_THROW(Entry("fusion").run(nlohmann::json{{"clahe_tiles_x", 1}}, input), Error);
  try {
    Entry("udcp").run(nlohmann::json{{"t0", 0.0}}, input);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("udcp: t0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace turbid
