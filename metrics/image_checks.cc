#include "metrics/image_checks.h"

#include <sstream>

#include "scenes/error.h"

namespace turbid {
namespace {

std::string Describe(const cv::Mat& m) {
  std::ostringstream out;
  out << m.cols << "x" << m.rows << "x" << m.channels();
  return out.str();
}

}  // namespace

void CheckMetricImage(const cv::Mat& image, const std::string& what) {
  if (image.empty()) throw Error(what + ": empty image");
  if (image.dims != 2) throw Error(what + ": expected a 2-D image");
  const int depth = image.depth();
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F && depth != CV_64F)
    throw Error(what + ": unsupported pixel depth (use 8-bit, 16-bit, float or double)");
  if (image.channels() < 1 || image.channels() > 4)
    throw Error(what + ": unsupported channel count " + std::to_string(image.channels()));
  if (depth == CV_32F || depth == CV_64F) {
    // checkRange is false for NaN and +-inf; report which so the user can find the source.
    cv::Point where;
    if (!cv::checkRange(image, true, &where)) {
      const cv::Mat row = image.reshape(1, image.rows).row(where.y);
      const double v = depth == CV_32F ? row.at<float>(where.x) : row.at<double>(where.x);
      std::ostringstream out;
      out << what << ": non-finite pixel value (" << v << ") at x=" << where.x / image.channels()
          << " y=" << where.y;
      throw Error(out.str());
    }
  }
}

void CheckMetricPair(const cv::Mat& reference, const cv::Mat& image, const std::string& metric) {
  CheckMetricImage(reference, metric + ": reference");
  CheckMetricImage(image, metric + ": image");
  if (reference.size() != image.size() || reference.channels() != image.channels())
    throw Error(metric + ": image is " + Describe(image) + " but the reference is " +
                Describe(reference) + " (sizes and channel counts must match)");
}

double DefaultDataRange(int depth) {
  switch (depth) {
    case CV_8U:
      return 255.0;
    case CV_16U:
      return 65535.0;
    default:
      return 1.0;
  }
}

}  // namespace turbid
