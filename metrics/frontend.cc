#include "metrics/frontend.h"

#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace turbid {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

struct BaseInfo {
  const char* name;
  bool higher_is_better;
  bool needs_detector;
};
constexpr BaseInfo kBases[] = {
    {"matches", true, true},
    {"inliers", true, true},
    {"inlier_ratio", true, true},
    {"track_survival", true, true},
    {"rpe_rot_deg", false, true},
    {"rpe_trans_deg", false, true},
    {"rpe_trans_m", false, true},
    {"pose_failed", false, true},
    {"flicker", false, false},
    {"keypoints", true, true},
    {"active", true, true},
    {"correspondences", true, true},
    {"homography_inliers", true, true},
};

// OpenCV's essential-matrix code assumes positive focal lengths (it divides its threshold by
// (fx + fy) / 2, which is 0 for ICL-NUIM's fy = -fx). A negative focal length is a camera frame
// with that axis flipped: the pair is solved in the frame S X (S = diag(sign fx, sign fy, 1)) with
// |fx|, |fy|, where the truth is S R S, S t; angles and lengths are the same in both frames.
cv::Matx33d CameraMatrix(const CameraIntrinsics& c) {
  return {std::abs(c.fx), 0.0, c.cx, 0.0, std::abs(c.fy), c.cy, 0.0, 0.0, 1.0};
}
cv::Matx33d AxisFlip(const CameraIntrinsics& c) {
  return cv::Matx33d::diag({c.fx < 0 ? -1.0 : 1.0, c.fy < 0 ? -1.0 : 1.0, 1.0});
}

double AngleDeg(const cv::Vec3d& a, const cv::Vec3d& b) {
  const double na = cv::norm(a), nb = cv::norm(b);
  if (!(na > 0) || !(nb > 0)) return kNan;
  const double c = std::clamp(a.dot(b) / (na * nb), -1.0, 1.0);
  return std::acos(c) * kDegPerRad;
}

}  // namespace

bool FrontendOptions::Check(std::string* why) const {
  const auto fail = [&](const char* text) {
    *why = text;
    return false;
  };
  if (orb_features < 10 || sift_features < 10) return fail("feature budgets must be >= 10");
  if (!(ratio > 0 && ratio <= 1)) return fail("ratio must be in (0, 1]");
  if (!(essential_threshold_px > 0) || !(pnp_threshold_px > 0))
    return fail("RANSAC thresholds must be > 0");
  if (!(essential_confidence > 0 && essential_confidence < 1) ||
      !(pnp_confidence > 0 && pnp_confidence < 1))
    return fail("RANSAC confidences must be in (0, 1)");
  if (min_pose_inliers < 5 || pnp_iterations < 1) return fail("min_pose_inliers must be >= 5");
  if (!(flicker_depth_tolerance > 0)) return fail("flicker_depth_tolerance must be > 0");
  if (active_min_matches < 0) return fail("active_min_matches must be >= 0");
  if (!(homography_threshold_px > 0) || homography_iterations < 1 ||
      !(homography_confidence > 0 && homography_confidence < 1))
    return fail("homography RANSAC: threshold > 0, iterations >= 1, confidence in (0, 1)");
  return true;
}

std::optional<FrontendMetric> ParseFrontendMetric(const std::string& name) {
  FrontendMetric m;
  m.name = name;
  std::string rest = name;
  bool prefixed = false;
  for (const auto& [prefix, detector] :
       {std::pair<std::string, FeatureDetector>{"orb_", FeatureDetector::kOrb},
        {"sift_", FeatureDetector::kSift}}) {
    if (rest.rfind(prefix, 0) == 0) {
      rest = rest.substr(prefix.size());
      m.detector = detector;
      prefixed = true;
      break;
    }
  }
  const size_t k = rest.rfind("_k");
  if (k != std::string::npos && k + 2 < rest.size() &&
      rest.find_first_not_of("0123456789", k + 2) == std::string::npos && rest.size() - k <= 6) {
    const int skip = std::stoi(rest.substr(k + 2));
    if (skip < 1 || skip > 1000 || rest[k + 2] == '0') return std::nullopt;
    m.skip = skip;
    rest = rest.substr(0, k);
  }
  for (const BaseInfo& base : kBases) {
    if (rest != base.name) continue;
    if (prefixed && !base.needs_detector) return std::nullopt;
    m.base = base.name;
    m.higher_is_better = base.higher_is_better;
    return m;
  }
  return std::nullopt;
}

std::vector<std::string> FrontendMetricBases() {
  std::vector<std::string> out;
  for (const BaseInfo& base : kBases) out.push_back(base.name);
  return out;
}

FrontendFeatures DetectFrontendFeatures(const FrontendOptions& options, FeatureDetector detector,
                                        const cv::Mat& gray8) {
  cv::Ptr<cv::Feature2D> feature;
  switch (detector) {
    case FeatureDetector::kOrb:
      feature = cv::ORB::create(options.orb_features);
      break;
    case FeatureDetector::kSift:
      feature = cv::SIFT::create(options.sift_features);
      break;
    default:
      throw Error("front-end metrics: detector '" + FeatureDetectorName(detector) +
                  "' is not offered (orb, sift)");
  }
  FrontendFeatures out;
  if (gray8.cols < MinimumFeatureImageSide(detector) ||
      gray8.rows < MinimumFeatureImageSide(detector))
    return out;
  std::vector<cv::KeyPoint> keypoints;
  feature->detectAndCompute(gray8, cv::noArray(), keypoints, out.descriptors);
  for (const cv::KeyPoint& kp : keypoints) out.points.push_back(kp.pt);
  return out;
}

double FrontendPair::Get(const std::string& base) const {
  if (base == "matches") return matches;
  if (base == "inliers") return inliers;
  if (base == "inlier_ratio") return inlier_ratio;
  if (base == "track_survival") return track_survival;
  if (base == "rpe_rot_deg") return rpe_rot_deg;
  if (base == "rpe_trans_deg") return rpe_trans_deg;
  if (base == "rpe_trans_m") return rpe_trans_m;
  if (base == "pose_failed") return pose_failed;
  if (base == "keypoints") return keypoints;
  if (base == "active") return active;
  if (base == "correspondences") return correspondences;
  if (base == "homography_inliers") return homography_inliers;
  throw Error("front-end metrics: no pair value '" + base + "'");
}

namespace {

// Ratio-test matches a -> b as point lists.
void MatchPoints(const FrontendOptions& options, FeatureDetector detector,
                 const FrontendFeatures& a, const FrontendFeatures& b, std::vector<cv::Point2f>* pa,
                 std::vector<cv::Point2f>* pb) {
  if (a.points.size() < 2 || b.points.size() < 2) return;
  cv::BFMatcher matcher(detector == FeatureDetector::kSift ? cv::NORM_L2 : cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(a.descriptors, b.descriptors, knn, 2);
  for (const auto& pair : knn) {
    if (pair.size() < 2 || !(pair[0].distance < options.ratio * pair[1].distance)) continue;
    pa->push_back(a.points[static_cast<size_t>(pair[0].queryIdx)]);
    pb->push_back(b.points[static_cast<size_t>(pair[0].trainIdx)]);
  }
}

// |t_PnP - t_true| with 3D points from a's depth at its matched keypoints; NaN when PnP fails.
double PnpTranslationError(const FrontendOptions& options, const FrontendFrame& a,
                           const std::vector<cv::Point2f>& pa, const std::vector<cv::Point2f>& pb,
                           const cv::Matx33d& k, const Pose& b_from_a) {
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  for (size_t i = 0; i < pa.size(); ++i) {
    const int x = cvRound(pa[i].x), y = cvRound(pa[i].y);
    if (x < 0 || y < 0 || x >= a.depth_m.cols || y >= a.depth_m.rows) continue;
    const float z = a.depth_m.at<float>(y, x);
    if (!(z > 0) || !std::isfinite(z)) continue;
    const cv::Vec3d ray = AxisFlip(a.camera) * a.camera.Ray(pa[i].x, pa[i].y);
    object.emplace_back(static_cast<float>(ray[0] * z), static_cast<float>(ray[1] * z), z);
    image.push_back(pb[i]);
  }
  if (static_cast<int>(object.size()) < options.min_pose_inliers) return kNan;
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const bool ok =
      cv::solvePnPRansac(object, image, k, cv::noArray(), rvec, tvec, false, options.pnp_iterations,
                         static_cast<float>(options.pnp_threshold_px), options.pnp_confidence,
                         inliers, cv::SOLVEPNP_EPNP);
  if (!ok || static_cast<int>(inliers.size()) < options.min_pose_inliers) return kNan;
  const cv::Vec3d t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return cv::norm(t - b_from_a.position_m);
}

// Inliers of a RANSAC homography a -> b (the paper's Fig. 8 "inliers"); 0 below 4 matches or
// without a model.
double HomographyInliers(const FrontendOptions& options, const std::vector<cv::Point2f>& pa,
                         const std::vector<cv::Point2f>& pb) {
  if (pa.size() < 4) return 0.0;
  cv::Mat mask;
  const cv::Mat h =
      cv::findHomography(pa, pb, cv::RANSAC, options.homography_threshold_px, mask,
                         options.homography_iterations, options.homography_confidence);
  return h.empty() ? 0.0 : static_cast<double>(cv::countNonZero(mask));
}

}  // namespace

unsigned FrontendPartOf(const std::string& base) {
  if (base == "inliers" || base == "inlier_ratio" || base == "track_survival" ||
      base == "rpe_rot_deg" || base == "rpe_trans_deg" || base == "pose_failed")
    return kFrontendEssential;
  if (base == "rpe_trans_m") return kFrontendPnp;
  if (base == "homography_inliers") return kFrontendHomography;
  return 0u;
}

FrontendPair EvaluateFrontendPair(const FrontendOptions& options, FeatureDetector detector,
                                  const FrontendFrame& a, const FrontendFrame& b, unsigned parts) {
  const FrontendFeatures& fa = a.features.at(detector);
  const FrontendFeatures& fb = b.features.at(detector);
  std::vector<cv::Point2f> pa, pb;
  MatchPoints(options, detector, fa, fb, &pa, &pb);
  FrontendPair out;
  out.matches = static_cast<double>(pa.size());
  out.rpe_rot_deg = out.rpe_trans_deg = out.rpe_trans_m = kNan;
  out.pose_failed = 1.0;
  const cv::Matx33d k = CameraMatrix(a.camera);
  const cv::Matx33d flip = AxisFlip(a.camera);
  Pose b_from_a = Relative(b.pose, a.pose);
  b_from_a = {flip * b_from_a.rotation * flip, flip * b_from_a.position_m};
  if (pa.size() >= 5 && (parts & kFrontendEssential)) {
    cv::Mat mask;
    cv::Mat e = cv::findEssentialMat(pa, pb, k, cv::RANSAC, options.essential_confidence,
                                     options.essential_threshold_px, mask);
    if (e.rows >= 3 && e.cols == 3) {
      e = e.rowRange(0, 3).clone();  // several solutions: the first (RANSAC returns its best)
      out.inliers = cv::countNonZero(mask);
      cv::Mat r, t;
      const int good = cv::recoverPose(e, pa, pb, k, r, t, mask);
      if (good >= options.min_pose_inliers) {
        out.pose_failed = 0.0;
        const cv::Matx33d r_est(r);
        out.rpe_rot_deg = RotationAngleDeg(r_est.t() * b_from_a.rotation);
        out.rpe_trans_deg = AngleDeg(cv::Vec3d(t.at<double>(0), t.at<double>(1), t.at<double>(2)),
                                     b_from_a.position_m);
      }
    }
  }
  if (pa.size() >= 5 && (parts & kFrontendPnp))
    out.rpe_trans_m = PnpTranslationError(options, a, pa, pb, k, b_from_a);
  out.keypoints = static_cast<double>(fb.points.size());
  out.active = out.matches > options.active_min_matches ? 1.0 : 0.0;
  out.correspondences = out.homography_inliers = kNan;
  if (out.active > 0) {
    out.correspondences = out.matches;
    if (parts & kFrontendHomography) out.homography_inliers = HomographyInliers(options, pa, pb);
  }
  out.inlier_ratio = out.matches > 0 ? out.inliers / out.matches : 0.0;
  out.track_survival =
      fa.points.empty() ? 0.0 : out.inliers / static_cast<double>(fa.points.size());
  if (!(parts & kFrontendEssential)) {
    out.inliers = out.inlier_ratio = out.track_survival = out.rpe_rot_deg = out.rpe_trans_deg =
        out.pose_failed = kNan;
  }
  return out;
}

double WarpedTemporalDifference(const FrontendOptions& options, const FrontendFrame& a,
                                const FrontendFrame& b) {
  return WarpedTemporalDifference(MakeTemporalWarp(options, a, b), a.gray8, b.gray8);
}

TemporalWarp MakeTemporalWarp(const FrontendOptions& options, const FrontendFrame& a,
                              const FrontendFrame& b) {
  const Pose a_from_b = Relative(a.pose, b.pose);
  const cv::Matx33d r = a_from_b.rotation;
  const cv::Vec3d t = a_from_b.position_m;
  cv::Mat map_x(b.depth_m.size(), CV_32F), map_y(b.depth_m.size(), CV_32F);
  cv::Mat valid(b.depth_m.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < b.depth_m.rows; ++y) {
    const float* z = b.depth_m.ptr<float>(y);
    float* mx = map_x.ptr<float>(y);
    float* my = map_y.ptr<float>(y);
    uint8_t* ok = valid.ptr<uint8_t>(y);
    for (int x = 0; x < b.depth_m.cols; ++x) {
      mx[x] = my[x] = -1.0f;
      if (!(z[x] > 0) || !std::isfinite(z[x])) continue;
      const cv::Vec3d p = r * (b.camera.Ray(x, y) * static_cast<double>(z[x])) + t;
      if (!(p[2] > 0)) continue;
      const double u = a.camera.fx * p[0] / p[2] + a.camera.cx;
      const double v = a.camera.fy * p[1] / p[2] + a.camera.cy;
      if (!(u >= 0 && v >= 0 && u <= a.depth_m.cols - 1 && v <= a.depth_m.rows - 1)) continue;
      const float za = a.depth_m.at<float>(cvRound(v), cvRound(u));
      if (!(std::abs(za - p[2]) <= options.flicker_depth_tolerance * p[2])) continue;
      mx[x] = static_cast<float>(u);
      my[x] = static_cast<float>(v);
      ok[x] = 1;
    }
  }
  return {map_x, map_y, valid};
}

double WarpedTemporalDifference(const TemporalWarp& warp, const cv::Mat& gray_a,
                                const cv::Mat& gray_b) {
  const cv::Mat& valid = warp.valid;
  cv::Mat source, warped;
  gray_a.convertTo(source, CV_32F);
  cv::remap(source, warped, warp.map_x, warp.map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  double sum = 0.0;
  int64_t n = 0;
  for (int y = 0; y < warped.rows; ++y) {
    const float* w = warped.ptr<float>(y);
    const uint8_t* g = gray_b.ptr<uint8_t>(y);
    const uint8_t* ok = valid.ptr<uint8_t>(y);
    for (int x = 0; x < warped.cols; ++x) {
      if (!ok[x]) continue;
      sum += std::abs(static_cast<double>(g[x]) - static_cast<double>(w[x]));
      ++n;
    }
  }
  return n > 0 ? sum / static_cast<double>(n) : kNan;
}

}  // namespace turbid
