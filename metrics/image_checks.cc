#include "metrics/image_checks.h"

#include <cstdint>
#include <sstream>

#include "core/error.h"

namespace turbid {
namespace {

// The first NaN or infinite element in row-major order (x counts elements, channels included),
// as cv::checkRange reports it; false when every element is finite. A float is non-finite when
// its exponent bits are all set: the per-row test is an OR over integers, which the compiler
// vectorizes (cv::checkRange tests element by element and cost ~2 ms per 640x480 colour image).
template <typename Float, typename Bits>
bool FirstNonFinite(const cv::Mat& image, cv::Point* where) {
  static_assert(sizeof(Float) == sizeof(Bits));
  constexpr Bits kExponent =
      sizeof(Bits) == 4 ? static_cast<Bits>(0x7f800000u) : static_cast<Bits>(0x7ff0000000000000ull);
  const int width = image.cols * image.channels();
  for (int y = 0; y < image.rows; ++y) {
    const Bits* row = reinterpret_cast<const Bits*>(image.ptr<Float>(y));
    Bits any = 0;
    for (int x = 0; x < width; ++x) any |= static_cast<Bits>((row[x] & kExponent) == kExponent);
    if (any == 0) continue;
    for (int x = 0; x < width; ++x) {
      if ((row[x] & kExponent) == kExponent) {
        *where = cv::Point(x, y);
        return true;
      }
    }
  }
  return false;
}

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
    // NaN and +-inf are refused; report which and where so the user can find the source.
    cv::Point where;
    const bool bad = depth == CV_32F ? FirstNonFinite<float, uint32_t>(image, &where)
                                     : FirstNonFinite<double, uint64_t>(image, &where);
    if (bad) {
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
