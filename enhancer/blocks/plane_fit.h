// Dominant-plane fit for plane-induced dehazing (paper §III-A.3: the plane from the four DVL beam
// hits gives the scene depth d(x) with the camera calibration). From points: exactly 3 define the
// plane; more give the total-least-squares plane (smallest singular vector of the centred points).
// From depth: RANSAC (Fischler & Bolles, CACM 24(6) 1981) over back-projected pixels, then a
// least-squares refit on the inliers. Planes follow scenes/scene.h: n.X + d = 0, |n| = 1, oriented
// so the camera is in front (d > 0).
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "scenes/scene.h"

namespace turbid {

// Throws Error for fewer than 3 points, non-finite points, (near-)collinear points, or a plane
// through the camera centre.
Plane FitPlaneToPoints(const std::vector<cv::Vec3d>& points_in_camera_m);

struct PlaneFitOptions {
  int iterations = 200;               // RANSAC hypotheses, in [1, 100000]
  double inlier_threshold_m = 0.02;   // point-to-plane distance for an inlier, metres, > 0
  int stride_px = 4;                  // use every stride-th pixel in x and y, in [1, 64]
  double min_inlier_fraction = 0.2;   // fail below this share of valid samples, in [0, 1]
  uint64_t seed = 1;                  // hypothesis sampling (deterministic)
  bool Check(std::string* why) const;
};

struct PlaneFitResult {
  Plane plane;
  int samples = 0;   // valid depth samples considered
  int inliers = 0;   // inliers of the final plane
  double rms_m = 0;  // RMS point-to-plane distance of the inliers
};

// Throws Error when depth has fewer than 3 valid samples or no plane reaches min_inlier_fraction.
PlaneFitResult FitPlaneToDepth(const PlaneFitOptions& options, const CameraIntrinsics& camera,
                               const cv::Mat& depth_m);

// z-depth of the plane along every pixel's ray (CV_32FC1, rows x cols of `camera`), NaN where the
// ray does not meet the plane in front of the camera.
cv::Mat DepthFromPlane(const Plane& plane, const CameraIntrinsics& camera);

}  // namespace turbid
