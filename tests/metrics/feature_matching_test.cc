// Feature matching on a synthetic textured image and a known homography warp of it.
#include "metrics/feature_matching.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace turbid {
namespace {

cv::Mat Texture(int width, int height, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat img(height, width, CV_8UC1, cv::Scalar(90));
  for (int k = 0; k < 400; ++k) {
    const cv::Point c(rng.uniform(0, width), rng.uniform(0, height));
    const int radius = rng.uniform(2, 14);
    if (k % 2)
      cv::circle(img, c, radius, cv::Scalar(rng.uniform(0, 256)), cv::FILLED, cv::LINE_AA);
    else
      cv::rectangle(img, c, c + cv::Point(radius, radius * 2 / 3),
                    cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
  }
  return img;
}

TEST(FeatureMatchOptions, DefaultsPassCheckAndNamesRoundTrip) {
  std::string why;
  EXPECT_TRUE(FeatureMatchOptions{}.Check(&why)) << why;
  for (auto d : {FeatureDetector::kOrb, FeatureDetector::kAkaze, FeatureDetector::kSift})
    EXPECT_EQ(ParseFeatureDetector(FeatureDetectorName(d)), d);
  EXPECT_THROW(ParseFeatureDetector("surf"), Error);
  FeatureMatchOptions bad;
  bad.ratio = 1.5;
  EXPECT_FALSE(bad.Check(&why));
}

TEST(FeatureMatching, WarpedCopyIsActiveWithMostlyInliersForEveryDetector) {
  const cv::Mat a = Texture(320, 240, 1);
  const cv::Mat h = (cv::Mat_<double>(3, 3) << 0.95, 0.05, 8, -0.04, 0.97, 5, 1e-5, 2e-5, 1);
  cv::Mat b;
  cv::warpPerspective(a, b, h, a.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(90));
  for (auto d : {FeatureDetector::kOrb, FeatureDetector::kAkaze, FeatureDetector::kSift}) {
    FeatureMatchOptions options;
    options.detector = d;
    const PairMatchResult r = MatchFeatures(options, a, b);
    EXPECT_TRUE(r.active) << FeatureDetectorName(d);
    EXPECT_GT(r.correspondences, 30) << FeatureDetectorName(d);
    EXPECT_GT(r.inliers, 0.7 * r.correspondences) << FeatureDetectorName(d);
    EXPECT_LE(r.inliers, r.correspondences);
    // Deterministic: the same numbers again.
    const PairMatchResult again = MatchFeatures(options, a, b);
    EXPECT_EQ(again.correspondences, r.correspondences);
    EXPECT_EQ(again.inliers, r.inliers);
  }
}

TEST(FeatureMatching, UnrelatedAndFlatImagesFindLittle) {
  const PairMatchResult r = MatchFeatures({}, Texture(320, 240, 2), Texture(320, 240, 3));
  EXPECT_LT(r.inliers, 20);
  const PairMatchResult flat =
      MatchFeatures({}, cv::Mat(100, 100, CV_8U, 128), cv::Mat(100, 100, CV_32F, 0.5));
  EXPECT_EQ(flat.keypoints_a, 0);
  EXPECT_EQ(flat.correspondences, 0);
  EXPECT_FALSE(flat.active);
}

TEST(FeatureMatching, SummaryAveragesOverActiveSetsOnly) {
  std::vector<PairMatchResult> pairs(4);
  pairs[0].correspondences = 11, pairs[0].inliers = 9;   // active (> 10)
  pairs[1].correspondences = 10, pairs[1].inliers = 10;  // not active (= 10)
  pairs[2].correspondences = 31, pairs[2].inliers = 21;  // active
  pairs[3].correspondences = 0;
  const MatchBatchResult s = SummarizeMatches({}, pairs);
  EXPECT_EQ(s.pairs, 4);
  EXPECT_EQ(s.active_sets, 2);
  EXPECT_DOUBLE_EQ(s.mean_correspondences, 21.0);
  EXPECT_DOUBLE_EQ(s.mean_inliers, 15.0);
  EXPECT_EQ(s.ToJson().at("pairs_detail").size(), 4u);
  EXPECT_EQ(SummarizeMatches({}, {}).mean_inliers, 0.0);
}

TEST(FeatureMatching, BadInputThrows) {
  EXPECT_THROW(MatchFeatures({}, cv::Mat(), cv::Mat(10, 10, CV_8U)), Error);
  cv::Mat nan(10, 10, CV_32F, cv::Scalar(0.5));
  nan.at<float>(2, 2) = NAN;
  EXPECT_THROW(MatchFeatures({}, nan, nan), Error);
}

}  // namespace
}  // namespace turbid
