#include "scenes/scene_summary.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace turbid {

DepthStats ComputeDepthStats(const cv::Mat& depth_m) {
  CV_Assert(depth_m.type() == CV_32FC1);
  std::vector<float> valid;
  valid.reserve(depth_m.total());
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* row = depth_m.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; ++x)
      if (std::isfinite(row[x]) && row[x] > 0.0f) valid.push_back(row[x]);
  }
  DepthStats stats;
  stats.valid_pixels = static_cast<int>(valid.size());
  stats.valid_fraction = depth_m.total() == 0 ? 0.0 : double(valid.size()) / depth_m.total();
  if (valid.empty()) return stats;
  const auto [lo, hi] = std::minmax_element(valid.begin(), valid.end());
  stats.min_m = *lo;
  stats.max_m = *hi;
  auto middle = valid.begin() + valid.size() / 2;
  std::nth_element(valid.begin(), middle, valid.end());
  stats.median_m = *middle;
  return stats;
}

nlohmann::json CameraToJson(const CameraIntrinsics& camera) {
  return {{"fx", camera.fx},       {"fy", camera.fy},         {"cx", camera.cx},
          {"cy", camera.cy},       {"width", camera.width},   {"height", camera.height}};
}

nlohmann::json PlaneToJson(const Plane& plane) {
  return {{"normal", {plane.normal[0], plane.normal[1], plane.normal[2]}},
          {"offset_m", plane.offset_m}};
}

nlohmann::json SceneSummaryJson(const Scene& scene) {
  nlohmann::json out;
  out["name"] = scene.name;
  out["width"] = scene.width();
  out["height"] = scene.height();
  out["channels"] = scene.channels();
  out["camera"] = CameraToJson(scene.camera);
  if (scene.camera_unknown) {
    out["camera"]["unknown"] = true;
    out["camera"]["note"] =
        "no intrinsics (\"camera\": \"unknown\"): range = depth; normals from a nominal "
        "camera with fx = fy = max(width, height)";
  }
  const DepthStats depth = ComputeDepthStats(scene.depth_m);
  out["depth"] = {{"valid_pixels", depth.valid_pixels}, {"valid_fraction", depth.valid_fraction},
                  {"min_m", depth.min_m},               {"median_m", depth.median_m},
                  {"max_m", depth.max_m}};
  int normals_valid = 0;
  for (int y = 0; y < scene.normals.rows; ++y)
    for (int x = 0; x < scene.normals.cols; ++x)
      if (std::isfinite(scene.normals.at<cv::Vec3f>(y, x)[0])) ++normals_valid;
  out["normals_valid_fraction"] =
      scene.normals.empty() ? 0.0 : double(normals_valid) / scene.normals.total();
  double lo = 0, hi = 0;
  cv::minMaxLoc(scene.image.reshape(1), &lo, &hi);
  const cv::Scalar mean = cv::mean(scene.image);
  double mean_all = 0;
  for (int c = 0; c < scene.channels(); ++c) mean_all += mean[c] / scene.channels();
  out["image"] = {{"min", lo}, {"max", hi}, {"mean", mean_all}, {"encoding", "linear"}};
  out["dominant_plane"] = scene.dominant_plane ? PlaneToJson(*scene.dominant_plane) : nlohmann::json();
  nlohmann::json dvl = nlohmann::json::array();
  for (const cv::Vec3d& p : scene.dvl_points_in_camera) dvl.push_back({p[0], p[1], p[2]});
  out["dvl_points_in_camera"] = dvl;
  out["input_hashes"] = scene.input_hashes;
  return out;
}

}  // namespace turbid
