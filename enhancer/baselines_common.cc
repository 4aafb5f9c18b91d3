#include "enhancer/baselines_common.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "enhancer/clahe.h"
#include "enhancer/guided_filter.h"
#include "enhancer/method.h"
#include "scenes/error.h"

namespace turbid::baselines_internal {

void ValidateImage(const cv::Mat& image, const std::string& method) {
  ValidateEnhanceImage(image, method);
}

cv::Mat MinFilter(const cv::Mat& gray, int size) {
  cv::Mat out;
  if (size <= 1) return gray.clone();
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(size, size));
  cv::erode(gray, out, kernel, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  return out;
}

cv::Mat GuidedSmooth(const cv::Mat& guide, const cv::Mat& src, int radius, double eps) {
  GuidedFilterOptions options;
  options.radius = std::max(1, std::min(radius, std::max(src.rows, src.cols)));
  options.eps = eps;
  return GuidedFilter(options, guide, src);
}

cv::Mat ClaheGray(const cv::Mat& gray, int tiles_x, int tiles_y, double clip_limit, int bins) {
  ClaheOptions options;
  options.tiles_x = tiles_x;
  options.tiles_y = tiles_y;
  options.clip_limit = clip_limit;
  options.bins = bins;
  options.distribution = ClaheDistribution::kUniform;
  return Clahe(options, gray);
}

cv::Mat RecoverRadiance(const cv::Mat& image, const cv::Mat& transmission,
                        const cv::Vec3f& airlight, double t_min) {
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
