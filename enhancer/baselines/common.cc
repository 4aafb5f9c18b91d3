#include "enhancer/baselines/common.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/method.h"
#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/image_pool.h"

namespace turbid::baselines_internal {

void ValidateImage(const cv::Mat& image, const std::string& method) {
  ValidateEnhanceImage(image, method);
}

namespace {

// Row kernels of the minimum filter and the radiance recovery (plain loops the compiler
// vectorises; TURBID_ROW_KERNEL adds an AVX2 clone). A minimum is exact, so any order of
// comparisons gives the same values as cv::erode.
TURBID_ROW_KERNEL void MinRows(float* __restrict dst, const float* __restrict a,
                               const float* __restrict b, int n) {
  for (int i = 0; i < n; ++i) dst[i] = std::min(a[i], b[i]);
}

TURBID_ROW_KERNEL void MinRows4(float* __restrict dst, const float* __restrict a, int step, int n) {
  for (int i = 0; i < n; ++i) {
    dst[i] = std::min(std::min(a[i], a[i + step]), std::min(a[i + 2 * step], a[i + 3 * step]));
  }
}

// Minimum over `size` consecutive values of the row `ext` (w + size - 1 values): windows of 4,
// 16, ... (four-way steps) and then 2 × that while <= size, by doubling (ping-pong between ext
// and tmp, both destroyed), then two overlapping windows of the largest length.
void RowWindowMin(float* ext, float* tmp, int w, int size, float* out) {
  int len = 1;
  float* src = ext;
  float* dst = tmp;
  for (; 4 * len <= size; len *= 4) {
    MinRows4(dst, src, len, w + size - 1 - 3 * len);
    std::swap(src, dst);
  }
  for (; 2 * len <= size; len *= 2) {
    MinRows(dst, src, src + len, w + size - 1 - len);
    std::swap(src, dst);
  }
  MinRows(out, src, src + (size - len), w);
}

TURBID_ROW_KERNEL void RecoverRow1(const float* __restrict in, const float* __restrict t, float a,
                                   float t_min, float* __restrict out, int w) {
  for (int x = 0; x < w; ++x) {
    const float tt = std::max(t[x], t_min);
    out[x] = std::clamp((in[x] - a) / tt + a, 0.0f, 1.0f);
  }
}

TURBID_ROW_KERNEL void RecoverRow3(const float* __restrict in, const float* __restrict t, float a0,
                                   float a1, float a2, float t_min, float* __restrict out, int w) {
  for (int x = 0; x < w; ++x) {
    const float tt = std::max(t[x], t_min);
    out[3 * x] = std::clamp((in[3 * x] - a0) / tt + a0, 0.0f, 1.0f);
    out[3 * x + 1] = std::clamp((in[3 * x + 1] - a1) / tt + a1, 0.0f, 1.0f);
    out[3 * x + 2] = std::clamp((in[3 * x + 2] - a2) / tt + a2, 0.0f, 1.0f);
  }
}

TURBID_ROW_KERNEL void ClampRow(float* __restrict v, float lo, float hi, int w) {
  for (int x = 0; x < w; ++x) v[x] = std::min(std::max(v[x], lo), hi);
}

}  // namespace

// Vertical pass: van Herk / Gil-Werman over blocks of `size` rows of the replicate-padded
// column (rows -r .. h-1+r, block b = padded rows [b size - r, (b+1) size - r)): output row y's
// window is the tail of block y / size (suffix minima) and the head of the next (prefix minima),
// about three comparisons per pixel whatever the size. Then each row's horizontal minimum by
// doubling (RowWindowMin). The last suffix row and the first prefix row are the image rows
// themselves, and each column minimum is written straight into the padded row that the
// horizontal pass reads (no row copies but the one of each block's first output row).
cv::Mat MinFilter(const cv::Mat& gray, int size) {
  CV_Assert(gray.type() == CV_32FC1);
  if (size <= 1) return gray.clone();
  const int h = gray.rows, w = gray.cols, r = size / 2;
  cv::Mat out = internal::PooledMat(gray.size(), CV_32FC1);
  std::vector<float> suffix(static_cast<size_t>(size) * w), prefix(static_cast<size_t>(size) * w);
  std::vector<const float*> s(size), p(size);  // suffix / prefix rows of the block
  std::vector<float> ext(static_cast<size_t>(w) + size - 1), tmp(ext.size());
  auto row = [&](int padded) { return gray.ptr<float>(std::clamp(padded, 0, h - 1)); };
  for (int y0 = 0; y0 < h; y0 += size) {
    // Block y0 / size holds padded rows y0 - r .. y0 - r + size - 1; the next block follows.
    const int top = y0 - r;
    s[size - 1] = row(top + size - 1);
    for (int i = size - 2; i >= 0; --i) {
      float* dst = suffix.data() + static_cast<size_t>(i) * w;
      MinRows(dst, s[i + 1], row(top + i), w);
      s[i] = dst;
    }
    const int rows_here = std::min(size, h - y0);
    if (rows_here > 1) {
      p[0] = row(top + size);
      for (int i = 1; i + 1 < rows_here; ++i) {
        float* dst = prefix.data() + static_cast<size_t>(i) * w;
        MinRows(dst, p[i - 1], row(top + size + i), w);
        p[i] = dst;
      }
    }
    float* col = ext.data() + r;
    for (int i = 0; i < rows_here; ++i) {
      if (i > 0) {
        MinRows(col, s[i], p[i - 1], w);
      } else {
        std::copy(s[0], s[0] + w, col);
      }
      std::fill(ext.begin(), ext.begin() + r, col[0]);
      std::fill(ext.begin() + r + w, ext.end(), col[w - 1]);
      RowWindowMin(ext.data(), tmp.data(), w, size, out.ptr<float>(y0 + i));
    }
  }
  return out;
}

cv::Mat GuidedSmooth(const cv::Mat& guide, const cv::Mat& src, int radius, double eps,
                     const std::function<void(int, float*)>& row_done) {
  GuidedFilterOptions options;
  options.radius = std::max(1, std::min(radius, std::max(src.rows, src.cols)));
  options.eps = eps;
  // Beyond the fused radii, the running-sum variant (equal to float rounding, about twice as
  // fast at dcp's r = 60 and cap's r = 30).
  if (guide.channels() == 1 && src.channels() == 1) {
    return GuidedFilterGrayRunning(guide, src, options.radius, eps, row_done);
  }
  cv::Mat q = GuidedFilter(options, guide, src);
  if (row_done) {
    for (int y = 0; y < q.rows; ++y) row_done(y, q.ptr<float>(y));
  }
  return q;
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
  CV_Assert(channels == 1 || channels == 3);
  cv::Mat out = internal::PooledMat(image.size(), image.type());
  const float floor = static_cast<float>(t_min);
  for (int y = 0; y < image.rows; ++y) {
    RecoverRadianceRow(image.ptr<float>(y), transmission.ptr<float>(y), channels, airlight, floor,
                       out.ptr<float>(y), image.cols);
  }
  return out;
}

void RecoverRadianceRow(const float* in, const float* t, int channels, const cv::Vec3f& airlight,
                        float t_min, float* out, int w) {
  if (channels == 1) {
    RecoverRow1(in, t, airlight[0], t_min, out, w);
  } else {
    RecoverRow3(in, t, airlight[0], airlight[1], airlight[2], t_min, out, w);
  }
}

void ClampRangeRow(float* v, float lo, float hi, int n) { ClampRow(v, lo, hi, n); }

void ClampRange(cv::Mat& image, float lo, float hi) {
  CV_Assert(image.depth() == CV_32F);
  const int n = image.cols * image.channels();
  for (int y = 0; y < image.rows; ++y) ClampRow(image.ptr<float>(y), lo, hi, n);
}

void ClampUnit(cv::Mat& image) {
  cv::max(image, 0.0, image);
  cv::min(image, 1.0, image);
}

}  // namespace turbid::baselines_internal
