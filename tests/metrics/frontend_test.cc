// Front-end metrics (metrics/frontend.h): the name grammar; the relative pose against a closed
// form (points projected through two known cameras, exact correspondences); and clean frames of
// the built-in scenes along trajectories, whose depth is exact, where the pose error must be near
// 0.
#include "metrics/frontend.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "metrics/feature_matching.h"
#include "scenes/sequence.h"

namespace turbid {
namespace {

TEST(FrontendMetricNames, GrammarDetectorsSkipsAndDirections) {
  const auto m = ParseFrontendMetric("rpe_rot_deg");
  ASSERT_TRUE(m);
  EXPECT_EQ(m->base, "rpe_rot_deg");
  EXPECT_EQ(m->detector, FeatureDetector::kOrb);
  EXPECT_EQ(m->skip, 1);
  EXPECT_FALSE(m->higher_is_better);
  const auto s = ParseFrontendMetric("sift_inlier_ratio_k5");
  ASSERT_TRUE(s);
  EXPECT_EQ(s->base, "inlier_ratio");
  EXPECT_EQ(s->detector, FeatureDetector::kSift);
  EXPECT_EQ(s->skip, 5);
  EXPECT_TRUE(s->higher_is_better);
  EXPECT_TRUE(ParseFrontendMetric("orb_track_survival"));
  EXPECT_TRUE(ParseFrontendMetric("flicker_k2"));
  EXPECT_TRUE(ParseFrontendMetric("pose_failed"));
  for (const char* bad : {"ssim", "sift_flicker", "rpe_rot_deg_k0", "rpe_rot_deg_k01",
                          "rpe_rot_deg_k1001", "akaze_matches", "matches_k", "rpe_rot"})
    EXPECT_FALSE(ParseFrontendMetric(bad)) << bad;
  EXPECT_EQ(FrontendMetricBases().size(), 13u);
  const auto h = ParseFrontendMetric("sift_homography_inliers_k2");
  ASSERT_TRUE(h);
  EXPECT_EQ(h->base, "homography_inliers");
  EXPECT_EQ(h->skip, 2);
  EXPECT_TRUE(ParseFrontendMetric("active") && ParseFrontendMetric("orb_keypoints"));
}

// Frame b of a pair whose features are exact projections of world points (unique random binary
// descriptors, so every match is right): the essential-matrix pose and PnP must give the truth.
FrontendFrame Projected(const CameraIntrinsics& camera, const Pose& pose,
                        const std::vector<cv::Vec3d>& world, const cv::Mat& descriptors,
                        std::vector<float>* depth_at) {
  FrontendFrame f;
  f.camera = camera;
  f.pose = pose;
  f.depth_m = cv::Mat(camera.height, camera.width, CV_32F, cv::Scalar(0));
  FrontendFeatures features;
  const Pose camera_from_world = pose.Inverse();
  for (size_t i = 0; i < world.size(); ++i) {
    const cv::Vec3d x = camera_from_world.Apply(world[i]);
    const double u = camera.fx * x[0] / x[2] + camera.cx, v = camera.fy * x[1] / x[2] + camera.cy;
    features.points.emplace_back(static_cast<float>(u), static_cast<float>(v));
    if (depth_at) depth_at->push_back(static_cast<float>(x[2]));
  }
  features.descriptors = descriptors;
  f.features[FeatureDetector::kOrb] = features;
  return f;
}

Pose Turned(double yaw_deg, double pitch_deg, const cv::Vec3d& position) {
  const double y = yaw_deg * CV_PI / 180, p = pitch_deg * CV_PI / 180;
  const cv::Matx33d ry(std::cos(y), 0, std::sin(y), 0, 1, 0, -std::sin(y), 0, std::cos(y));
  const cv::Matx33d rx(1, 0, 0, 0, std::cos(p), -std::sin(p), 0, std::sin(p), std::cos(p));
  return {ry * rx, position};
}

TEST(FrontendPair, ExactCorrespondencesGiveTheTruePoseForEitherSignOfFy) {
  for (const double fy_sign : {1.0, -1.0}) {
    CameraIntrinsics camera{500.0, 500.0 * fy_sign, 319.5, 239.5, 640, 480};
    cv::RNG rng(7);
    std::vector<cv::Vec3d> world;
    for (int i = 0; i < 300; ++i)
      world.emplace_back(rng.uniform(-1.5, 1.5), rng.uniform(-1.0, 1.0), rng.uniform(3.0, 6.0));
    cv::Mat descriptors(300, 32, CV_8U);
    rng.fill(descriptors, cv::RNG::UNIFORM, 0, 256);
    const Pose pose_a = Turned(2.0, -1.0, {0.1, 0.0, 0.0});
    const Pose pose_b = Turned(5.0, 1.5, {0.25, 0.05, 0.1});
    std::vector<float> depth;
    FrontendFrame a = Projected(camera, pose_a, world, descriptors, &depth);
    // a's depth at its keypoints (rounded pixels), for PnP: the exact z there.
    const std::vector<cv::Point2f>& pa = a.features[FeatureDetector::kOrb].points;
    for (size_t i = 0; i < pa.size(); ++i)
      a.depth_m.at<float>(cvRound(pa[i].y), cvRound(pa[i].x)) = depth[i];
    const FrontendFrame b = Projected(camera, pose_b, world, descriptors, nullptr);
    const FrontendPair r = EvaluateFrontendPair(FrontendOptions{}, FeatureDetector::kOrb, a, b);
    EXPECT_EQ(r.matches, 300);
    EXPECT_EQ(r.inliers, 300);
    EXPECT_DOUBLE_EQ(r.inlier_ratio, 1.0);
    EXPECT_EQ(r.pose_failed, 0.0);
    EXPECT_LT(r.rpe_rot_deg, 0.01) << fy_sign;
    EXPECT_LT(r.rpe_trans_deg, 0.1) << fy_sign;
    // Depth is read at the rounded pixel, so the 3D points are off by up to half a pixel's ray:
    // ~0.5 / 500 * 4.5 m = 4.5 mm laterally; PnP averages that over 300 points.
    EXPECT_LT(r.rpe_trans_m, 0.005) << fy_sign;
    // The wrong convention (a_from_b instead of b_from_a) would be off by twice the rotation.
    EXPECT_GT(RotationAngleDeg(Relative(pose_a, pose_b).rotation), 3.0);
  }
}

TEST(FrontendPair, TooFewMatchesFailThePose) {
  CameraIntrinsics camera{500.0, 500.0, 319.5, 239.5, 640, 480};
  FrontendFrame a, b;
  a.camera = b.camera = camera;
  a.depth_m = b.depth_m = cv::Mat(480, 640, CV_32F, cv::Scalar(0));
  a.features[FeatureDetector::kOrb] = {};
  b.features[FeatureDetector::kOrb] = {};
  const FrontendPair r = EvaluateFrontendPair(FrontendOptions{}, FeatureDetector::kOrb, a, b);
  EXPECT_EQ(r.matches, 0);
  EXPECT_EQ(r.pose_failed, 1.0);
  EXPECT_EQ(r.inlier_ratio, 0.0);
  EXPECT_TRUE(std::isnan(r.rpe_rot_deg));
  EXPECT_TRUE(std::isnan(r.rpe_trans_m));
}

// Clean frames of a built-in scene along a trajectory: exact depth and poses.
FrontendFrame CleanFrame(const Sequence& sequence, int i, const FrontendOptions& options) {
  const Scene scene = sequence.Frame(i);
  FrontendFrame f;
  f.gray8 = ToGray8(scene.image, 1.0);
  f.depth_m = scene.depth_m;
  f.camera = scene.camera;
  f.pose = sequence.pose(i);
  for (FeatureDetector d : {FeatureDetector::kOrb, FeatureDetector::kSift})
    f.features[d] = DetectFrontendFeatures(options, d, f.gray8);
  return f;
}

// The room is 3D (walls, floor, furniture), so the essential matrix is well defined; the seafloor
// is nearly one plane, where the five-point essential matrix has a second, twisted solution with
// the same support (Nister 2004; Hartley & Zisserman 2004, Sec. 11.9), so its rotation and
// direction errors are those of a monocular front-end on a plane and only PnP (with depth) is
// checked there. Tolerances: the measured values (SIFT on the room 0.22 deg, 0.89 deg, 1.5 mm;
// PnP on the seafloor 1.5 mm ORB, 1.0 mm SIFT) x ~2-5.
TEST(FrontendPair, CleanBuiltinFramesHaveNearZeroPoseError) {
  struct Case {
    const char* scene;
    const char* kind;
    int step;
    bool essential;  // check the essential-matrix pose
  };
  const FrontendOptions options;
  for (const Case& c : {Case{"room", "pass", 3, true}, Case{"seafloor", "pass", 2, false}}) {
    TrajectoryOptions trajectory;
    trajectory.kind = c.kind;
    trajectory.frames = 1 + c.step;
    trajectory.speed_m_per_s = 1.0;  // 0.1 m per frame
    BuiltinSceneOptions scene;
    const auto sequence = MakeBuiltinSequence(c.scene, scene, trajectory);
    const FrontendFrame a = CleanFrame(*sequence, 0, options);
    const FrontendFrame b = CleanFrame(*sequence, c.step, options);
    for (FeatureDetector d : {FeatureDetector::kOrb, FeatureDetector::kSift}) {
      const FrontendPair r = EvaluateFrontendPair(options, d, a, b);
      SCOPED_TRACE(std::string(c.scene) + " " + FeatureDetectorName(d));
      std::printf("%s %s: matches %.0f inliers %.0f rot %.4f deg dir %.3f deg trans %.5f m\n",
                  c.scene, FeatureDetectorName(d).c_str(), r.matches, r.inliers, r.rpe_rot_deg,
                  r.rpe_trans_deg, r.rpe_trans_m);
      EXPECT_GT(r.matches, 100);
      EXPECT_GT(r.inliers, 0.5 * r.matches);
      // ORB on the room's repeated floor planks and wall: its pose errors are a front end's
      // (measured 4.0 deg, 85 deg, 17 mm), not a check of the code; SIFT is checked.
      if (d == FeatureDetector::kOrb && c.essential) continue;
      EXPECT_LT(r.rpe_trans_m, 0.005);  // 5 mm of a 0.2-0.3 m step, with exact depth
      if (!c.essential) continue;
      EXPECT_EQ(r.pose_failed, 0.0);
      EXPECT_LT(r.rpe_rot_deg, 0.5);
      EXPECT_LT(r.rpe_trans_deg, 5.0);
    }
    // Warped by the true motion, the clean frames agree to a few 8-bit levels (texture
    // interpolation); a brightness step of 20 levels shows as ~20 more.
    const double same = WarpedTemporalDifference(options, a, b);
    FrontendFrame brighter = b;
    brighter.gray8 = b.gray8 + 20;
    const double shifted = WarpedTemporalDifference(options, a, brighter);
    std::printf("%s: temporal difference %.3f, +20: %.3f\n", c.scene, same, shifted);
    EXPECT_LT(same, 6.0);
    EXPECT_GT(shifted - same, 12.0);
  }
}

// The paper's Fig. 8 figures on a closed form: 300 points of a plane seen from two cameras (a
// homography maps one view onto the other exactly) plus 50 matches moved 60-100 px off their true
// position: the homography keeps exactly the 300. A pair with 10 matches is no active set (the
// paper: "more than 10 correspondences"), with 11 it is.
TEST(FrontendPair, HomographyInliersAndActiveSetsOnAPlane) {
  const CameraIntrinsics camera{500.0, 500.0, 319.5, 239.5, 640, 480};
  cv::RNG rng(11);
  std::vector<cv::Vec3d> world;
  for (int i = 0; i < 350; ++i)
    world.emplace_back(rng.uniform(-1.5, 1.5), rng.uniform(-1.0, 1.0), 4.0);
  cv::Mat descriptors(350, 32, CV_8U);
  rng.fill(descriptors, cv::RNG::UNIFORM, 0, 256);
  const FrontendFrame a = Projected(camera, Turned(0, 0, {0, 0, 0}), world, descriptors, nullptr);
  FrontendFrame b =
      Projected(camera, Turned(4.0, -2.0, {0.2, 0.05, 0.1}), world, descriptors, nullptr);
  std::vector<cv::Point2f>& pb = b.features[FeatureDetector::kOrb].points;
  for (size_t i = 300; i < pb.size(); ++i) {
    const double angle = rng.uniform(0.0, 2 * CV_PI), r = rng.uniform(60.0, 100.0);
    pb[i] += cv::Point2f(static_cast<float>(r * std::cos(angle)),
                         static_cast<float>(r * std::sin(angle)));
  }
  FrontendFrame a_ = a;
  a_.depth_m = b.depth_m = cv::Mat(480, 640, CV_32F, cv::Scalar(0));
  const FrontendOptions options;
  const FrontendPair r = EvaluateFrontendPair(options, FeatureDetector::kOrb, a_, b);
  EXPECT_EQ(r.matches, 350);
  EXPECT_EQ(r.keypoints, 350);
  EXPECT_EQ(r.active, 1.0);
  EXPECT_EQ(r.correspondences, 350);
  EXPECT_EQ(r.homography_inliers, 300);
  for (const int n : {10, 11}) {
    FrontendFrame a_n = a_, b_n = b;
    for (FrontendFrame* f : {&a_n, &b_n}) {
      FrontendFeatures& ff = f->features[FeatureDetector::kOrb];
      ff.points.resize(static_cast<size_t>(n));
      ff.descriptors = ff.descriptors.rowRange(0, n).clone();
    }
    const FrontendPair small = EvaluateFrontendPair(options, FeatureDetector::kOrb, a_n, b_n);
    EXPECT_EQ(small.matches, n);
    EXPECT_EQ(small.active, n > 10 ? 1.0 : 0.0) << n;
    EXPECT_EQ(std::isnan(small.correspondences), n <= 10) << n;
    EXPECT_EQ(std::isnan(small.homography_inliers), n <= 10) << n;
    if (n > 10) {
      EXPECT_EQ(small.homography_inliers, n);
    }
  }
}

// The Fig. 8 figures of the front end are those of `turbid score --pairs` (MatchFeatures, the code
// scripts/fig8_hull_matching.py used): on two clean hull frames 3 cm apart, the same detector
// budget gives the same keypoints, correspondences and homography inliers, exactly.
TEST(FrontendPair, Fig8FiguresEqualScorePairs) {
  TrajectoryOptions trajectory;
  trajectory.kind = "pass";
  trajectory.frames = 3;
  trajectory.altitude_m = 1.06;
  BuiltinSceneOptions scene;
  scene.scale = 0.5;
  const auto sequence = MakeBuiltinSequence("hull", scene, trajectory);
  FrontendOptions options;
  options.orb_features = options.sift_features = 2000;
  const FrontendFrame a = CleanFrame(*sequence, 0, options);
  const FrontendFrame b = CleanFrame(*sequence, 2, options);
  for (FeatureDetector d : {FeatureDetector::kOrb, FeatureDetector::kSift}) {
    SCOPED_TRACE(FeatureDetectorName(d));
    const FrontendPair r = EvaluateFrontendPair(options, d, a, b);
    FeatureMatchOptions match;
    match.detector = d;
    match.max_features = 2000;
    const PairMatchResult m = MatchFeatures(match, a.gray8, b.gray8, 255.0);
    std::printf("hull %s: keypoints %.0f matches %.0f homography inliers %.0f\n",
                FeatureDetectorName(d).c_str(), r.keypoints, r.matches, r.homography_inliers);
    EXPECT_GT(m.correspondences, 100);
    EXPECT_EQ(r.keypoints, m.keypoints_b);
    EXPECT_EQ(r.matches, m.correspondences);
    EXPECT_EQ(r.active, m.active ? 1.0 : 0.0);
    EXPECT_EQ(r.correspondences, m.correspondences);
    EXPECT_EQ(r.homography_inliers, m.inliers);
    // Asked for the homography part only (as a sweep with only Fig. 8 metrics asks): the same
    // figures, and the parts not asked for are NaN.
    const FrontendPair h = EvaluateFrontendPair(options, d, a, b, kFrontendHomography);
    EXPECT_EQ(h.matches, r.matches);
    EXPECT_EQ(h.homography_inliers, r.homography_inliers);
    EXPECT_TRUE(std::isnan(h.inliers) && std::isnan(h.pose_failed) && std::isnan(h.rpe_trans_m));
    const FrontendPair e = EvaluateFrontendPair(options, d, a, b, kFrontendEssential);
    EXPECT_EQ(e.inliers, r.inliers);
    EXPECT_EQ(e.rpe_rot_deg, r.rpe_rot_deg);
    EXPECT_TRUE(std::isnan(e.homography_inliers) && std::isnan(e.rpe_trans_m));
  }
}

}  // namespace
}  // namespace turbid
