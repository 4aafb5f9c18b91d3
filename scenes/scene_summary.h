// A scene's vital statistics as JSON (what `turbid scene` writes as summary.json and prints), and
// the reverse direction for a scene's own geometry: a loadable scene file for written outputs.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <string>

#include "scenes/scene.h"

namespace turbid {

struct DepthStats {
  int valid_pixels = 0;         // finite, > 0
  double valid_fraction = 0.0;  // valid_pixels / all pixels, in [0, 1]
  double min_m = 0.0;           // over valid pixels (0 when none)
  double median_m = 0.0;
  double max_m = 0.0;
};
DepthStats ComputeDepthStats(const cv::Mat& depth_m);

nlohmann::json CameraToJson(const CameraIntrinsics& camera);  // {fx, fy, cx, cy, width, height}
nlohmann::json PlaneToJson(const Plane& plane);               // {normal: [x, y, z], offset_m}

// {name, width, height, channels, camera, depth: {...DepthStats}, normals_valid_fraction,
//  image: {min, max, mean}, dominant_plane (or null), dvl_points_in_camera, input_hashes}.
nlohmann::json SceneSummaryJson(const Scene& scene);

}  // namespace turbid
