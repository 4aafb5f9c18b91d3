#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

#include "enhancer/baselines.h"
#include "enhancer/baselines_common.h"
#include "scenes/builtin.h"
#include "scenes/error.h"
#include "tests/enhancer/baselines_test_images.h"

namespace turbid {
namespace {

cv::Mat RandomImage(int rows, int cols, int channels, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  cv::Mat image(rows, cols, CV_32FC(channels));
  float* p = image.ptr<float>();
  for (size_t i = 0; i < image.total() * channels; ++i) p[i] = u(rng);
  return image;
}

TEST(BaselinesFusion, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(FusionOptions{}.Check(&why)) << why;
  FusionOptions bad;
  bad.levels = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("levels"), std::string::npos);
  bad = FusionOptions{};
  bad.clahe.tiles_x = 1;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("clahe"), std::string::npos);
  EXPECT_THROW(Fusion(bad, cv::Mat(3, 3, CV_32FC3, cv::Scalar::all(0.5))), Error);
}

// Known answer: when every input is the same image, any weights summing to 1 give it back (the
// Laplacian pyramid collapses exactly), whatever the number of levels.
TEST(BaselinesFusion, BlendOfAgreeingInputsIsTheInput) {
  for (int channels : {1, 3}) {
    const cv::Mat image = RandomImage(37, 50, channels, 11);
    const cv::Mat w0 = RandomImage(37, 50, 1, 12);
    const cv::Mat w1 = 1.0 - w0;
    for (int levels : {1, 3, 5, 12}) {
      const cv::Mat out = PyramidBlend({image, image}, {w0, w1}, levels);
      EXPECT_LT(cv::norm(out, image, cv::NORM_INF), 1e-5) << channels << " " << levels;
    }
  }
}

// One level is a plain per-pixel weighted sum (closed form).
TEST(BaselinesFusion, SingleLevelIsWeightedSum) {
  const cv::Mat a = RandomImage(9, 7, 3, 1);
  const cv::Mat b = RandomImage(9, 7, 3, 2);
  const cv::Mat w = RandomImage(9, 7, 1, 3);
  const cv::Mat out = PyramidBlend({a, b}, {w, 1.0 - w}, 1);
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 7; ++x) {
      const float wv = w.at<float>(y, x);
      const cv::Vec3f expected = a.at<cv::Vec3f>(y, x) * wv + b.at<cv::Vec3f>(y, x) * (1 - wv);
      const cv::Vec3f d = out.at<cv::Vec3f>(y, x) - expected;
      ASSERT_LT(std::sqrt(d.dot(d)), 1e-6);
    }
  }
}

TEST(BaselinesFusion, WeightsSumToOneAndInputsAreDerived) {
  BuiltinSceneOptions scene_options;
  scene_options.scale = 0.25;
  const cv::Mat clean = MakeBuiltinScene("seafloor", scene_options).image;
  const cv::Mat hazy = clean * 0.5 + cv::Scalar(0.35, 0.3, 0.05);  // blue-green cast
  const FusionResult result = FusionDetailed(FusionOptions{}, hazy);
  ASSERT_EQ(result.inputs.size(), 2u);
  ASSERT_EQ(result.weights.size(), 2u);
  const cv::Mat sum = result.weights[0] + result.weights[1];
  EXPECT_LT(cv::norm(sum, cv::Mat(sum.size(), CV_32FC1, cv::Scalar(1.0)), cv::NORM_INF), 1e-5);
  double lo, hi;
  cv::minMaxLoc(result.weights[0], &lo, &hi);
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 1.0);
  // Gray-world balance equalises the channel means of input 1 (no gain hit the cap here).
  const cv::Scalar means = cv::mean(result.inputs[0]);
  EXPECT_NEAR(means[0], means[2], 0.02);
  EXPECT_NEAR(means[1], means[2], 0.02);
  // Input 2 has more contrast than input 1.
  cv::Scalar m0, s0, m1, s1;
  cv::meanStdDev(baselines_internal::Luminance(result.inputs[0]), m0, s0);
  cv::meanStdDev(baselines_internal::Luminance(result.inputs[1]), m1, s1);
  EXPECT_GT(s1[0], s0[0]);
}

// The weight terms on a flat image: no contrast, no saliency, exposedness only.
TEST(BaselinesFusion, WeightOfFlatImageIsExposedness) {
  const cv::Mat flat(6, 6, CV_32FC1, cv::Scalar(0.75));
  const cv::Mat w = FusionWeight(flat, 0.25);
  const double expected = std::exp(-(0.25 * 0.25) / (2 * 0.25 * 0.25));
  EXPECT_LT(cv::norm(w, cv::Mat(6, 6, CV_32FC1, cv::Scalar(expected)), cv::NORM_INF), 1e-6);
}

}  // namespace
}  // namespace turbid
