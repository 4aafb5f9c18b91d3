#include "enhancer/blocks/linear_upsample.h"

#include <algorithm>
#include <cmath>

#include "core/row_kernel.h"

namespace turbid::enhancer_internal {
namespace {

// cv::resize's source position of destination index d: the float f, its floor s (f - s left in
// *f).
int SourcePosition(int d, double scale, float* f) {
  const float pos = static_cast<float>((d + 0.5) * scale - 0.5);
  const int s = static_cast<int>(std::floor(pos));
  *f = pos - static_cast<float>(s);
  return s;
}

// a w0 + b w1 in float, each product rounded, then the sum. No FMA clone (TURBID_ROW_KERNEL's
// AVX2 target has none), so no product is fused with the sum: cv::resize's baseline SSE2 kernel
// and its scalar tail round each product.
TURBID_ROW_KERNEL void BlendRows(const float* __restrict a, const float* __restrict b, float w0,
                                 float w1, float* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = a[i] * w0 + b[i] * w1;
}

}  // namespace

LinearUpsampler::LinearUpsampler(const cv::Mat& src, cv::Size size) : size_(size) {
  CV_Assert(src.type() == CV_32FC1 && !src.empty() && src.cols <= size.width &&
            src.rows <= size.height);
  if (src.size() == size) {
    src_ = src;
    return;
  }
  const int sw = src.cols, sh = src.rows, dw = size.width, dh = size.height;
  // Horizontal pass: per destination column, the left source column and its two weights; from
  // xmax on, the last source value.
  const double scale_x = 1.0 / (static_cast<double>(dw) / sw);
  std::vector<int> ofs(dw);
  std::vector<float> a0(dw), a1(dw);
  int xmax = dw;
  for (int dx = 0; dx < dw; ++dx) {
    float f;
    int s = SourcePosition(dx, scale_x, &f);
    if (s < 0) f = 0.0f, s = 0;
    if (s + 1 >= sw) {
      xmax = std::min(xmax, dx);
      if (s >= sw - 1) f = 0.0f, s = sw - 1;
    }
    ofs[dx] = s;
    a0[dx] = 1.0f - f;
    a1[dx] = f;
  }
  horizontal_.create(sh, dw, CV_32F);
  for (int y = 0; y < sh; ++y) {
    const float* s = src.ptr<float>(y);
    float* h = horizontal_.ptr<float>(y);
    int dx = 0;
    for (; dx < xmax; ++dx) {
      const float p = s[ofs[dx]] * a0[dx];  // two products rounded apart, then the sum
      const float q = s[ofs[dx] + 1] * a1[dx];
      h[dx] = p + q;
    }
    for (; dx < dw; ++dx) h[dx] = s[ofs[dx]];
  }
  // Vertical weights: f unclamped, the rows clamped.
  const double scale_y = 1.0 / (static_cast<double>(dh) / sh);
  r0_.resize(dh), r1_.resize(dh), w0_.resize(dh), w1_.resize(dh);
  for (int dy = 0; dy < dh; ++dy) {
    float f;
    const int s = SourcePosition(dy, scale_y, &f);
    r0_[dy] = std::clamp(s, 0, sh - 1);
    r1_[dy] = std::clamp(s + 1, 0, sh - 1);
    w0_[dy] = 1.0f - f;
    w1_[dy] = f;
  }
}

const float* LinearUpsampler::Row(int y, float* buf) const {
  if (!src_.empty()) return src_.ptr<float>(y);
  BlendRows(horizontal_.ptr<float>(r0_[y]), horizontal_.ptr<float>(r1_[y]), w0_[y], w1_[y], buf,
            size_.width);
  return buf;
}

cv::Mat LinearUpsampler::EveryNthRow(int every) const {
  CV_Assert(every >= 1);
  cv::Mat out((size_.height + every - 1) / every, size_.width, CV_32F);
  for (int i = 0; i < out.rows; ++i) {
    float* dst = out.ptr<float>(i);
    const float* row = Row(i * every, dst);
    if (row != dst) std::copy_n(row, size_.width, dst);
  }
  return out;
}

}  // namespace turbid::enhancer_internal
