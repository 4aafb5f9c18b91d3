#include "scenes/image_io.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>

#include "scenes/atomic_file.h"
#include "scenes/error.h"

namespace turbid {
namespace fs = std::filesystem;

bool ReadImageOptions::Check(std::string* /*why*/) const { return true; }

bool WriteImageOptions::Check(std::string* why) const {
  if (bit_depth != 8 && bit_depth != 16) {
    if (why) *why = "bit_depth must be 8 or 16";
    return false;
  }
  return true;
}

cv::Mat SrgbToLinear(const cv::Mat& srgb) {
  CV_Assert(srgb.depth() == CV_32F);
  cv::Mat out = srgb.clone();
  // forEach<float> on a multi-channel Mat visits only cols elements per row: work on one channel.
  cv::Mat flat = out.reshape(1);
  flat.forEach<float>([](float& v, const int*) {
    v = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
  });
  return out;
}

cv::Mat LinearToSrgb(const cv::Mat& linear) {
  CV_Assert(linear.depth() == CV_32F);
  cv::Mat out = linear.clone();
  cv::Mat flat = out.reshape(1);
  flat.forEach<float>([](float& v, const int*) {
    v = v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
  });
  return out;
}

cv::Mat ReadImage(const std::string& path, const ReadImageOptions& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(path, "file not found");
  cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED | cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (raw.empty()) throw Error(path, "cannot decode image (corrupt or unsupported format)");
  if (raw.channels() == 4) cv::cvtColor(raw, raw, cv::COLOR_BGRA2BGR);
  if (raw.channels() != 1 && raw.channels() != 3)
    throw Error(path, "unsupported channel count " + std::to_string(raw.channels()));
  cv::Mat out;
  double scale = 1.0;
  if (!options.keep_raw) {
    if (raw.depth() == CV_8U) scale = 1.0 / 255.0;
    if (raw.depth() == CV_16U) scale = 1.0 / 65535.0;
  }
  raw.convertTo(out, CV_32F, scale);
  if (options.transfer == Transfer::kSrgb && !options.keep_raw) out = SrgbToLinear(out);
  return out;
}

void WriteImage(const std::string& path, const cv::Mat& image, const WriteImageOptions& options) {
  ThrowIfInvalid(options, path);
  if (image.empty()) throw Error(path, "refusing to write an empty image");
  const std::string ext = fs::path(path).extension().string();
  cv::Mat data;
  image.convertTo(data, CV_32F);
  if (ext == ".exr") {
    AtomicWrite(path, options.overwrite, [&](const std::string& temp) {
      if (!cv::imwrite(temp, data, {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_FLOAT}))
        throw Error(path, "EXR encoder failed");
    });
    return;
  }
  if (ext != ".png") throw Error(path, "unsupported output format (use .png or .exr)");
  if (options.transfer == Transfer::kSrgb) data = LinearToSrgb(data);
  cv::Mat encoded;
  const double max_value = options.bit_depth == 16 ? 65535.0 : 255.0;
  cv::Mat clipped = cv::min(cv::max(data, 0.0), 1.0);
  cv::patchNaNs(clipped, 0.0);
  clipped.convertTo(encoded, options.bit_depth == 16 ? CV_16U : CV_8U, max_value);
  AtomicWrite(path, options.overwrite, [&](const std::string& temp) {
    if (!cv::imwrite(temp, encoded)) throw Error(path, "PNG encoder failed");
  });
}

}  // namespace turbid
