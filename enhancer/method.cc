#include "enhancer/method.h"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace turbid {

// True when every float of the row is finite: a float is NaN or ±inf exactly when its exponent
// bits are all ones. An integer OR over the row vectorises (cv::checkRange is a scalar pass, ~1.5
// ms on a 1360x1024 image, a tenth of `simplified`).
bool RowIsFinite(const float* row, size_t count) {
  uint32_t all_ones_exponent = 0;
  for (size_t i = 0; i < count; ++i) {
    uint32_t bits;
    std::memcpy(&bits, row + i, sizeof(bits));
    all_ones_exponent |= static_cast<uint32_t>((bits & 0x7f800000u) == 0x7f800000u);
  }
  return all_ones_exponent == 0;
}

void ValidateEnhanceImageLayout(const cv::Mat& image, const std::string& method) {
  if (image.empty()) throw Error(method + ": empty input image");
  if (image.depth() != CV_32F) throw Error(method + ": input image must be float32");
  if (image.channels() != 1 && image.channels() != 3) {
    throw Error(method + ": input image must have 1 or 3 channels, got " +
                std::to_string(image.channels()));
  }
}

void ValidateEnhanceImage(const cv::Mat& image, const std::string& method) {
  ValidateEnhanceImageLayout(image, method);
  const size_t row_floats = static_cast<size_t>(image.cols) * image.channels();
  for (int y = 0; y < image.rows; ++y) {
    if (!RowIsFinite(image.ptr<float>(y), row_floats)) {
      throw Error(method + ": input image has non-finite values (row " + std::to_string(y) + ")");
    }
  }
}

}  // namespace turbid
