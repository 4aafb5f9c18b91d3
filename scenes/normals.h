// Surface normals from a z-depth map, for sources that have none (RGB-D and stereo frames).
// Each pixel is back-projected through the camera; the tangent along x (and y) is the one-sided
// difference towards the neighbour whose depth is closer to the pixel's own, so a normal never
// straddles a depth discontinuity; differences whose relative depth jump exceeds
// max_relative_jump are rejected. Normals are unit length, in the camera frame, facing the camera
// (n . X < 0); NaN where the pixel or both neighbours along x or y are invalid.
#pragma once

#include <opencv2/core.hpp>

#include <string>

#include "scenes/scene.h"

namespace turbid {

struct NormalsFromDepthOptions {
  // Largest |z_neighbour - z| / z accepted as the same surface (dimensionless, > 0). 0.05 keeps
  // slopes up to ~85 degrees at 640 px / 60 degree field of view while cutting object edges.
  double max_relative_jump = 0.05;
  bool Check(std::string* why) const;
};

// depth_m: CV_32FC1, metres, NaN (or <= 0) = invalid. Returns CV_32FC3 normals.
cv::Mat NormalsFromDepth(const CameraIntrinsics& camera, const cv::Mat& depth_m,
                         const NormalsFromDepthOptions& options = {});

}  // namespace turbid
