#include "scenes/normals.h"

#include <opencv2/core/utility.hpp>

#include <cmath>
#include <limits>

#include "core/error.h"

namespace turbid {

bool NormalsFromDepthOptions::Check(std::string* why) const {
  if (!std::isfinite(max_relative_jump) || max_relative_jump <= 0.0) {
    if (why) *why = "max_relative_jump must be finite and > 0";
    return false;
  }
  return true;
}

namespace {

bool Valid(float z) { return std::isfinite(z) && z > 0.0f; }

// Tangent along one image axis at a pixel: the one-sided difference to the neighbour with the
// smaller depth jump, if any is accepted. Returns false when neither side qualifies.
bool Tangent(const cv::Vec3d& centre, float z, float z_prev, const cv::Vec3d& p_prev, float z_next,
             const cv::Vec3d& p_next, double max_jump, cv::Vec3d* tangent) {
  const double jump_prev = Valid(z_prev) ? std::abs(double(z_prev) - z) : HUGE_VAL;
  const double jump_next = Valid(z_next) ? std::abs(double(z_next) - z) : HUGE_VAL;
  const double limit = max_jump * z;
  if (jump_next <= jump_prev && jump_next <= limit) {
    *tangent = p_next - centre;
    return true;
  }
  if (jump_prev <= limit) {
    *tangent = centre - p_prev;
    return true;
  }
  return false;
}

}  // namespace

cv::Mat NormalsFromDepth(const CameraIntrinsics& camera, const cv::Mat& depth_m,
                         const NormalsFromDepthOptions& options) {
  ThrowIfInvalid(options, "normals from depth");
  ThrowIfInvalid(camera, "normals from depth: camera");
  if (depth_m.type() != CV_32FC1) throw Error("normals from depth", "depth must be CV_32FC1");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat normals(depth_m.size(), CV_32FC3, cv::Scalar::all(nan));
  const int w = depth_m.cols, h = depth_m.rows;
  auto point = [&](int x, int y) { return camera.BackProject(x, y, depth_m.at<float>(y, x)); };
  auto depth = [&](int x, int y) {
    return (x < 0 || y < 0 || x >= w || y >= h) ? nan : depth_m.at<float>(y, x);
  };
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      for (int x = 0; x < w; ++x) {
        const float z = depth_m.at<float>(y, x);
        if (!Valid(z)) continue;
        const cv::Vec3d centre = point(x, y);
        const float zl = depth(x - 1, y), zr = depth(x + 1, y);
        const float zu = depth(x, y - 1), zd = depth(x, y + 1);
        cv::Vec3d tx, ty;
        if (!Tangent(centre, z, zl, Valid(zl) ? point(x - 1, y) : cv::Vec3d(), zr,
                     Valid(zr) ? point(x + 1, y) : cv::Vec3d(), options.max_relative_jump, &tx) ||
            !Tangent(centre, z, zu, Valid(zu) ? point(x, y - 1) : cv::Vec3d(), zd,
                     Valid(zd) ? point(x, y + 1) : cv::Vec3d(), options.max_relative_jump, &ty)) {
          continue;
        }
        cv::Vec3d n = tx.cross(ty);
        const double length = cv::norm(n);
        if (!(length > 0.0)) continue;
        n /= length;
        if (n.dot(centre) > 0.0) n = -n;
        normals.at<cv::Vec3f>(y, x) = cv::Vec3f(n);
      }
    }
  });
  return normals;
}

}  // namespace turbid
