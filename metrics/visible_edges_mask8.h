// The visible-edge mask's 8-bit fast path (visible_edges_mask8.cc) and the window geometry it
// shares with visible_edges.cc. Internal to the metrics module.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "metrics/visible_edges.h"

namespace turbid::visible_edges {

constexpr int kWindow = 7;  // S in the code, the paper's 7×7 sub-windows
constexpr int kStep = 4;    // round(S/2): windows overlap by 3 pixels

// MATLAB padarray(..., 'symmetric') index: mirror including the edge pixel, periodic beyond.
inline int Reflect(int i, int n) {
  if (n == 1) return 0;
  const int period = 2 * n;
  int k = i % period;
  if (k < 0) k += period;
  return k < n ? k : period - 1 - k;
}

// The 8-bit image mirrored by `pad` on every side.
class MirroredGray8 {
 public:
  MirroredGray8(const cv::Mat& gray8, int pad)
      : pad_(pad),
        cols_(gray8.cols + 2 * pad),
        data_(static_cast<size_t>(gray8.rows + 2 * pad) * cols_) {
    for (int r = 0; r < gray8.rows + 2 * pad; ++r) {
      const uint8_t* src = gray8.ptr<uint8_t>(Reflect(r - pad, gray8.rows));
      uint8_t* dst = &data_[static_cast<size_t>(r) * cols_];
      std::copy(src, src + gray8.cols, dst + pad);
      for (int c = 0; c < pad; ++c) {
        dst[c] = src[Reflect(c - pad, gray8.cols)];
        dst[pad + gray8.cols + c] = src[Reflect(gray8.cols + c, gray8.cols)];
      }
    }
  }
  int operator()(int i, int j) const {
    return data_[static_cast<size_t>(i + pad_) * cols_ + (j + pad_)];
  }
  const uint8_t* Row(int i) const { return &data_[static_cast<size_t>(i + pad_) * cols_ + pad_]; }
  int cols() const { return cols_; }

 private:
  int pad_;
  int cols_;
  std::vector<uint8_t> data_;
};

// VisibleEdgeMask() on CV_8UC1 gray: the same windows, thresholds, sums and decisions.
cv::Mat VisibleEdgeMask8(const VisibleEdgeOptions& options, const cv::Mat& gray8);

}  // namespace turbid::visible_edges
