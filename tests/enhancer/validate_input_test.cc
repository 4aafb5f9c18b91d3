// ValidateEnhanceImage's finiteness check (an integer test on the exponent bits) against
// std::isfinite: every non-finite value is caught wherever it sits, extreme finite values pass,
// and a view only looks at its own pixels.
#include <gtest/gtest.h>

#include <cfloat>
#include <limits>

#include "enhancer/method.h"
#include "core/error.h"

namespace turbid {
namespace {

TEST(ValidateEnhanceImage, FiniteExtremesPass) {
  cv::Mat image(5, 37, CV_32FC3, cv::Scalar::all(0.5));
  image.at<cv::Vec3f>(0, 0) = {FLT_MAX, -FLT_MAX, FLT_MIN};
  image.at<cv::Vec3f>(4, 36) = {std::numeric_limits<float>::denorm_min(), -0.0f, 0.0f};
  EXPECT_NO_THROW(ValidateEnhanceImage(image, "m"));
}

TEST(ValidateEnhanceImage, EveryNonFiniteValueIsCaughtWhereverItIs) {
  const float bad[] = {
      std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::signaling_NaN(),
      std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()};
  for (float value : bad)
    for (int channels : {1, 3})
      for (cv::Point at : {cv::Point(0, 0), cv::Point(36, 0), cv::Point(17, 2), cv::Point(36, 4)})
        for (int c = 0; c < channels; ++c) {
          cv::Mat image(5, 37, CV_32FC(channels), cv::Scalar::all(0.25));
          image.ptr<float>(at.y)[at.x * channels + c] = value;
          try {
            ValidateEnhanceImage(image, "m");
            ADD_FAILURE() << value << " at " << at << " channel " << c << " passed";
          } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("m: input image has non-finite values (row " +
                                                 std::to_string(at.y) + ")"),
                      std::string::npos)
                << e.what();
          }
        }
}

TEST(ValidateEnhanceImage, ViewsCheckOnlyTheirPixels) {
  cv::Mat image(10, 40, CV_32FC1, cv::Scalar(0.5));
  image.at<float>(1, 1) = std::numeric_limits<float>::quiet_NaN();  // outside the view
  const cv::Mat view = image(cv::Rect(5, 3, 20, 5));
  ASSERT_FALSE(view.isContinuous());
  EXPECT_NO_THROW(ValidateEnhanceImage(view, "m"));
  image.at<float>(7, 24) = std::numeric_limits<float>::infinity();  // last pixel of the view
  EXPECT_THROW(ValidateEnhanceImage(view, "m"), Error);
}

}  // namespace
}  // namespace turbid
