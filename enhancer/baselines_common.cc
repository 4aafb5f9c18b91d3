#include "enhancer/baselines_common.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>

#include "scenes/error.h"

namespace turbid::baselines_internal {

void ValidateImage(const cv::Mat& image, const std::string& method) {
  if (image.empty()) throw Error(method + ": empty input image");
  if (image.depth() != CV_32F) throw Error(method + ": input must be float32 (got another depth)");
  if (image.channels() != 1 && image.channels() != 3) {
    throw Error(method + ": input must have 1 or 3 channels (got " +
                std::to_string(image.channels()) + ")");
  }
  if (!cv::checkRange(image, /*quiet=*/true)) {
    throw Error(method + ": input contains NaN or infinite values");
  }
}

cv::Mat MinFilter(const cv::Mat& gray, int size) {
  cv::Mat out;
  if (size <= 1) return gray.clone();
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(size, size));
  cv::erode(gray, out, kernel, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  return out;
}

cv::Mat GuidedSmooth(const cv::Mat& guide, const cv::Mat& src, int radius, double eps) {
  const int capped = std::max(1, std::min(radius, std::max(src.rows, src.cols)));
  cv::Mat out;
  cv::ximgproc::guidedFilter(guide, src, out, capped, eps, CV_32F);
  return out;
}

cv::Mat ClaheGray(const cv::Mat& gray, int tiles_x, int tiles_y, double clip_limit, int bins) {
  // Temporary: OpenCV's CLAHE on 16-bit data until enhancer/clahe.h lands.
  (void)bins;
  cv::Mat u16;
  gray.convertTo(u16, CV_16U, 65535.0);
  const int tx = std::max(1, std::min(tiles_x, gray.cols));
  const int ty = std::max(1, std::min(tiles_y, gray.rows));
  const double cv_clip = 1.0 + clip_limit * 256.0;
  cv::Ptr<cv::CLAHE> clahe = cv::createCLAHE(cv_clip, cv::Size(tx, ty));
  cv::Mat eq;
  clahe->apply(u16, eq);
  cv::Mat out;
  eq.convertTo(out, CV_32F, 1.0 / 65535.0);
  return out;
}

cv::Mat RecoverRadiance(const cv::Mat& image, const cv::Mat& transmission, const cv::Vec3f& airlight,
                        double t_min) {
  const int channels = image.channels();
  cv::Mat out(image.size(), image.type());
  for (int y = 0; y < image.rows; ++y) {
    const float* in = image.ptr<float>(y);
    const float* t = transmission.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      const float tt = std::max(t[x], static_cast<float>(t_min));
      for (int c = 0; c < channels; ++c) {
        const float a = airlight[c];
        const float j = (in[x * channels + c] - a) / tt + a;
        o[x * channels + c] = std::clamp(j, 0.0f, 1.0f);
      }
    }
  }
  return out;
}

void ClampUnit(cv::Mat& image) {
  cv::max(image, 0.0, image);
  cv::min(image, 1.0, image);
}

}  // namespace turbid::baselines_internal
