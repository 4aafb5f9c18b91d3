#include "enhancer/blocks/box_filter.h"

#include <algorithm>
#include <cstring>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/row_kernel.h"
#include "enhancer/blocks/box_stream.h"

namespace turbid {
namespace {

// Horizontal clipped-window sums of K planes (stride w apart) along one row, the K running sums
// interleaved so their dependent adds overlap.
template <int K>
void HorizontalPass(const float* col, float* out, int w, int r, const float* inv_cx, float inv_cy) {
  float s[K];
  for (int k = 0; k < K; ++k) {
    s[k] = 0.0f;
    for (int x = 0; x <= std::min(r, w - 1); ++x) s[k] += col[k * w + x];
  }
  for (int x = 0; x < w; ++x) {
    const float scale = inv_cx[x] * inv_cy;
    const bool enter = x + r + 1 < w, leave = x - r >= 0;
    for (int k = 0; k < K; ++k) {
      const float* c = col + k * w;
      out[k * w + x] = s[k] * scale;
      s[k] += (enter ? c[x + r + 1] : 0.0f) - (leave ? c[x - r] : 0.0f);
    }
  }
}

TURBID_ROW_KERNEL void ColumnUpdate(float* __restrict c, const float* __restrict a,
                                    const float* __restrict s, int w) {
  if (a != nullptr && s != nullptr) {
    for (int x = 0; x < w; ++x) c[x] += a[x] - s[x];
  } else if (a != nullptr) {
    for (int x = 0; x < w; ++x) c[x] += a[x];
  } else if (s != nullptr) {
    for (int x = 0; x < w; ++x) c[x] -= s[x];
  }
}

}  // namespace

PlaneRows StoredPlanes(const std::vector<cv::Mat>& planes) {
  return [&planes](int k, int y, float*) { return planes[k].ptr<float>(y); };
}

// Box means of K planar one-channel float images of the same size over the clipped
// (2r+1)x(2r+1) window, one output row at a time. Vertical sums are running column sums (one add
// and one subtract per pixel, vectorised across the row); horizontal sums run along the row on
// the differences (one dependent add per pixel, K chains interleaved). `emit(y, means)` receives
// K row pointers of width W. Float rounding drift of the running sums stays below ~1e-6 of the
// mean for 1360-pixel rows (checked against OpenCV in the tests).
void BoxMeansRows(int k_count, int h, int w, int r, const PlaneRows& plane_row,
                  const std::function<void(int, const std::vector<const float*>&)>& emit) {
  std::vector<float> col(static_cast<size_t>(k_count) * w, 0.0f);
  std::vector<float> out(static_cast<size_t>(k_count) * w, 0.0f);
  std::vector<float> scratch_a(w), scratch_s(w);
  std::vector<float> inv_cx(w);
  for (int x = 0; x < w; ++x) {
    const int c = std::min(x + r, w - 1) - std::max(x - r, 0) + 1;
    inv_cx[x] = 1.0f / static_cast<float>(c);
  }
  std::vector<const float*> rows(k_count);
  // Prime the column sums with rows [0, r-1] (row y+r is added at the top of each step).
  for (int yy = 0; yy < std::min(r, h); ++yy) {
    for (int k = 0; k < k_count; ++k) {
      ColumnUpdate(col.data() + static_cast<size_t>(k) * w, plane_row(k, yy, scratch_a.data()),
                   nullptr, w);
    }
  }
  for (int y = 0; y < h; ++y) {
    const int add = y + r;
    const int sub = y - r - 1;
    for (int k = 0; k < k_count; ++k) {
      ColumnUpdate(col.data() + static_cast<size_t>(k) * w,
                   add < h ? plane_row(k, add, scratch_a.data()) : nullptr,
                   sub >= 0 ? plane_row(k, sub, scratch_s.data()) : nullptr, w);
    }
    const int cy = std::min(y + r, h - 1) - std::max(y - r, 0) + 1;
    const float inv_cy = 1.0f / static_cast<float>(cy);
    if (k_count == 2) {
      HorizontalPass<2>(col.data(), out.data(), w, r, inv_cx.data(), inv_cy);
    } else if (k_count == 4) {
      HorizontalPass<4>(col.data(), out.data(), w, r, inv_cx.data(), inv_cy);
    } else if (k_count == 13) {
      HorizontalPass<13>(col.data(), out.data(), w, r, inv_cx.data(), inv_cy);
    } else {
      for (int k = 0; k < k_count; ++k) {
        HorizontalPass<1>(col.data() + static_cast<size_t>(k) * w,
                          out.data() + static_cast<size_t>(k) * w, w, r, inv_cx.data(), inv_cy);
      }
    }
    for (int k = 0; k < k_count; ++k) rows[k] = out.data() + static_cast<size_t>(k) * w;
    emit(y, rows);
  }
}

void BoxMeansRows(const std::vector<cv::Mat>& planes, int r,
                  const std::function<void(int, const std::vector<const float*>&)>& emit) {
  BoxMeansRows(static_cast<int>(planes.size()), planes[0].rows, planes[0].cols, r,
               StoredPlanes(planes), emit);
}

cv::Mat BoxMean(const cv::Mat& src, int radius) {
  if (src.empty() || src.depth() != CV_32F) throw Error("box mean: expected a float32 image");
  if (radius < 0) throw Error("box mean: radius must be >= 0");
  std::vector<cv::Mat> planes;
  cv::split(src, planes);
  std::vector<cv::Mat> out(planes.size());
  for (cv::Mat& o : out) o.create(src.size(), CV_32F);
  BoxMeansRows(planes, radius, [&](int y, const std::vector<const float*>& m) {
    for (size_t k = 0; k < m.size(); ++k) std::copy(m[k], m[k] + src.cols, out[k].ptr<float>(y));
  });
  cv::Mat merged;
  cv::merge(out, merged);
  return merged;
}

void BoxFilterReflect(const cv::Mat& source, cv::Mat& dst, int radius, bool normalize) {
  CV_Assert(source.depth() == CV_32F && radius >= 1);
  const cv::Mat src = source;                 // a header of its own: dst may be the same Mat object
  if (dst.data == src.data) dst = cv::Mat();  // rows of src are read after rows of dst are written
  dst.create(src.size(), src.type());
  const int k = 2 * radius + 1;
  const size_t bytes = sizeof(float) * src.cols * src.channels();
  box_stream::BoxStreamImage(
      src, radius, normalize ? 1.0 / (k * k) : 1.0,
      [&](int y, const float* const* out) { std::memcpy(dst.ptr<float>(y), out[0], bytes); });
}

}  // namespace turbid
