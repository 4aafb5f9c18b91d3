// Depth maps of real RGB-D frames: the nearest-neighbour stretch onto the image grid, the erosion
// of the valid mask, and the intrinsics of frames without calibration. docs/formats.md.
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "scenes/scene_loader.h"

namespace turbid {

cv::Mat StretchNearest(const cv::Mat& depth, const cv::Size& size) {
  CV_Assert(depth.type() == CV_32FC1 && !depth.empty() && size.width > 0 && size.height > 0);
  // Column / row of the depth cell holding each output pixel's centre.
  auto table = [](int out_n, int in_n) {
    std::vector<int> index(static_cast<size_t>(out_n));
    for (int i = 0; i < out_n; ++i) {
      const long long k = (2LL * i + 1) * in_n / (2LL * out_n);  // floor((i + 0.5) in / out)
      index[static_cast<size_t>(i)] = static_cast<int>(std::min<long long>(k, in_n - 1));
    }
    return index;
  };
  const std::vector<int> xs = table(size.width, depth.cols);
  const std::vector<int> ys = table(size.height, depth.rows);
  cv::Mat out(size, CV_32FC1);
  for (int y = 0; y < size.height; ++y) {
    const float* src = depth.ptr<float>(ys[static_cast<size_t>(y)]);
    float* dst = out.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) dst[x] = src[xs[static_cast<size_t>(x)]];
  }
  return out;
}

cv::Mat ErodeValidDepth(const cv::Mat& depth_m, int radius_px) {
  CV_Assert(depth_m.type() == CV_32FC1 && radius_px >= 0);
  if (radius_px == 0) return depth_m;
  cv::Mat valid(depth_m.size(), CV_8UC1);
  for (int y = 0; y < depth_m.rows; ++y)
    for (int x = 0; x < depth_m.cols; ++x)
      valid.at<uchar>(y, x) = std::isfinite(depth_m.at<float>(y, x)) ? 255 : 0;
  cv::Mat eroded;
  // Outside the map counts as valid: the border is not a hole in the reconstruction.
  cv::erode(valid, eroded,
            cv::getStructuringElement(cv::MORPH_RECT, {2 * radius_px + 1, 2 * radius_px + 1}),
            {-1, -1}, 1, cv::BORDER_CONSTANT, cv::Scalar(255));
  cv::Mat out = depth_m.clone();
  out.setTo(std::numeric_limits<float>::quiet_NaN(), eroded == 0);
  return out;
}

CameraIntrinsics UnknownCamera(int width, int height) {
  return {1e9, 1e9, 0.5 * (width - 1), 0.5 * (height - 1), width, height};
}

CameraIntrinsics NominalCamera(int width, int height) {
  const double f = std::max(width, height);
  return {f, f, 0.5 * (width - 1), 0.5 * (height - 1), width, height};
}

}  // namespace turbid
