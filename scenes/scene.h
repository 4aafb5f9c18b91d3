// The scene: what every other module consumes. A pinhole camera, the clean image rho(x), z-depth,
// surface normals and optional geometry (dominant plane, DVL beam hits). See docs/formats.md.
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace turbid {

// Pinhole intrinsics in pixels. fy may be negative (ICL-NUIM stores fy = -480 because its image y
// axis points up); the sign is kept so that back-projection reproduces the dataset's geometry.
struct CameraIntrinsics {
  double fx = 0.0;   // focal length along x, pixels (non-zero)
  double fy = 0.0;   // focal length along y, pixels (non-zero; sign carries the y-axis direction)
  double cx = 0.0;   // principal point x, pixels
  double cy = 0.0;   // principal point y, pixels
  int width = 0;     // image width, pixels (> 0)
  int height = 0;    // image height, pixels (> 0)

  bool Check(std::string* why) const;
  // Ray direction K^-1 [u v 1]^T (z component 1, not normalised) for pixel centre (u, v).
  cv::Vec3d Ray(double u, double v) const {
    return {(u - cx) / fx, (v - cy) / fy, 1.0};
  }
  // Camera-frame point seen at pixel (u, v) with z-depth z.
  cv::Vec3d BackProject(double u, double v, double z_m) const { return Ray(u, v) * z_m; }
};

// Plane n . X + d = 0 in the camera frame, |n| = 1, oriented towards the camera (d > 0 when the
// camera is in front of it).
struct Plane {
  cv::Vec3d normal{0.0, 0.0, -1.0};
  double offset_m = 0.0;
};

struct Scene {
  std::string name;                 // short identifier used in tables and file names
  CameraIntrinsics camera;
  cv::Mat image;                    // rho(x): CV_32FC1 or CV_32FC3 (BGR), linear, in [0, 1]
  cv::Mat depth_m;                  // CV_32FC1 z-depth in metres, NaN where invalid
  cv::Mat normals;                  // CV_32FC3 unit normals (camera frame, facing the camera), NaN where unknown
  std::optional<Plane> dominant_plane;          // when the scene knows it exactly
  std::vector<cv::Vec3d> dvl_points_in_camera;  // DVL-style beam hits on the surface, metres
  std::map<std::string, std::string> input_hashes;  // input file path -> sha256 (empty for built-ins)
  // The scene file said "camera": "unknown": `camera` holds nominal intrinsics under which range
  // = depth (scenes/scene_loader.h UnknownCamera); summaries say so.
  bool camera_unknown = false;

  int width() const { return image.cols; }
  int height() const { return image.rows; }
  int channels() const { return image.channels(); }
  // Throws turbid::Error when sizes, types or values are inconsistent.
  void Validate() const;
  // Validate without the pass over the depth values (sizes, types and the camera only), for
  // callers that check the depth in a pass of their own and call Validate when it finds a bad
  // value (the renderer's range pass).
  void ValidateLayout() const;
};

// Range along the viewing ray r = z * |K^-1 [u v 1]| (metres); NaN where depth is NaN.
cv::Mat RangeFromDepth(const CameraIntrinsics& camera, const cv::Mat& depth_m);

// RangeFromDepth one row at a time (the same values): dx = RangeColumnTable(camera, cols), the
// columns' (x - cx) / fx; RangeFromDepthRow writes row y of the range (dx.size() values) from row
// y of the depth, z.
std::vector<double> RangeColumnTable(const CameraIntrinsics& camera, int cols);
void RangeFromDepthRow(const CameraIntrinsics& camera, const std::vector<double>& dx,
                       const float* z, int y, float* r);

}  // namespace turbid
