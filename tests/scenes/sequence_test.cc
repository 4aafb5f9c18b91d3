// Sequences (scenes/sequence.h), trajectories (scenes/trajectory.h) and poses (scenes/pose.h).
#include "scenes/sequence.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "scenes/image_io.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

constexpr double kPi = 3.14159265358979323846;

double MaxAbs(const cv::Matx33d& a, const cv::Matx33d& b) { return cv::norm(a - b, cv::NORM_INF); }

TEST(Pose, QuaternionRoundTripAndComposition) {
  // 90 degrees about z: x -> y.
  const Pose p =
      Pose::FromTranslationQuaternion({1, 2, 3}, {0, 0, std::sin(kPi / 4), std::cos(kPi / 4)});
  EXPECT_LT(cv::norm(p.rotation * cv::Vec3d(1, 0, 0) - cv::Vec3d(0, 1, 0)), 1e-12);
  EXPECT_NEAR(RotationAngleDeg(p.rotation), 90.0, 1e-9);
  const cv::Vec4d q = p.Quaternion();
  EXPECT_NEAR(q[2], std::sin(kPi / 4), 1e-12);
  EXPECT_NEAR(q[3], std::cos(kPi / 4), 1e-12);
  // Every branch of Shepperd's method: rotations of 170 degrees about each axis.
  for (const cv::Vec3d& axis : {cv::Vec3d(1, 0, 0), cv::Vec3d(0, 1, 0), cv::Vec3d(0, 0, 1),
                                cv::Vec3d(1, 1, 1) / std::sqrt(3.0)}) {
    const double a = 170 * kPi / 180;
    const cv::Vec4d qa(axis[0] * std::sin(a / 2), axis[1] * std::sin(a / 2),
                       axis[2] * std::sin(a / 2), std::cos(a / 2));
    const Pose r = Pose::FromTranslationQuaternion({0, 0, 0}, qa);
    const Pose back = Pose::FromTranslationQuaternion({0, 0, 0}, r.Quaternion());
    EXPECT_LT(MaxAbs(r.rotation, back.rotation), 1e-12) << axis;
  }
  const Pose identity = p.Inverse().Compose(p);
  EXPECT_LT(MaxAbs(identity.rotation, cv::Matx33d::eye()), 1e-12);
  EXPECT_LT(cv::norm(identity.position_m), 1e-12);
  EXPECT_THROW(Pose::FromTranslationQuaternion({0, 0, 0}, {0, 0, 0, 0}), Error);
}

TEST(Trajectory, SurveyKeepsItsAltitudeAndSpeed) {
  TrajectoryOptions t;
  t.frames = 120;
  t.lane_length_m = 1.0;
  const std::vector<Pose> poses = BuiltinTrajectory("seafloor", t);
  ASSERT_EQ(poses.size(), 120u);
  // The seabed plane in the world (scenes/builtin_seafloor.cc): through (0, 0, 2.5), normal
  // towards the camera (0.10, -0.80, -0.60) normalised; the camera starts at the origin.
  const cv::Vec3d n = cv::normalize(cv::Vec3d(0.10, -0.80, -0.60));
  const double altitude = n.dot(cv::Vec3d(0, 0, 0) - cv::Vec3d(0, 0, 2.5));
  double max_lateral = 0;
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(n.dot(poses[i].position_m - cv::Vec3d(0, 0, 2.5)), altitude, 1e-9) << i;
    EXPECT_LT(MaxAbs(poses[i].rotation, cv::Matx33d::eye()), 1e-15);
    if (i > 0) {
      // Each step is speed / rate along the path (0.03 m; a lane's end cuts a corner).
      const double step = cv::norm(poses[i].position_m - poses[i - 1].position_m);
      EXPECT_LE(step, 0.03 + 1e-12) << i;
      EXPECT_GE(step, 0.03 / std::sqrt(2.0) - 1e-12) << i;
    }
    max_lateral = std::max(max_lateral, cv::norm(poses[i].position_m));
  }
  // 120 frames * 0.03 m = 3.6 m of path: more than three 1 m lanes, so it turned.
  EXPECT_GT(max_lateral, 1.0);
}

TEST(Trajectory, PassHoverAndOptions) {
  TrajectoryOptions t;
  t.kind = "pass";
  t.frames = 10;
  t.altitude_m = 1.0;
  const std::vector<Pose> pass = BuiltinTrajectory("hull", t);
  const cv::Vec3d d = pass[9].position_m - pass[0].position_m;
  EXPECT_NEAR(cv::norm(d), 9 * 0.03, 1e-12);
  EXPECT_NEAR(cv::norm(pass[1].position_m - pass[0].position_m) * 9, cv::norm(d), 1e-12);
  t.kind = "hover";
  const std::vector<Pose> hover = BuiltinTrajectory("room", t);
  const Pose home = BuiltinScenePose("room");
  for (const Pose& p : hover) {
    const cv::Vec3d off = p.position_m - home.position_m;
    for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(off[k]), t.hover_amplitude_m + 1e-12);
    EXPECT_LE(RotationAngleDeg(home.rotation.t() * p.rotation), 1.0 * std::sqrt(3.0) + 1e-9);
  }
  TrajectoryOptions bad;
  bad.kind = "orbit";
  EXPECT_THROW(BuiltinTrajectory("room", bad), Error);
  TrajectoryOptions read;
  TrajectoryFields().Read(nlohmann::json{{"kind", "pass"}, {"frames", 5}}, &read, "test");
  EXPECT_EQ(read.frames, 5);
  EXPECT_THROW(TrajectoryFields().Read(nlohmann::json{{"frames", 2.5}}, &read, "test"), Error);
}

// Median |z predicted - z seen| (or, with `colour`, of the albedo's first channel) when frame a's
// pixels are moved into frame b with the relative pose b_from_a (bilinear lookup in b; points
// leaving the image are skipped).
double MedianReprojectionError(const Scene& a, const Scene& b, const Pose& b_from_a,
                               bool colour = false) {
  std::vector<double> errors;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      const float z = a.depth_m.at<float>(y, x);
      if (!std::isfinite(z)) continue;
      const cv::Vec3d p = b_from_a.Apply(a.camera.BackProject(x, y, z));
      const double u = b.camera.fx * p[0] / p[2] + b.camera.cx;
      const double v = b.camera.fy * p[1] / p[2] + b.camera.cy;
      if (!(u >= 1 && v >= 1 && u < b.width() - 2 && v < b.height() - 2)) continue;
      const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
      const double fx = u - x0, fy = v - y0;
      cv::Mat d = b.depth_m;
      if (colour) cv::extractChannel(b.image, d, 0);
      const double seen =
          (1 - fy) * ((1 - fx) * d.at<float>(y0, x0) + fx * d.at<float>(y0, x0 + 1)) +
          fy * ((1 - fx) * d.at<float>(y0 + 1, x0) + fx * d.at<float>(y0 + 1, x0 + 1));
      const double expected = colour ? a.image.at<cv::Vec3f>(y, x)[0] : p[2];
      if (std::isfinite(seen)) errors.push_back(std::abs(seen - expected));
    }
  }
  EXPECT_GT(errors.size(), 1000u);
  if (errors.empty()) return 0;
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

TEST(Sequence, BuiltinFramesAgreeWithTheirPoses) {
  BuiltinSceneOptions o;
  o.scale = 0.25;
  o.supersampling = 4;
  TrajectoryOptions t;
  t.frames = 6;
  const auto seq = MakeBuiltinSequence("seafloor", o, t);
  ASSERT_EQ(seq->size(), 6);
  const Scene a = seq->Frame(0), b = seq->Frame(5);
  EXPECT_EQ(b.name, "seafloor_survey#5");
  EXPECT_NEAR(seq->timestamp_s(5), 0.5, 1e-12);
  // With the true relative pose the geometry of frame 0 lands on frame 5's depth (exact ray
  // casting; what is left is the bilinear lookup on a tilted plane, well under a millimetre).
  const Pose b_from_a = Relative(seq->pose(5), seq->pose(0));
  const double depth_error = MedianReprojectionError(a, b, b_from_a);
  EXPECT_LT(depth_error, 1e-3) << depth_error;
  // A camera gliding parallel to a plane sees the same depth map: the texture tells the motion.
  // Frame 0's albedo lands on frame 5's with the pose, not without it (15 cm of motion).
  const double colour_with = MedianReprojectionError(a, b, b_from_a, true);
  const double colour_without = MedianReprojectionError(a, b, Pose{}, true);
  EXPECT_LT(colour_with * 3, colour_without) << colour_with << " vs " << colour_without;
  // Frame 0 is the scene itself.
  const Scene home = MakeBuiltinScene("seafloor", o);
  EXPECT_EQ(cv::norm(a.image, home.image, cv::NORM_INF), 0.0);
}

TEST(Sequence, TumFolderRoundTrip) {
  testing::TempDir dir;
  BuiltinSceneOptions o;
  o.scale = 0.1;
  o.supersampling = 1;
  TrajectoryOptions t;
  t.kind = "hover";
  t.frames = 3;
  const auto seq = MakeBuiltinSequence("room", o, t);
  WriteTumSequence(*seq, dir.path(), false);
  EXPECT_THROW(WriteTumSequence(*seq, dir.path(), false), Error);  // no silent overwrite
  const auto back = LoadRgbdSequence(dir.File("sequence.json"));
  ASSERT_EQ(back->size(), 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(MaxAbs(back->pose(i).rotation, seq->pose(i).rotation), 1e-12) << i;
    EXPECT_LT(cv::norm(back->pose(i).position_m - seq->pose(i).position_m), 1e-12) << i;
    const Scene f = seq->Frame(i), g = back->Frame(i);
    // Colour: one 8-bit sRGB level; depth: half a 1/5000 m unit.
    EXPECT_LE(cv::norm(LinearToSrgb(f.image), LinearToSrgb(g.image), cv::NORM_INF),
              0.5 / 255 + 1e-6);
    cv::Mat diff;
    cv::absdiff(f.depth_m, g.depth_m, diff);
    double worst = 0;
    cv::minMaxLoc(diff, nullptr, &worst, nullptr, nullptr, f.depth_m == f.depth_m);
    EXPECT_LE(worst, 0.5 / 5000 + 1e-6);
    EXPECT_EQ(g.camera.fx, f.camera.fx);
  }
}

TEST(Sequence, IclNuimFramesWithGroundTruth) {
  TURBID_REQUIRE_DATA(data);
  testing::TempDir dir;
  const std::string icl = data + "/icl_nuim_lr_kt1";
  const nlohmann::json spec = {{"type", "rgbd_sequence"},
                               {"associations", icl + "/associations.txt"},
                               {"groundtruth", icl + "/livingRoom1.gt.freiburg"},
                               {"camera", "icl_nuim"},
                               {"frames", 4},
                               {"time_offset_s", 1}};
  const auto seq = LoadRgbdSequence(dir.Write("icl.json", spec.dump()));
  ASSERT_EQ(seq->size(), 4);
  // Ground-truth line "1 0 0 -2.25 0 0 0 1" is frame 0 (ICL-NUIM's ids start at 1).
  EXPECT_LT(cv::norm(seq->pose(0).position_m - cv::Vec3d(0, 0, -2.25)), 1e-12);
  EXPECT_LT(MaxAbs(seq->pose(0).rotation, cv::Matx33d::eye()), 1e-12);
  EXPECT_NEAR(seq->pose(1).position_m[2], -2.25091, 1e-9);
  const Scene f = seq->Frame(3);
  EXPECT_EQ(f.width(), 640);
  EXPECT_EQ(f.camera.fy, -480.0);
  EXPECT_EQ(f.name, "icl#3");
}

TEST(Sequence, BadFilesAreOneLineErrors) {
  testing::TempDir dir;
  dir.Write("a.txt", "0 rgb/0.png 0 depth/0.png\n1 rgb/1.png\n");
  dir.Write("gt.txt", "0 0 0 0 0 0 0 1\n");
  const nlohmann::json spec = {{"type", "rgbd_sequence"},
                               {"associations", "a.txt"},
                               {"groundtruth", "gt.txt"},
                               {"camera", "tum_fr1"}};
  auto message = [&](const nlohmann::json& j) -> std::string {
    try {
      LoadRgbdSequence(dir.Write("s.json", j.dump()));
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message(spec).find("a.txt: line 2"), std::string::npos) << message(spec);
  dir.Write("a.txt", "0 rgb/0.png 0 depth/0.png\n5 rgb/1.png 5 depth/1.png\n");
  EXPECT_NE(message(spec).find("no pose within 0.02 s"), std::string::npos) << message(spec);
  nlohmann::json unknown = spec;
  unknown["assocations"] = "a.txt";
  EXPECT_NE(message(unknown).find("assocations"), std::string::npos);
  nlohmann::json camera = spec;
  camera["camera"] = "no_such_camera";
  EXPECT_NE(message(camera).find("s.json"), std::string::npos) << message(camera);
  dir.Write("gt.txt", "0 0 0 0 0 0 0 0\n");
  EXPECT_NE(message(spec).find("gt.txt: line 1"), std::string::npos) << message(spec);
}

}  // namespace
}  // namespace turbid
