#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "enhancer/baselines/clahe.h"
#include "enhancer/baselines/common.h"
#include "enhancer/blocks/clahe.h"
#include "core/error.h"

namespace turbid {
namespace {

TEST(BaselinesClahe, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(ClaheBaselineOptions{}.Check(&why)) << why;
  ClaheBaselineOptions bad;
  bad.clip_limit = 2.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("clip_limit"), std::string::npos);
  EXPECT_THROW(ClaheBaseline(bad, cv::Mat(8, 8, CV_32FC1, cv::Scalar(0.5))), Error);
}

cv::Mat LowContrastRamp(int rows, int cols) {
  cv::Mat gray(rows, cols, CV_32FC1);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      gray.at<float>(y, x) = 0.4f + 0.2f * static_cast<float>(x + y) / (rows + cols);
    }
  }
  return gray;
}

// Gray input is exactly adapthisteq-style CLAHE with the uniform target (enhancer/blocks/clahe.h).
TEST(BaselinesClahe, GrayEqualsUniformClahe) {
  const cv::Mat gray = LowContrastRamp(40, 48);
  const ClaheBaselineOptions options;
  ClaheOptions reference;
  reference.distribution = ClaheDistribution::kUniform;
  const cv::Mat expected = Clahe(reference, gray);
  EXPECT_LT(cv::norm(ClaheBaseline(options, gray), expected, cv::NORM_INF), 1e-6);
  // And it stretches the low-contrast ramp (input range about 0.2).
  double in_lo, in_hi, lo, hi;
  cv::minMaxLoc(gray, &in_lo, &in_hi);
  cv::minMaxLoc(ClaheBaseline(options, gray), &lo, &hi);
  EXPECT_GT(hi - lo, 1.5 * (in_hi - in_lo));
}

// Colour: luminance is equalised and the channels scale by one ratio, so the chromaticity
// (channel ratios) is kept wherever nothing clips.
TEST(BaselinesClahe, ColourKeepsChannelRatios) {
  const cv::Mat gray = LowContrastRamp(40, 48);
  cv::Mat color;
  cv::merge(std::vector<cv::Mat>{gray * 0.9, gray * 0.6, gray * 0.3}, color);
  const cv::Mat out = ClaheBaseline(ClaheBaselineOptions{}, color);
  int checked = 0;
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      const cv::Vec3f p = out.at<cv::Vec3f>(y, x);
      if (p[0] >= 1.0f || p[0] <= 1e-4f) continue;
      ASSERT_NEAR(p[1] / p[0], 0.6 / 0.9, 1e-4);
      ASSERT_NEAR(p[2] / p[0], 0.3 / 0.9, 1e-4);
      ++checked;
    }
  }
  EXPECT_GT(checked, out.rows * out.cols / 2);
  // The luminance of the result is the equalised luminance (where nothing clipped).
  ClaheOptions reference;
  reference.distribution = ClaheDistribution::kUniform;
  const cv::Mat expected = Clahe(reference, baselines_internal::Luminance(color));
  EXPECT_NEAR(baselines_internal::Luminance(out).at<float>(20, 24), expected.at<float>(20, 24),
              1e-5);
}

}  // namespace
}  // namespace turbid

namespace turbid {
namespace {

// The luminance (its own loop where it reproduces OpenCV on this CPU) equals cv::transform's, in
// B, G, R and R, G, B order, on odd sizes and values beyond [0, 1].
TEST(BaselinesClahe, LuminanceEqualsOpenCvTransformInBothOrders) {
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(7, 3), cv::Size(641, 97), cv::Size(1360, 9)}) {
    cv::Mat bgr(size, CV_32FC3);
    cv::RNG rng(size.width * 31 + size.height);
    rng.fill(bgr, cv::RNG::UNIFORM, -0.5, 2.0);
    bgr.at<cv::Vec3f>(0, 0) = cv::Vec3f(0.0f, 1.0f, 1e-40f);
    cv::Mat expected, rgb;
    cv::transform(bgr, expected, cv::Matx13f(0.0722f, 0.7152f, 0.2126f));
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    EXPECT_EQ(cv::norm(baselines_internal::Luminance(bgr), expected, cv::NORM_INF), 0.0) << size;
    EXPECT_EQ(cv::norm(baselines_internal::Luminance(rgb, true), expected, cv::NORM_INF), 0.0)
        << size;
  }
}

}  // namespace
}  // namespace turbid
