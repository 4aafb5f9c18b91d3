#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

#include "enhancer/baselines.h"
#include "scenes/builtin.h"
#include "scenes/error.h"

namespace turbid {
namespace {

TEST(BaselinesTarel, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(TarelOptions{}.Check(&why)) << why;
  TarelOptions bad;
  bad.p = 1.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("p must"), std::string::npos);
  bad = TarelOptions{};
  bad.sv = 10;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(Tarel(bad, cv::Mat(3, 3, CV_32FC1, cv::Scalar(0.5))), Error);
}

void ExpectBruteForceMedian(const cv::Mat& image, int size) {
  const cv::Mat median = MedianFilter(image, size);
  const int half = size / 2;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      std::vector<float> window;
      for (int dy = -half; dy <= half; ++dy) {
        for (int dx = -half; dx <= half; ++dx) {
          window.push_back(
              image.at<float>(cv::borderInterpolate(y + dy, image.rows, cv::BORDER_REFLECT),
                              cv::borderInterpolate(x + dx, image.cols, cv::BORDER_REFLECT)));
        }
      }
      std::sort(window.begin(), window.end());
      ASSERT_EQ(median.at<float>(y, x), window[window.size() / 2]) << size << " " << y << "," << x;
    }
  }
}

TEST(BaselinesTarel, MedianFilterMatchesBruteForceWithReflectBorder) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  cv::Mat image(29, 37, CV_32FC1);
  for (auto it = image.begin<float>(); it != image.end<float>(); ++it) *it = u(rng);
  ExpectBruteForceMedian(image, 5);
  ExpectBruteForceMedian(image, 11);
  ExpectBruteForceMedian(image(cv::Rect(0, 0, 3, 2)).clone(), 11);  // window larger than image
  // Values packed in a narrow range with many ties (8-bit levels) and one outlier far away,
  // so most of the window shares a coarse bin.
  for (auto it = image.begin<float>(); it != image.end<float>(); ++it) {
    *it = 0.5f + std::round(*it * 6.0f) / 255.0f;
  }
  image.at<float>(3, 4) = -7.0f;
  ExpectBruteForceMedian(image, 11);
  ExpectBruteForceMedian(cv::Mat(5, 5, CV_32FC1, cv::Scalar(0.25)), 3);
}

// Known answer: a constant veil V over a scene that is black on most pixels (Koschmieder with a
// white sky, I = J (1 - V) + V). Every 11x11 window is mostly V, so med(W) = V, the median
// deviation is 0 and the inferred veil is exactly p V; the restoration is (I - pV) / (1 - pV).
TEST(BaselinesTarel, RecoversConstantVeil) {
  const float veil = 0.4f;
  for (int channels : {1, 3}) {
    cv::Mat clean(30, 33, CV_32FC(channels), cv::Scalar::all(0.0));
    for (int y = 0; y < clean.rows; y += 3) {
      for (int x = 0; x < clean.cols; x += 3) {
        for (int c = 0; c < channels; ++c) {
          clean.ptr<float>(y)[x * channels + c] = 0.3f + 0.2f * c + 0.01f * ((x + y) % 7);
        }
      }
    }
    const cv::Mat hazy = clean * (1.0 - veil) + cv::Scalar::all(veil);
    TarelOptions options;
    options.balance = -1.0;  // the veil is white already
    options.p = 0.99;
    const TarelResult result = TarelDetailed(options, hazy);
    for (int y = 0; y < hazy.rows; ++y) {
      for (int x = 0; x < hazy.cols; ++x) {
        ASSERT_NEAR(result.veil.at<float>(y, x), options.p * veil, 1e-6);
        for (int c = 0; c < channels; ++c) {
          const double i = hazy.ptr<float>(y)[x * channels + c];
          const double expected = (i - options.p * veil) / (1.0 - options.p * veil);
          ASSERT_NEAR(result.restored.ptr<float>(y)[x * channels + c], expected, 1e-5);
          // and close to the clean scene, off by the 1 % of the veil p leaves
          ASSERT_NEAR(result.restored.ptr<float>(y)[x * channels + c],
                      clean.ptr<float>(y)[x * channels + c], 0.01);
        }
      }
    }
  }
}

// The veil never exceeds the whiteness (Tarel 2009 constraint 0 <= V <= W), on a real-looking
// colour scene with each white-balance mode.
TEST(BaselinesTarel, VeilBelowMinimumChannel) {
  BuiltinSceneOptions scene_options;
  scene_options.scale = 0.25;
  const Scene scene = MakeBuiltinScene("seafloor", scene_options);
  cv::Mat hazy = scene.image * 0.6 + cv::Scalar(0.3, 0.25, 0.05);
  for (double balance : {-1.0, 0.0, 0.5}) {
    TarelOptions options;
    options.balance = balance;
    const TarelResult result = TarelDetailed(options, hazy);
    EXPECT_EQ(cv::countNonZero(result.veil > result.whiteness), 0) << balance;
    EXPECT_EQ(cv::countNonZero(result.veil < 0.0f), 0) << balance;
    std::vector<cv::Mat> planes;
    cv::split(result.balanced, planes);
    const cv::Mat w = cv::min(cv::min(planes[0], planes[1]), planes[2]);
    EXPECT_EQ(cv::norm(w, result.whiteness, cv::NORM_INF), 0.0);
    double lo, hi;
    cv::minMaxLoc(result.image.reshape(1), &lo, &hi);
    EXPECT_GE(lo, 0.0);
    EXPECT_LE(hi, 1.0);
  }
}

// Global white balance maps the mean colour of the whitest 1 % to gray.
TEST(BaselinesTarel, GlobalWhiteBalanceNeutralisesTint) {
  cv::Mat image(20, 20, CV_32FC3, cv::Scalar(0.2, 0.2, 0.1));
  image(cv::Rect(0, 0, 4, 4)).setTo(cv::Scalar(0.9, 0.8, 0.6));  // the whitest patch, tinted
  TarelOptions options;
  const TarelResult result = TarelDetailed(options, image);
  EXPECT_NEAR(result.white[0], 1.0f, 1e-6);
  EXPECT_NEAR(result.white[1], 0.8f / 0.9f, 1e-6);
  EXPECT_NEAR(result.white[2], 0.6f / 0.9f, 1e-6);
  const cv::Vec3f balanced = result.balanced.at<cv::Vec3f>(1, 1);
  EXPECT_NEAR(balanced[0], balanced[1], 1e-6);
  EXPECT_NEAR(balanced[0], balanced[2], 1e-6);
}

}  // namespace
}  // namespace turbid
