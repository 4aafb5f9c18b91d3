// NYU Depth v2 labelled-file reader (scenes/nyu_depth_v2.h). The HDF5 calls live in the plugin
// turbid_hdf5.so (scenes/plugin/hdf5_plugin.cc), opened on the first read so that the library and
// `turbid` do not link libhdf5; this file checks options and paths and builds the frame.
#include "scenes/nyu_depth_v2.h"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <sstream>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/input_file.h"
#include "scenes/plugin/hdf5_plugin.h"
#include "scenes/plugin_loader.h"

namespace turbid {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

std::string OutOfRange(int index, int count) {
  return "frame " + std::to_string(index) + " out of range (the file holds " +
         std::to_string(count) + " frames, 0.." + std::to_string(count - 1) + ")";
}

// Checks that `path` is an existing regular file, then has the plugin check its layout and, when
// 0 <= `index` < N, read frame `index` into `codes` and `depth` (layout:
// scenes/plugin/hdf5_plugin.h). Returns the frame count N.
int ReadWithPlugin(const std::string& path, const NyuFrameOptions& options, int index,
                   uint8_t* codes, float* depth) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(path, "file not found");
  CheckInputFile(path);
  std::string why;
  auto* read = reinterpret_cast<TurbidHdf5ReadNyuFn*>(
      plugins::LoadPluginSymbol(kTurbidHdf5PluginFileName, kTurbidHdf5ReadNyuSymbol, "HDF5", &why));
  if (!read) throw Error(path, "reading NYU Depth v2 .mat files needs HDF5, but " + why);
  int count = 0;
  std::string error;
  if (read(path.c_str(), options.depth_dataset.c_str(), index, &count, codes, depth, &error) != 0)
    throw Error(path, error);
  return count;
}

}  // namespace

CameraIntrinsics NyuKinectRgbCamera() {
  return {5.1885790117450188e+02,
          5.1946961112127485e+02,
          3.2558244941119034e+02,
          2.5373616633400465e+02,
          kWidth,
          kHeight};
}

cv::Rect NyuBorderCropBox() { return cv::Rect(40, 44, 561, 427); }

bool NyuFrameOptions::Check(std::string* why) const {
  if (depth_dataset != "depths" && depth_dataset != "rawDepths") {
    if (why) *why = "depth dataset must be 'depths' or 'rawDepths', got '" + depth_dataset + "'";
    return false;
  }
  return true;
}

int NyuFrameCount(const std::string& path, const NyuFrameOptions& options) {
  ThrowIfInvalid(options, path);
  return ReadWithPlugin(path, options, -1, nullptr, nullptr);
}

NyuFrame ReadNyuFrame(const std::string& path, int index, const NyuFrameOptions& options) {
  ThrowIfInvalid(options, path);
  std::vector<uint8_t> codes(size_t{3} * kWidth * kHeight);
  std::vector<float> depth(size_t{kWidth} * kHeight);
  const int count = ReadWithPlugin(path, options, index, codes.data(), depth.data());
  if (index < 0 || index >= count) throw Error(path, OutOfRange(index, count));
  NyuFrame frame;
  frame.sha256 = Sha256Bytes(
      std::string(reinterpret_cast<const char*>(codes.data()), codes.size()) +
      std::string(reinterpret_cast<const char*>(depth.data()), depth.size() * sizeof(float)));
  // Stored element [c][x][y] (y fastest, MATLAB column-major) -> row y, column x, BGR.
  cv::Mat image(kHeight, kWidth, CV_32FC3);
  cv::Mat depth_m(kHeight, kWidth, CV_32FC1);
  const size_t plane = size_t{kWidth} * kHeight;
  for (int y = 0; y < kHeight; ++y) {
    cv::Vec3f* row = image.ptr<cv::Vec3f>(y);
    float* z = depth_m.ptr<float>(y);
    for (int x = 0; x < kWidth; ++x) {
      const size_t at = size_t{static_cast<size_t>(x)} * kHeight + y;
      for (int c = 0; c < 3; ++c) row[x][2 - c] = codes[c * plane + at] / 255.0f;
      const float v = depth[at];
      if (!std::isfinite(v) || v < 0.0f) {
        std::ostringstream value;
        value << v;
        throw Error(path, "'" + options.depth_dataset + "' frame " + std::to_string(index) +
                              " has depth " + value.str() + " at pixel (" + std::to_string(x) +
                              ", " + std::to_string(y) +
                              ") (must be finite and >= 0 metres; 0 = unknown)");
      }
      z[x] = v == 0.0f ? std::numeric_limits<float>::quiet_NaN() : v;
    }
  }
  if (options.color == Transfer::kSrgb) image = SrgbToLinear(image);
  frame.camera = NyuKinectRgbCamera();
  if (options.crop_border) {
    const cv::Rect box = NyuBorderCropBox();
    image = image(box).clone();
    depth_m = depth_m(box).clone();
    frame.camera.cx -= box.x;
    frame.camera.cy -= box.y;
    frame.camera.width = box.width;
    frame.camera.height = box.height;
  }
  frame.image = image;
  frame.depth_m = depth_m;
  return frame;
}

}  // namespace turbid
