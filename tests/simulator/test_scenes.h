// Small synthetic scenes with known geometry for the simulator tests.
#pragma once

#include <cmath>
#include <opencv2/core.hpp>

#include "scenes/scene.h"

namespace turbid::testing {

// A fronto-parallel plane at z = depth_m facing the camera, with a deterministic texture in
// [0.05, 0.95]. fx = fy = focal_px, principal point at the image centre.
inline Scene MakePlaneScene(int width, int height, double depth_m, int channels = 3,
                            double focal_px = 100.0) {
  Scene scene;
  scene.name = "plane";
  scene.camera = {focal_px, focal_px, (width - 1) / 2.0, (height - 1) / 2.0, width, height};
  scene.image = cv::Mat(height, width, CV_32FC(channels));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < channels; ++c)
        scene.image.ptr<float>(y)[x * channels + c] =
            static_cast<float>(0.5 + 0.45 * std::sin(0.7 * x + 1.3 * y + 2.1 * c));
  scene.depth_m = cv::Mat(height, width, CV_32FC1, cv::Scalar(depth_m));
  scene.normals = cv::Mat(height, width, CV_32FC3, cv::Scalar(0, 0, -1));
  scene.dominant_plane = Plane{{0, 0, -1}, depth_m};
  return scene;
}

}  // namespace turbid::testing
