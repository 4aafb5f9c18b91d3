// MSE / PSNR against scikit-image reference values; CNR against hand-computed regions.
#include "metrics/full_reference.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "metrics/image_checks.h"
#include "core/error.h"
#include "tests/metrics/reference_files.h"

namespace turbid {
namespace {

TEST(PsnrOptions, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(PsnrOptions{}.Check(&why)) << why;
  EXPECT_TRUE(CnrOptions{}.Check(&why)) << why;
  CnrOptions one_mask;
  one_mask.signal_mask = cv::Mat(4, 4, CV_8U, 255);
  EXPECT_FALSE(one_mask.Check(&why));
}

TEST(Psnr, MatchesScikitImageReferenceValues) {
  TURBID_REQUIRE_METRICS_REFERENCE(dir);
  std::ifstream in(dir + "/expected.json");
  const nlohmann::json expected = nlohmann::json::parse(in);
  for (const auto& c : expected.at("cases")) {
    const std::string name = c.at("image").get<std::string>();
    const cv::Mat ref = cv::imread(dir + "/" + c.at("reference").get<std::string>(),
                                   cv::IMREAD_UNCHANGED);
    const cv::Mat img = cv::imread(dir + "/" + name, cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(ref.empty() || img.empty()) << name;
    const double want_mse = c.at("mse_uint8").get<double>();
    const double mse = Mse(ref, img);
    EXPECT_LE(std::abs(mse - want_mse), 1e-9 * std::max(1.0, want_mse)) << name;
    const double psnr = Psnr({}, ref, img);
    const auto& want = c.at("psnr_uint8_range255");
    if (want.is_string()) {
      EXPECT_EQ(want.get<std::string>(), "inf");
      EXPECT_TRUE(std::isinf(psnr) && psnr > 0) << name;
    } else {
      EXPECT_LE(std::abs(psnr - want.get<double>()), 1e-9 * want.get<double>()) << name;
    }
    // Raw 8-bit values held as float with data range 255: the same numbers (the CLI's path).
    cv::Mat ref_f, img_f;
    ref.convertTo(ref_f, CV_32F);
    img.convertTo(img_f, CV_32F);
    PsnrOptions raw;
    raw.data_range = 255;
    if (!want.is_string()) {
      EXPECT_LE(std::abs(Psnr(raw, ref_f, img_f) - want.get<double>()), 1e-9 * want.get<double>());
    }
  }
}

TEST(Psnr, ClosedFormOnFloatAndSixteenBit) {
  cv::Mat a(8, 10, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  cv::Mat b = a.clone();
  b.at<cv::Vec3f>(2, 3)[1] = 0.75f;  // one sample off by 0.25 out of 240
  const double mse = 0.25 * 0.25 / 240.0;
  EXPECT_NEAR(Mse(a, b), mse, 1e-15);
  EXPECT_NEAR(Psnr({}, a, b), 10 * std::log10(1.0 / mse), 1e-9);
  cv::Mat a16(4, 4, CV_16U, cv::Scalar(1000)), b16(4, 4, CV_16U, cv::Scalar(1010));
  EXPECT_DOUBLE_EQ(Mse(a16, b16), 100.0);
  EXPECT_NEAR(Psnr({}, a16, b16), 10 * std::log10(65535.0 * 65535.0 / 100.0), 1e-9);
}

TEST(Psnr, BadInputThrows) {
  const cv::Mat a(8, 8, CV_32F, 0.5);
  EXPECT_THROW(Mse(a, cv::Mat(8, 9, CV_32F, 0.5)), Error);
  EXPECT_THROW(Mse(a, cv::Mat(8, 8, CV_32FC3, 0.5)), Error);
  EXPECT_THROW(Mse(a, cv::Mat(8, 8, CV_8U, 1)), Error);
  EXPECT_THROW(Mse(cv::Mat(), a), Error);
  cv::Mat inf = a.clone();
  inf.at<float>(1, 1) = INFINITY;
  EXPECT_THROW(Psnr({}, a, inf), Error);
}

TEST(Cnr, TwoLevelImageWithNoiseMatchesHandComputation) {
  // Left half 0.2, right half 0.8, plus +-0.05 checkerboard: both Otsu classes have std 0.05.
  cv::Mat img(20, 40, CV_32F);
  for (int i = 0; i < img.rows; ++i)
    for (int j = 0; j < img.cols; ++j)
      img.at<float>(i, j) = (j < 20 ? 0.2f : 0.8f) + (((i + j) % 2) ? 0.05f : -0.05f);
  const CnrResult r = Cnr({}, img);
  EXPECT_EQ(r.signal_pixels, 400);
  EXPECT_EQ(r.background_pixels, 400);
  EXPECT_NEAR(r.signal_mean, 0.8, 1e-6);
  EXPECT_NEAR(r.background_mean, 0.2, 1e-6);
  EXPECT_NEAR(r.cnr, 0.6 / std::sqrt(2 * 0.05 * 0.05), 1e-4);
  // Scale-free: the same image on a 0..255 scale gives the same CNR.
  cv::Mat img255 = img * 255.0;
  CnrOptions raw;
  raw.data_range = 255.0;
  EXPECT_NEAR(Cnr(raw, img255).cnr, r.cnr, 1e-6 * r.cnr);
}

TEST(Cnr, ColourUsesRec601LumaAndMasksOverrideOtsu) {
  cv::Mat img(10, 10, CV_32FC3, cv::Scalar(0.1, 0.2, 0.3));  // B, G, R
  img(cv::Rect(0, 0, 5, 10)).setTo(cv::Scalar(0.5, 0.6, 0.7));
  const double y_dark = 0.114 * 0.1 + 0.587 * 0.2 + 0.299 * 0.3;
  const double y_bright = 0.114 * 0.5 + 0.587 * 0.6 + 0.299 * 0.7;
  const CnrResult r = Cnr({}, img);
  EXPECT_NEAR(r.signal_mean, y_bright, 1e-6);
  EXPECT_NEAR(r.background_mean, y_dark, 1e-6);
  EXPECT_TRUE(std::isinf(r.cnr));  // flat regions that differ: defined as +inf
  CnrOptions masks;
  masks.signal_mask = cv::Mat(10, 10, CV_8U, cv::Scalar(0));
  masks.signal_mask(cv::Rect(0, 0, 2, 10)).setTo(255);
  masks.background_mask = cv::Mat(10, 10, CV_8U, cv::Scalar(0));
  masks.background_mask(cv::Rect(3, 0, 5, 10)).setTo(255);  // 2 bright + 3 dark columns
  const CnrResult m = Cnr(masks, img);
  const double bg_mean = (2 * y_bright + 3 * y_dark) / 5;
  const double bg_std = std::sqrt(6.0) / 5 * (y_bright - y_dark);  // two-level mixture, p = 2/5
  EXPECT_NEAR(m.cnr, std::abs(y_bright - bg_mean) / bg_std, 1e-5);
  EXPECT_EQ(m.otsu_threshold, -1);
}

TEST(Cnr, ConstantImageIsZeroAndBadInputThrows) {
  EXPECT_EQ(Cnr({}, cv::Mat(12, 12, CV_32F, cv::Scalar(0.4))).cnr, 0.0);
  EXPECT_THROW(Cnr({}, cv::Mat()), Error);
  cv::Mat nan(4, 4, CV_32F, cv::Scalar(0.1));
  nan.at<float>(0, 0) = NAN;
  EXPECT_THROW(Cnr({}, nan), Error);
  CnrOptions masks;
  masks.signal_mask = cv::Mat(3, 3, CV_8U, 255);
  masks.background_mask = cv::Mat(3, 3, CV_8U, 255);
  EXPECT_THROW(Cnr(masks, cv::Mat(4, 4, CV_32F, 0.1)), Error);
}

// The finite check names the pixel and value of the first non-finite element that cv::checkRange
// (the check it replaced) finds, in float and double, gray and colour, wide rows and narrow ones.
// checkRange reports the pixel column; the message printed before divided it by the channel count
// again (and printed another element's value) for colour images.
TEST(MetricImageCheck, NamesTheFirstNonFiniteElementAsCheckRange) {
  const float values[] = {NAN, INFINITY, -INFINITY};
  int cases = 0;
  for (int depth : {CV_32F, CV_64F}) {
    for (int channels : {1, 3}) {
      for (cv::Size size : {cv::Size(1, 1), cv::Size(37, 5), cv::Size(640, 48)}) {
        for (int k = 0; k < 3; ++k) {
          cv::Mat image(size, CV_MAKETYPE(depth, channels));
          cv::randu(image, -1e6, 1e6);
          EXPECT_NO_THROW(CheckMetricImage(image, "fine"));
          cv::Mat flat = image.reshape(1, image.rows);
          const int y = (k * 7) % size.height, x = (k * 53 + 11) % flat.cols;
          const int y2 = std::min(y + 1, size.height - 1);  // a later one that must not be named
          if (depth == CV_32F) {
            flat.at<float>(y2, flat.cols - 1) = values[(k + 1) % 3];
            flat.at<float>(y, x) = values[k];
          } else {
            flat.at<double>(y2, flat.cols - 1) = values[(k + 1) % 3];
            flat.at<double>(y, x) = values[k];
          }
          cv::Point expected;
          ASSERT_FALSE(cv::checkRange(image, true, &expected));
          std::string message;
          try {
            CheckMetricImage(image, "img");
          } catch (const Error& e) {
            message = e.what();
          }
          const std::string where =
              "at x=" + std::to_string(expected.x) + " y=" + std::to_string(expected.y);
          const std::string value = k == 0 ? "(nan)" : (k == 1 ? "(inf)" : "(-inf)");
          EXPECT_NE(message.find("non-finite pixel value " + value), std::string::npos) << message;
          EXPECT_NE(message.find(where), std::string::npos) << message << " vs " << where;
          ++cases;
        }
      }
    }
  }
  EXPECT_EQ(cases, 36);
}

}  // namespace
}  // namespace turbid

namespace turbid {
namespace {

// The Otsu path sums both regions in one pass per statistic; the mask path (given masks, the code
// of both paths before that change) is the reference: the Otsu regions passed as masks must give
// the same bits. Noisy (ragged regions), smooth colour, 8-bit, odd sizes, one region only.
TEST(Cnr, OtsuPathGivesTheSameBitsAsItsRegionsGivenAsMasks) {
  cv::RNG rng(18);
  std::vector<cv::Mat> images;
  cv::Mat noisy(97, 131, CV_32F);
  rng.fill(noisy, cv::RNG::UNIFORM, 0.0, 1.0);
  images.push_back(noisy);
  cv::Mat smooth(61, 83, CV_32FC3);
  for (int y = 0; y < smooth.rows; ++y)
    for (int x = 0; x < smooth.cols; ++x)
      smooth.at<cv::Vec3f>(y, x) = {x / 83.0f, 0.3f + y / 200.0f, 0.5f * std::sin(0.1f * (x + y)) + 0.5f};
  images.push_back(smooth);
  cv::Mat eight(40, 33, CV_8UC1);
  rng.fill(eight, cv::RNG::UNIFORM, 0, 256);
  images.push_back(eight);
  images.push_back(cv::Mat(9, 7, CV_32F, cv::Scalar(0.25)));  // one region
  cv::Mat negative(23, 17, CV_32F);
  rng.fill(negative, cv::RNG::UNIFORM, -0.5, 0.5);  // sums through zero and below
  images.push_back(negative);
  for (size_t k = 0; k < images.size(); ++k) {
    SCOPED_TRACE(k);
    const cv::Mat& image = images[k];
    const CnrResult otsu = Cnr({}, image);
    const double range = image.depth() == CV_8U ? 255.0 : 1.0;
    cv::Mat y8, above;
    Luminance(image).convertTo(y8, CV_8U, 255.0 / range);
    cv::threshold(y8, above, otsu.otsu_threshold, 255, cv::THRESH_BINARY);
    CnrOptions masks;
    masks.signal_mask = above;
    cv::bitwise_not(above, masks.background_mask);
    const CnrResult given = Cnr(masks, image);
    auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; };
    EXPECT_TRUE(same(otsu.cnr, given.cnr)) << otsu.cnr << " vs " << given.cnr;
    EXPECT_TRUE(same(otsu.signal_mean, given.signal_mean));
    EXPECT_TRUE(same(otsu.background_mean, given.background_mean));
    EXPECT_TRUE(same(otsu.signal_std, given.signal_std));
    EXPECT_TRUE(same(otsu.background_std, given.background_std));
    EXPECT_EQ(otsu.signal_pixels, given.signal_pixels);
    EXPECT_EQ(otsu.background_pixels, given.background_pixels);
  }
}

}  // namespace
}  // namespace turbid
