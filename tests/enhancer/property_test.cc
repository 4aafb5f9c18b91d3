// Property tests (issue 17): every registered enhancement method, with default parameters, on
// seeded random images (gray and colour, 1x1 to odd sizes, constant, black/white, near 0 and 1)
// returns a finite float image of the input's size and channels within [0, 1], or throws one
// clear Error (a single non-empty line) - never a crash, NaN or a silently resized result.
// Methods that need geometry get a plane scene of the image's size; the oracles get a real render
// of that scene with random parameters as their input and sidecar.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "enhancer/registry.h"
#include "core/error.h"
#include "simulator/render.h"
#include "tests/simulator/test_scenes.h"
#include "tests/support/random_images.h"
#include "tests/support/random_render.h"

namespace turbid {
namespace {

class EnhanceProperty : public ::testing::TestWithParam<int> {};

TEST_P(EnhanceProperty, EveryMethodGivesAValidImageOrOneClearError) {
  const uint64_t seed = static_cast<uint64_t>(GetParam());
  const testing::RandomImage input = testing::MakeRandomImage(seed);
  const cv::Mat& image = input.image;
  std::mt19937_64 rng(seed + 1000);
  const Scene scene = testing::MakePlaneScene(image.cols, image.rows, 0.5 + 5.0 * (rng() % 100) / 100.0,
                                              image.channels(), 50.0 + (rng() % 400));
  nlohmann::json params = testing::RandomRenderParams(rng);
  const RenderResult render = Render(RenderOptionsFromJson(params), scene);
  int errors = 0;
  for (const MethodInfo& method : ListMethods()) {
    // The oracles invert a render whose parameters they read from its sidecar.
    const EnhanceInput in{method.needs_sidecar ? render.image : image, &scene, &render.sidecar};
    const std::string what = method.name + " on " + input.what + " (seed " + std::to_string(seed) + ")";
    cv::Mat out;
    try {
      out = Enhance(method.name, nlohmann::json::object(), in);
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_FALSE(message.empty()) << what;
      EXPECT_EQ(message.find('\n'), std::string::npos) << what << ": " << message;
      ++errors;
      continue;
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": threw a non-turbid exception: " << e.what();
      continue;
    }
    ASSERT_EQ(out.size(), image.size()) << what;
    ASSERT_EQ(out.type(), CV_32FC(image.channels())) << what;
    ASSERT_TRUE(cv::checkRange(out, true)) << what << ": non-finite output";
    double lo, hi;
    cv::minMaxLoc(out.reshape(1), &lo, &hi);
    EXPECT_GE(lo, 0.0) << what;
    EXPECT_LE(hi, 1.0 + 1e-6) << what;
  }
  // Errors are for inputs a method cannot handle, not the rule: most methods must succeed.
  EXPECT_LT(errors, static_cast<int>(ListMethods().size()) / 2) << input.what;
}

INSTANTIATE_TEST_SUITE_P(Seeds, EnhanceProperty, ::testing::Range(0, 32));

}  // namespace
}  // namespace turbid
