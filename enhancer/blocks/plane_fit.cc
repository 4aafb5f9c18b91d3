#include "enhancer/blocks/plane_fit.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "simulator/noise.h"

namespace turbid {
namespace {

Plane Oriented(cv::Vec3d n, double d) {
  const double len = cv::norm(n);
  n /= len;
  d /= len;
  if (d < 0) n = -n, d = -d;
  return Plane{n, d};
}

// Total least squares through the points (no checks).
Plane LeastSquares(const std::vector<cv::Vec3d>& pts, double* smallest_ratio) {
  cv::Vec3d c(0, 0, 0);
  for (const cv::Vec3d& p : pts) c += p;
  c /= static_cast<double>(pts.size());
  cv::Matx33d cov = cv::Matx33d::zeros();
  for (const cv::Vec3d& p : pts) {
    const cv::Vec3d q = p - c;
    cov += q * q.t();
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(cv::Mat(cov), w, u, vt);
  const cv::Vec3d n(vt.at<double>(2, 0), vt.at<double>(2, 1), vt.at<double>(2, 2));
  if (smallest_ratio) *smallest_ratio = w.at<double>(1) / std::max(w.at<double>(0), 1e-300);
  return Oriented(n, -n.dot(c));
}

}  // namespace

Plane FitPlaneToPoints(const std::vector<cv::Vec3d>& pts) {
  if (pts.size() < 3) {
    throw Error("plane fit: need at least 3 points, got " + std::to_string(pts.size()));
  }
  double scale = 0;
  for (const cv::Vec3d& p : pts) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      throw Error("plane fit: non-finite point");
    }
    scale = std::max(scale, cv::norm(p));
  }
  Plane plane;
  if (pts.size() == 3) {
    const cv::Vec3d n = (pts[1] - pts[0]).cross(pts[2] - pts[0]);
    if (cv::norm(n) <= 1e-9 * std::max(scale * scale, 1e-12)) {
      throw Error("plane fit: the 3 points are collinear");
    }
    plane = Oriented(n, -n.dot(pts[0]));
  } else {
    double ratio = 0;
    plane = LeastSquares(pts, &ratio);
    if (ratio < 1e-12) throw Error("plane fit: the points are collinear");
  }
  if (plane.offset_m <= 1e-9 * std::max(scale, 1e-9)) {
    throw Error("plane fit: the plane passes through the camera centre");
  }
  return plane;
}

bool PlaneFitOptions::Check(std::string* why) const {
  if (iterations < 1 || iterations > 100000) {
    *why = "iterations must be in [1, 100000]";
    return false;
  }
  if (!std::isfinite(inlier_threshold_m) || inlier_threshold_m <= 0) {
    *why = "inlier_threshold_m must be > 0";
    return false;
  }
  if (stride_px < 1 || stride_px > 64) {
    *why = "stride_px must be in [1, 64]";
    return false;
  }
  if (!(min_inlier_fraction >= 0 && min_inlier_fraction <= 1)) {
    *why = "min_inlier_fraction must be in [0, 1]";
    return false;
  }
  return true;
}

PlaneFitResult FitPlaneToDepth(const PlaneFitOptions& options, const CameraIntrinsics& camera,
                               const cv::Mat& depth_m) {
  ThrowIfInvalid(options, "plane fit");
  if (depth_m.empty() || depth_m.type() != CV_32FC1) {
    throw Error("plane fit: depth must be a non-empty float32 one-channel map");
  }
  std::vector<cv::Vec3d> pts;
  for (int y = 0; y < depth_m.rows; y += options.stride_px) {
    const float* z = depth_m.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; x += options.stride_px) {
      if (std::isfinite(z[x]) && z[x] > 0) pts.push_back(camera.BackProject(x, y, z[x]));
    }
  }
  if (pts.size() < 3) throw Error("plane fit: fewer than 3 valid depth samples");
  const uint64_t key = RandomKey(options.seed, 0x706c616e65ULL);
  const size_t n = pts.size();
  int best = -1;
  Plane best_plane;
  uint64_t counter = 0;
  for (int it = 0; it < options.iterations; ++it) {
    size_t i[3];
    for (size_t& v : i) v = static_cast<size_t>(RandomUniform(key, counter++) * n) % n;
    const cv::Vec3d nn = (pts[i[1]] - pts[i[0]]).cross(pts[i[2]] - pts[i[0]]);
    if (cv::norm(nn) < 1e-12) continue;
    const Plane p = Oriented(nn, -nn.dot(pts[i[0]]));
    int count = 0;
    for (const cv::Vec3d& q : pts) {
      if (std::fabs(p.normal.dot(q) + p.offset_m) <= options.inlier_threshold_m) ++count;
    }
    if (count > best) best = count, best_plane = p;
  }
  PlaneFitResult result;
  result.samples = static_cast<int>(n);
  if (best < 3 || best < options.min_inlier_fraction * n) {
    throw Error("plane fit: no plane found in the depth map (best inlier share " +
                std::to_string(std::max(best, 0) / static_cast<double>(n)) + ")");
  }
  // Refit on the inliers, then recount.
  std::vector<cv::Vec3d> inl;
  for (const cv::Vec3d& q : pts) {
    if (std::fabs(best_plane.normal.dot(q) + best_plane.offset_m) <= options.inlier_threshold_m) {
      inl.push_back(q);
    }
  }
  result.plane = LeastSquares(inl, nullptr);
  double ss = 0;
  int count = 0;
  for (const cv::Vec3d& q : pts) {
    const double d = result.plane.normal.dot(q) + result.plane.offset_m;
    if (std::fabs(d) <= options.inlier_threshold_m) ss += d * d, ++count;
  }
  result.inliers = count;
  result.rms_m = count > 0 ? std::sqrt(ss / count) : 0.0;
  return result;
}

cv::Mat DepthFromPlane(const Plane& plane, const CameraIntrinsics& camera) {
  cv::Mat z(camera.height, camera.width, CV_32F);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int y = 0; y < camera.height; ++y) {
    float* out = z.ptr<float>(y);
    for (int x = 0; x < camera.width; ++x) {
      // n.(z ray) + d = 0 -> z = -d / n.ray (ray has z component 1).
      const double denom = plane.normal.dot(camera.Ray(x, y));
      const double depth = denom < -1e-12 ? -plane.offset_m / denom : nan;
      out[x] = static_cast<float>(depth > 0 ? depth : nan);
    }
  }
  return z;
}

}  // namespace turbid
