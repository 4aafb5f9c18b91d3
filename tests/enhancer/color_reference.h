// Shared by the colour-path tests (color_paths_test.cc, full_color_kernels_test.cc): the
// pre-optimisation noise estimate of commit 6722196 and a bitwise image comparison.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <opencv2/core.hpp>

namespace turbid::color_reference {

// The Immerkaer estimate as commit 6722196 computed it: one float chain per row, rows summed in
// double.
inline double ReferenceNoiseSigma(const cv::Mat& image) {
  if (image.rows < 3 || image.cols < 3) return 0.0;
  const int ch = image.channels(), n = (image.cols - 2) * ch;
  double total = 0.0;
  for (int y = 1; y + 1 < image.rows; ++y) {
    const float* a = image.ptr<float>(y - 1);
    const float* b = image.ptr<float>(y);
    const float* c = image.ptr<float>(y + 1);
    float row = 0.0f;
    for (int i = ch; i < n + ch; ++i) {
      const float v = (a[i - ch] + a[i + ch] + c[i - ch] + c[i + ch]) -
                      2.0f * (a[i] + c[i] + b[i - ch] + b[i + ch]) + 4.0f * b[i];
      row += std::abs(v);
    }
    total += row;
  }
  const double count = 6.0 * (image.cols - 2) * (image.rows - 2) * ch;
  return std::sqrt(CV_PI / 2.0) * total / count;
}

// Bitwise equality of two float images (+0 and -0 count as equal; a NaN equals only the same NaN
// bits); the message names the first differing value.
inline ::testing::AssertionResult SameBits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) {
    return ::testing::AssertionFailure() << "size or type differ";
  }
  const size_t n = static_cast<size_t>(a.cols) * a.channels();
  for (int y = 0; y < a.rows; ++y) {
    const float* p = a.ptr<float>(y);
    const float* q = b.ptr<float>(y);
    for (size_t i = 0; i < n; ++i) {
      if (std::memcmp(p + i, q + i, sizeof(float)) != 0 && !(p[i] == 0.0f && q[i] == 0.0f)) {
        return ::testing::AssertionFailure()
               << "row " << y << " value " << i << ": " << p[i] << " vs " << q[i] << " (max |diff| "
               << cv::norm(a, b, cv::NORM_INF) << ")";
      }
    }
  }
  return ::testing::AssertionSuccess();
}

}  // namespace turbid::color_reference
