#include "scenes/pose.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace turbid {

Pose Pose::FromTranslationQuaternion(const cv::Vec3d& t, const cv::Vec4d& q_xyzw) {
  const double n = cv::norm(q_xyzw);
  if (!std::isfinite(n) || n < 1e-12 || !std::isfinite(cv::norm(t)))
    throw Error("pose: the quaternion must be finite and non-zero, the translation finite");
  const double x = q_xyzw[0] / n, y = q_xyzw[1] / n, z = q_xyzw[2] / n, w = q_xyzw[3] / n;
  Pose p;
  p.rotation = cv::Matx33d(1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                           2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                           2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y));
  p.position_m = t;
  return p;
}

// Shepperd's method: the largest of w, x, y, z is taken from the diagonal, the others from the
// off-diagonal sums (stable for every rotation).
cv::Vec4d Pose::Quaternion() const {
  const cv::Matx33d& r = rotation;
  const double trace = r(0, 0) + r(1, 1) + r(2, 2);
  cv::Vec4d q;
  if (trace >= std::max({r(0, 0), r(1, 1), r(2, 2)})) {
    const double s = 2 * std::sqrt(std::max(0.0, 1 + trace));
    q = {(r(2, 1) - r(1, 2)) / s, (r(0, 2) - r(2, 0)) / s, (r(1, 0) - r(0, 1)) / s, s / 4};
  } else if (r(0, 0) >= r(1, 1) && r(0, 0) >= r(2, 2)) {
    const double s = 2 * std::sqrt(std::max(0.0, 1 + r(0, 0) - r(1, 1) - r(2, 2)));
    q = {s / 4, (r(0, 1) + r(1, 0)) / s, (r(0, 2) + r(2, 0)) / s, (r(2, 1) - r(1, 2)) / s};
  } else if (r(1, 1) >= r(2, 2)) {
    const double s = 2 * std::sqrt(std::max(0.0, 1 + r(1, 1) - r(0, 0) - r(2, 2)));
    q = {(r(0, 1) + r(1, 0)) / s, s / 4, (r(1, 2) + r(2, 1)) / s, (r(0, 2) - r(2, 0)) / s};
  } else {
    const double s = 2 * std::sqrt(std::max(0.0, 1 + r(2, 2) - r(0, 0) - r(1, 1)));
    q = {(r(0, 2) + r(2, 0)) / s, (r(1, 2) + r(2, 1)) / s, s / 4, (r(1, 0) - r(0, 1)) / s};
  }
  q /= cv::norm(q);
  return q[3] < 0 ? -q : q;
}

double RotationAngleDeg(const cv::Matx33d& r) {
  const double c = std::clamp((r(0, 0) + r(1, 1) + r(2, 2) - 1) / 2, -1.0, 1.0);
  return std::acos(c) * 180.0 / 3.14159265358979323846;
}

}  // namespace turbid
