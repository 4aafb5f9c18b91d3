// Rigid camera poses for sequences (docs/formats.md "Sequences"): camera-to-world, metres,
// X_world = rotation X_camera + position_m. TUM RGB-D's ground-truth lines (tx ty tz qx qy qz qw)
// are this pose with the rotation as a unit quaternion.
#pragma once

#include <array>
#include <opencv2/core.hpp>

namespace turbid {

struct Pose {
  cv::Matx33d rotation = cv::Matx33d::eye();  // world_from_camera
  cv::Vec3d position_m{0.0, 0.0, 0.0};        // camera centre in the world, metres

  cv::Vec3d Apply(const cv::Vec3d& x) const { return rotation * x + position_m; }
  Pose Inverse() const {
    const cv::Matx33d rt = rotation.t();
    return {rt, -(rt * position_m)};
  }
  // (this o b)(x) = this(b(x)): e.g. world_from_a.Compose(a_from_b) = world_from_b.
  Pose Compose(const Pose& b) const {
    return {rotation * b.rotation, rotation * b.position_m + position_m};
  }
  // From a TUM line's translation and quaternion (x, y, z, w; normalised here). Throws Error for
  // a zero or non-finite quaternion.
  static Pose FromTranslationQuaternion(const cv::Vec3d& t, const cv::Vec4d& q_xyzw);
  // The rotation as a unit quaternion (x, y, z, w) with w >= 0.
  cv::Vec4d Quaternion() const;
};

// The pose of b in a's camera frame: a_from_b = world_from_a^-1 o world_from_b.
inline Pose Relative(const Pose& world_from_a, const Pose& world_from_b) {
  return world_from_a.Inverse().Compose(world_from_b);
}

// Angle of a rotation matrix, degrees, in [0, 180].
double RotationAngleDeg(const cv::Matx33d& rotation);

}  // namespace turbid
