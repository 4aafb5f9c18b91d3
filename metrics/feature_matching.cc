#include "metrics/feature_matching.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "metrics/full_reference.h"
#include "metrics/image_checks.h"
#include "core/error.h"

namespace turbid {

std::string FeatureDetectorName(FeatureDetector detector) {
  switch (detector) {
    case FeatureDetector::kOrb:
      return "orb";
    case FeatureDetector::kAkaze:
      return "akaze";
    case FeatureDetector::kSift:
      return "sift";
  }
  return "orb";
}

FeatureDetector ParseFeatureDetector(const std::string& name) {
  if (name == "orb") return FeatureDetector::kOrb;
  if (name == "akaze") return FeatureDetector::kAkaze;
  if (name == "sift") return FeatureDetector::kSift;
  throw Error("feature detector: unknown name '" + name + "' (use orb, akaze or sift)");
}

bool FeatureMatchOptions::Check(std::string* why) const {
  auto fail = [&](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (max_features < 10) return fail("max_features must be >= 10");
  if (!(ratio > 0.0 && ratio <= 1.0)) return fail("ratio must be in (0, 1]");
  if (!(ransac_threshold_px > 0.0)) return fail("ransac_threshold_px must be > 0");
  if (ransac_max_iterations < 1) return fail("ransac_max_iterations must be >= 1");
  if (!(ransac_confidence > 0.0 && ransac_confidence < 1.0))
    return fail("ransac_confidence must be in (0, 1)");
  if (active_min_correspondences < 0) return fail("active_min_correspondences must be >= 0");
  return true;
}

nlohmann::json PairMatchResult::ToJson() const {
  return {{"keypoints_a", keypoints_a},
          {"keypoints_b", keypoints_b},
          {"correspondences", correspondences},
          {"inliers", inliers},
          {"active", active}};
}

nlohmann::json MatchBatchResult::ToJson() const {
  nlohmann::json detail = nlohmann::json::array();
  for (const PairMatchResult& p : per_pair) detail.push_back(p.ToJson());
  return {{"detector", detector},         {"pairs", pairs},
          {"active_sets", active_sets},   {"mean_correspondences", mean_correspondences},
          {"mean_inliers", mean_inliers}, {"pairs_detail", detail}};
}

cv::Mat ToGray8(const cv::Mat& image, double data_range) {
  const double range = data_range > 0.0 ? data_range : DefaultDataRange(image.depth());
  cv::Mat bgr = image;
  if (image.channels() == 4) {
    std::vector<cv::Mat> planes;
    cv::split(image, planes);
    planes.pop_back();
    cv::merge(planes, bgr);
  }
  cv::Mat gray = Luminance(bgr);
  cv::Mat out;
  gray.convertTo(out, CV_8U, 255.0 / range);
  return out;
}

namespace {

cv::Ptr<cv::Feature2D> MakeDetector(const FeatureMatchOptions& options) {
  switch (options.detector) {
    case FeatureDetector::kAkaze:
      return cv::AKAZE::create();
    case FeatureDetector::kSift:
      return cv::SIFT::create(options.max_features);
    case FeatureDetector::kOrb:
    default:
      return cv::ORB::create(options.max_features);
  }
}

}  // namespace

int MinimumFeatureImageSide(FeatureDetector detector) {
  return detector == FeatureDetector::kSift ? 1 : 2;
}

void CheckFeatureImageSize(FeatureDetector detector, const cv::Mat& image,
                           const std::string& what) {
  const int side = MinimumFeatureImageSide(detector);
  if (image.cols < side || image.rows < side) {
    throw Error(what + ": image is " + std::to_string(image.cols) + "x" +
                std::to_string(image.rows) + ", feature matching with " +
                FeatureDetectorName(detector) + " needs at least " + std::to_string(side) + "x" +
                std::to_string(side) + " pixels");
  }
}

PairMatchResult MatchFeatures(const FeatureMatchOptions& options, const cv::Mat& a,
                              const cv::Mat& b, double data_range) {
  ThrowIfInvalid(options, "feature matching");
  CheckMetricImage(a, "feature matching: first image");
  CheckMetricImage(b, "feature matching: second image");
  CheckFeatureImageSize(options.detector, a, "feature matching: first image");
  CheckFeatureImageSize(options.detector, b, "feature matching: second image");
  const cv::Mat gray_a = ToGray8(a, data_range);
  const cv::Mat gray_b = ToGray8(b, data_range);

  const cv::Ptr<cv::Feature2D> detector = MakeDetector(options);
  std::vector<cv::KeyPoint> kp_a, kp_b;
  cv::Mat desc_a, desc_b;
  detector->detectAndCompute(gray_a, cv::noArray(), kp_a, desc_a);
  detector->detectAndCompute(gray_b, cv::noArray(), kp_b, desc_b);

  PairMatchResult result;
  result.keypoints_a = static_cast<int>(kp_a.size());
  result.keypoints_b = static_cast<int>(kp_b.size());
  if (kp_a.size() >= 2 && kp_b.size() >= 2) {
    // ORB and AKAZE (MLDB) descriptors are binary: Hamming distance; SIFT: L2.
    const int norm = options.detector == FeatureDetector::kSift ? cv::NORM_L2 : cv::NORM_HAMMING;
    cv::BFMatcher matcher(norm, false);
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(desc_a, desc_b, knn, 2);
    std::vector<cv::Point2f> pts_a, pts_b;
    for (const auto& m : knn) {
      if (m.size() < 2) continue;
      if (m[0].distance < options.ratio * m[1].distance) {
        pts_a.push_back(kp_a[m[0].queryIdx].pt);
        pts_b.push_back(kp_b[m[0].trainIdx].pt);
      }
    }
    result.correspondences = static_cast<int>(pts_a.size());
    if (pts_a.size() >= 4) {
      cv::Mat inlier_mask;
      const cv::Mat h =
          cv::findHomography(pts_a, pts_b, cv::RANSAC, options.ransac_threshold_px, inlier_mask,
                             options.ransac_max_iterations, options.ransac_confidence);
      if (!h.empty()) result.inliers = cv::countNonZero(inlier_mask);
    }
  }
  result.active = result.correspondences > options.active_min_correspondences;
  return result;
}

MatchBatchResult SummarizeMatches(const FeatureMatchOptions& options,
                                  const std::vector<PairMatchResult>& pairs) {
  MatchBatchResult batch;
  batch.detector = FeatureDetectorName(options.detector);
  batch.pairs = static_cast<int>(pairs.size());
  batch.per_pair = pairs;
  double corr = 0.0, inl = 0.0;
  for (const PairMatchResult& p : pairs) {
    if (p.correspondences <= options.active_min_correspondences) continue;
    ++batch.active_sets;
    corr += p.correspondences;
    inl += p.inliers;
  }
  if (batch.active_sets > 0) {
    batch.mean_correspondences = corr / batch.active_sets;
    batch.mean_inliers = inl / batch.active_sets;
  }
  return batch;
}

}  // namespace turbid
