// Bilinear upsampling of a one-channel float map, row by row, with the arithmetic of
// cv::resize(src, dst, size, 0, 0, cv::INTER_LINEAR) in OpenCV 4.x (bit for bit): `full`'s t and
// E_L maps, computed at 1/light_subsample, are read one upsampled row at a time instead of being
// written whole.
//
// cv::resize's float bilinear filter is separable. Horizontally, destination column dx maps to
// f = (float)((dx + 0.5) * sw / dw - 0.5) (the scale 1 / (dw / sw) in double), s = floor(f), and
// weights 1 - f and f - s (floats) of source columns s and s + 1; a column left of the source
// (s < 0) takes s = 0 with weights 1 and 0, and from the first column whose s + 1 falls off the
// right edge on, the value is the last source value as is. Each source row is filtered so, in
// float (product, product, sum). Vertically, row dy's f and s are computed the same way but not
// clamped: the weights stay 1 - f and f, and the two source rows are clamped to the map (at the
// top and bottom the same row twice, so an edge row is h * (1 - f) + h * f, not h). An equal size
// is no resize at all (the map as is). Checked against cv::resize on many sizes and factors
// (tests/enhancer/linear_upsample_test.cc).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace turbid::enhancer_internal {

class LinearUpsampler {
 public:
  LinearUpsampler() = default;
  // `src`: CV_32FC1, at most `size` in each dimension.
  LinearUpsampler(const cv::Mat& src, cv::Size size);

  bool empty() const { return size_.width == 0; }
  cv::Size size() const { return size_; }
  // Row y of the upsampled map: a pointer to `buf` (size().width floats), or into the source map
  // when the size is the source's.
  const float* Row(int y, float* buf) const;
  // The rows y = 0, every, 2 every, ... as one CV_32FC1 image.
  cv::Mat EveryNthRow(int every) const;

 private:
  cv::Mat src_;                 // the map, when it is not resized
  cv::Mat horizontal_;          // each source row filtered horizontally: src rows x size.width
  std::vector<int> r0_, r1_;    // per output row: the two source rows (clamped)
  std::vector<float> w0_, w1_;  // and their weights
  cv::Size size_;
};

}  // namespace turbid::enhancer_internal
