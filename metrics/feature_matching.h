// Feature matching between image pairs, the geometric-vision test of the source paper (Fig. 8):
// keypoints + descriptors (ORB, AKAZE or SIFT from OpenCV 4.6 features2d), two-nearest-neighbour
// brute-force matching with Lowe's ratio test (D. Lowe, "Distinctive image features from
// scale-invariant keypoints", IJCV 60(2), 2004, Sec. 7.1: keep a match when d1 < ratio * d2, 0.8),
// then a RANSAC homography (cv::findHomography) whose inliers are counted.
// Batch summary as in the paper: an "active set" is a pair with MORE than 10 correspondences;
// mean correspondences and mean inliers are averaged over the active sets only.
// Deterministic: detectors and brute-force matching are deterministic, and OpenCV's RANSAC seeds
// its own RNG with a fixed value on every call.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace turbid {

enum class FeatureDetector { kOrb, kAkaze, kSift };

std::string FeatureDetectorName(FeatureDetector detector);  // "orb" | "akaze" | "sift"
FeatureDetector ParseFeatureDetector(const std::string& name);  // throws Error for unknown names

// The smallest width and height `detector` takes: OpenCV's ORB and AKAZE fail an assertion on an
// image 1 pixel wide or tall (their pyramid and scale space), SIFT finds no keypoint there.
int MinimumFeatureImageSide(FeatureDetector detector);

// Throws Error("<what>: image is WxH, feature matching with <detector> needs at least NxN pixels")
// for an image below MinimumFeatureImageSide (MatchFeatures checks both images with it).
void CheckFeatureImageSize(FeatureDetector detector, const cv::Mat& image, const std::string& what);

struct FeatureMatchOptions {
  // Keypoint detector and descriptor. The paper does not name one; ORB is the cheapest.
  FeatureDetector detector = FeatureDetector::kOrb;
  // Keypoint budget for ORB and SIFT (AKAZE has no budget), >= 10. ORB's own default is 500;
  // 2000 keeps textured 1360x1024 images from saturating it.
  int max_features = 2000;
  // Lowe ratio-test threshold, (0, 1]. Lowe 2004 Sec. 7.1: 0.8.
  double ratio = 0.8;
  // RANSAC reprojection threshold in pixels, > 0 (OpenCV's default 3).
  double ransac_threshold_px = 3.0;
  // RANSAC iteration cap and confidence (OpenCV defaults 2000 and 0.995).
  int ransac_max_iterations = 2000;
  double ransac_confidence = 0.995;
  // A pair is "active" when correspondences > this. Paper Fig. 8: 10.
  int active_min_correspondences = 10;
  bool Check(std::string* why) const;
};

struct PairMatchResult {
  int keypoints_a = 0;
  int keypoints_b = 0;
  int correspondences = 0;  // matches passing the ratio test
  int inliers = 0;          // RANSAC homography inliers (0 when < 4 correspondences or no model)
  bool active = false;      // correspondences > active_min_correspondences
  nlohmann::json ToJson() const;
};

struct MatchBatchResult {
  std::string detector;
  int pairs = 0;
  int active_sets = 0;                // pairs with correspondences > threshold
  double mean_correspondences = 0.0;  // over active sets; 0 when none is active
  double mean_inliers = 0.0;          // over active sets; 0 when none is active
  std::vector<PairMatchResult> per_pair;
  nlohmann::json ToJson() const;  // summary keys + "pairs_detail" array
};

// Matches one pair. Images: any accepted depth, 1 or 3 (or 4) channels, converted to 8-bit gray
// (float inputs are taken as [0, 1] unless data_range says otherwise); sizes may differ.
// Throws Error for empty or non-finite input or bad options.
PairMatchResult MatchFeatures(const FeatureMatchOptions& options, const cv::Mat& a,
                              const cv::Mat& b, double data_range = 0.0);

// The paper's summary over many pairs.
MatchBatchResult SummarizeMatches(const FeatureMatchOptions& options,
                                  const std::vector<PairMatchResult>& pairs);

// 8-bit single-channel view of an image (Rec. 601 luma for colour), scaled by 255 / data_range
// (0 = from depth) and rounded, saturating.
cv::Mat ToGray8(const cv::Mat& image, double data_range = 0.0);

}  // namespace turbid
