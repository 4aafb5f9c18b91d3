// Property tests (issue 17): for seeded random valid render parameters and scenes (synthetic
// planes of awkward sizes, built-in scenes at small scales) the output is finite, in range, and the
// same bytes whatever the thread count.
#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>

#include <cmath>
#include <random>
#include <string>

#include "scenes/builtin.h"
#include "scenes/camera_encoding.h"
#include "simulator/render.h"
#include "tests/simulator/test_scenes.h"
#include "tests/support/random_render.h"

namespace turbid {
namespace {

class RenderProperty : public ::testing::TestWithParam<int> {};

Scene RandomScene(std::mt19937_64& rng, std::string* what) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (rng() % 3 == 0) {
    const std::vector<std::string> names = BuiltinSceneNames();
    const std::string name = names[rng() % names.size()];
    const double scale = 0.02 + 0.04 * unit(rng);
    *what = "builtin:" + name + " scale " + std::to_string(scale);
    return MakeBuiltinScene(name, {.scale = scale});
  }
  static const int kSides[] = {1, 2, 3, 7, 16, 31, 45};
  const int width = kSides[rng() % 7], height = kSides[rng() % 7];
  const int channels = rng() % 2 == 0 ? 1 : 3;
  const double depth = 0.2 + 8.0 * unit(rng);
  const double focal = 20.0 + 400.0 * unit(rng);
  *what = "plane " + std::to_string(width) + "x" + std::to_string(height) + "x" +
          std::to_string(channels) + " at " + std::to_string(depth) + " m";
  return testing::MakePlaneScene(width, height, depth, channels, focal);
}

void ExpectFiniteInRange(const cv::Mat& m, double lo, double hi, const std::string& what) {
  ASSERT_FALSE(m.empty()) << what;
  ASSERT_TRUE(cv::checkRange(m, true)) << what << ": non-finite values";
  double min_value, max_value;
  cv::minMaxLoc(m.reshape(1), &min_value, &max_value);
  EXPECT_GE(min_value, lo) << what;
  EXPECT_LE(max_value, hi) << what;
}

TEST_P(RenderProperty, FiniteInRangeAndThreadCountIndependent) {
  std::mt19937_64 rng(static_cast<uint64_t>(GetParam()) * 7919 + 17);
  std::string what;
  const Scene scene = RandomScene(rng, &what);
  const nlohmann::json params = testing::RandomRenderParams(rng);
  SCOPED_TRACE(what + " " + params.dump());
  RenderOptions options = RenderOptionsFromJson(params);
  options.maps = MapSelection::FromList("transmission,light,veil,noise");
  const Renderer renderer(scene);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const RenderResult one = renderer.Render(options);
  cv::setNumThreads(4);
  const RenderResult four = renderer.Render(options);
  cv::setNumThreads(threads);

  ASSERT_EQ(one.image.size(), scene.image.size());
  ASSERT_EQ(one.image.channels(), scene.image.channels());
  ExpectFiniteInRange(one.image, 0.0, 1.0, "image");
  ASSERT_TRUE(cv::checkRange(one.lit, true)) << "lit: non-finite values";
  ExpectFiniteInRange(one.transmission, 0.0, 1.0, "transmission");
  ASSERT_TRUE(cv::checkRange(one.light, true)) << "light: non-finite values";
  ASSERT_TRUE(cv::checkRange(one.veil, true)) << "veil: non-finite values";
  if (options.camera.bit_depth != 32) {
    // Quantised: every value is the decoded value of an integer code of the camera's encoding
    // (sRGB by default, scenes/camera_encoding.h), so quantising it again changes nothing.
    const cv::Mat again =
        QuantiseEncoded(one.image, options.camera.encoding, options.camera.bit_depth);
    EXPECT_EQ(cv::norm(again, one.image, cv::NORM_INF), 0.0);
  }
  EXPECT_EQ(cv::norm(one.image, four.image, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(one.lit, four.lit, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(one.noise, four.noise, cv::NORM_INF), 0.0);
}

INSTANTIATE_TEST_SUITE_P(Seeds, RenderProperty, ::testing::Range(0, 24));

}  // namespace
}  // namespace turbid
