// SLAM front-end metrics on pairs of frames with known poses (docs/metrics.md "Front-end metrics
// on sequences", issue "Sequences"): keypoints and descriptors (ORB or SIFT, OpenCV 4.6
// features2d), two-nearest-neighbour brute-force matching with Lowe's ratio test, a RANSAC
// essential matrix and the relative pose it gives (cv::findEssentialMat, cv::recoverPose), and a
// metric pose from the first frame's depth (cv::solvePnPRansac), scored against the ground-truth
// relative pose; plus the temporal difference behind the flicker metric (the second frame
// compared with the first warped by the known motion and depth).
//
// Poses are camera-to-world (scenes/pose.h). For a pair (a, b) the truth is b_from_a =
// world_from_b^-1 o world_from_a, so that X_b = R X_a + t. Deterministic: detectors and
// brute-force matching are deterministic and OpenCV's RANSAC seeds its own RNG on every call.
#pragma once

#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "metrics/feature_matching.h"
#include "scenes/pose.h"
#include "scenes/scene.h"

namespace turbid {

struct FrontendOptions {
  // Keypoint budget per image. ORB: 1000 at 640x480, ORB-SLAM's (Mur-Artal et al. 2015) setting,
  // with OpenCV's other defaults (8 levels, scale 1.2, FAST threshold 20); SIFT: 1000, OpenCV's
  // defaults otherwise (3 layers per octave, contrast 0.04, edge 10, sigma 1.6).
  int orb_features = 1000;
  int sift_features = 1000;
  // Lowe ratio test (Lowe 2004, Sec. 7.1).
  double ratio = 0.8;
  // Essential matrix RANSAC: threshold on the Sampson distance in pixels, and confidence.
  double essential_threshold_px = 1.0;
  double essential_confidence = 0.999;
  // A pose counts as estimated when recoverPose keeps at least this many inliers in front of both
  // cameras (else pose_failed = 1 and the rotation/direction errors are NaN).
  int min_pose_inliers = 15;
  // PnP RANSAC (3D points from the first frame's depth, 2D in the second): reprojection
  // threshold in pixels, iterations, confidence; at least min_pose_inliers inliers.
  double pnp_threshold_px = 2.0;
  int pnp_iterations = 1000;
  double pnp_confidence = 0.999;
  // Flicker: a warped pixel counts when the first frame's depth where it lands agrees with the
  // predicted depth within this fraction (occlusions and disocclusions are left out).
  double flicker_depth_tolerance = 0.05;
  // The paper's Fig. 8 (Cho & Kim 2019): a pair is an "active set" when it has MORE than
  // active_min_matches ratio-test matches (10); its homography inliers come from a RANSAC
  // homography (cv::findHomography) with this reprojection threshold in pixels, iteration cap and
  // confidence (OpenCV's defaults 3, 2000, 0.995; the same as turbid score --pairs).
  int active_min_matches = 10;
  double homography_threshold_px = 3.0;
  int homography_iterations = 2000;
  double homography_confidence = 0.995;
  bool Check(std::string* why) const;
};

// The front-end metric names of sweeps: [orb_|sift_]BASE[_kN], and flicker[_kN].
//   matches          ratio-test matches of the pair                        (higher is better)
//   inliers          essential-matrix RANSAC inliers                       (higher)
//   inlier_ratio     inliers / matches (0 without matches)                 (higher)
//   track_survival   inliers / keypoints of the first frame: the share of its features that
//                    survive into the second as verified matches            (higher)
//   rpe_rot_deg      rotation error of the essential-matrix pose, degrees  (lower)
//   rpe_trans_deg    angle between estimated and true translation direction, degrees (lower)
//   rpe_trans_m      |t_PnP - t_true|, metres (PnP with the first frame's depth) (lower)
//   pose_failed      1 when the essential-matrix pose could not be estimated, else 0 (lower)
//   flicker          mean |E_b - W(E_a)| - mean |C_b - W(C_a)|: the enhanced frames' temporal
//                    difference after warping with the known motion, in excess of the clean
//                    frames' (8-bit luma levels; WarpedTemporalDifference)  (lower)
// The paper's Fig. 8 figures (its "active sets", "correspondences" and "inliers"):
//   keypoints        keypoints detected in the second frame                 (higher)
//   active           1 when the pair has more than active_min_matches matches, else 0: its mean
//                    is the share of active sets                            (higher)
//   correspondences  matches of an active pair; NaN (left out of the mean) for the others, so the
//                    mean is the paper's mean over the active sets          (higher)
//   homography_inliers  RANSAC homography inliers of an active pair; NaN for the others (higher)
// The detector prefix defaults to orb; _kN pairs frame i - N with frame i (N in [1, 1000],
// default 1: consecutive frames).
struct FrontendMetric {
  std::string name;  // as written
  std::string base;  // "matches", ..., "flicker"
  FeatureDetector detector = FeatureDetector::kOrb;
  int skip = 1;
  bool higher_is_better = true;
};
// nullopt when `name` is not of this grammar (then it is no front-end metric).
std::optional<FrontendMetric> ParseFrontendMetric(const std::string& name);
// The bases, for --list and docs.
std::vector<std::string> FrontendMetricBases();

// Keypoint positions and descriptors of one image.
struct FrontendFeatures {
  std::vector<cv::Point2f> points;
  cv::Mat descriptors;
};
FrontendFeatures DetectFrontendFeatures(const FrontendOptions& options, FeatureDetector detector,
                                        const cv::Mat& gray8);

// One frame as the front end sees it: the 8-bit luma image, its depth (metres, NaN invalid),
// the camera and the pose, and the features of each detector asked for.
struct FrontendFrame {
  cv::Mat gray8;
  cv::Mat depth_m;
  CameraIntrinsics camera;
  Pose pose;
  std::map<FeatureDetector, FrontendFeatures> features;
};

struct FrontendPair {
  double matches = 0, inliers = 0, inlier_ratio = 0, track_survival = 0;
  double rpe_rot_deg = 0, rpe_trans_deg = 0, rpe_trans_m = 0, pose_failed = 0;
  double keypoints = 0, active = 0, correspondences = 0, homography_inliers = 0;
  double Get(const std::string& base) const;  // by metric base; throws Error for others
};
// The parts of a pair's evaluation beyond matching (which is always done: matches, keypoints,
// active, correspondences). EvaluateFrontendPair computes the parts asked for; the values of the
// others are NaN. A sweep asks for the parts its metrics need (SequenceScorer).
enum FrontendPart : unsigned {
  // Essential-matrix RANSAC and recoverPose: inliers, inlier_ratio, track_survival, rpe_rot_deg,
  // rpe_trans_deg, pose_failed.
  kFrontendEssential = 1u,
  kFrontendPnp = 2u,         // solvePnPRansac: rpe_trans_m
  kFrontendHomography = 4u,  // findHomography: homography_inliers
  kFrontendAllParts = 7u,
};
// The part a metric base needs (0: matching only, or flicker).
unsigned FrontendPartOf(const std::string& base);

// The pair (a, b) with `detector`'s features (both frames must hold them).
FrontendPair EvaluateFrontendPair(const FrontendOptions& options, FeatureDetector detector,
                                  const FrontendFrame& a, const FrontendFrame& b,
                                  unsigned parts = kFrontendAllParts);

// mean |b - W(a)| (8-bit luma levels) over the pixels of b whose warp into a is valid (depth of b
// finite, lands inside a, a's depth there within flicker_depth_tolerance of the prediction); W(a)
// is a's gray8 sampled bilinearly at b's pixels moved by the true motion. NaN when no pixel is
// valid.
double WarpedTemporalDifference(const FrontendOptions& options, const FrontendFrame& a,
                                const FrontendFrame& b);

// The same in two steps: the warp depends only on the frames' depth, cameras and poses, so a
// sweep computes it once per pair and applies it to the luma of every method.
struct TemporalWarp {
  cv::Mat map_x, map_y;  // where each pixel of b lands in a (CV_32F)
  cv::Mat valid;         // CV_8U, 1 where the warp is valid
};
TemporalWarp MakeTemporalWarp(const FrontendOptions& options, const FrontendFrame& a,
                              const FrontendFrame& b);
// mean |gray_b - W(gray_a)| over the valid pixels (8-bit luma images of a and b); NaN when none.
double WarpedTemporalDifference(const TemporalWarp& warp, const cv::Mat& gray_a,
                                const cv::Mat& gray_b);

}  // namespace turbid
