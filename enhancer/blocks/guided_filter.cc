#include "enhancer/blocks/guided_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/row_kernel.h"
#include "enhancer/blocks/box_filter.h"
#include "enhancer/blocks/guided_filter_color.h"
#include "enhancer/blocks/guided_kernels.h"
#include "enhancer/blocks/guided_segments.h"
#include "enhancer/simd_switch.h"
#include "simulator/image_pool.h"

namespace turbid {
namespace {

using namespace guided_internal;  // NOLINT(google-build-using-namespace): this filter's internals

void CheckInputs(const GuidedFilterOptions& options, const cv::Mat& guide, const cv::Mat& src) {
  ThrowIfInvalid(options, "guided filter");
  if (guide.empty() || src.empty()) throw Error("guided filter: empty image");
  if (guide.depth() != CV_32F || src.depth() != CV_32F) {
    throw Error("guided filter: images must be float32");
  }
  if (guide.channels() != 1 && guide.channels() != 3) {
    throw Error("guided filter: guide must have 1 or 3 channels, got " +
                std::to_string(guide.channels()));
  }
  if (guide.size() != src.size()) {
    throw Error("guided filter: guide and source sizes differ");
  }
}

// Vertical running sums are float and re-anchored by direct summation every kAnchorRows rows, so
// rounding drift spans at most that many steps (the variance mean(I^2) - mean(I)^2 cancels, so a
// drift over a thousand rows would show in a = var / (var + eps)).
constexpr int kAnchorRows = 64;

// Re-anchoring (every kAnchorRows rows): the column sums over the window's rows from zero, the
// rows added in order as the running steps add them (so the same roundings), but 16 columns at a
// time in registers instead of one pass over the whole row per window row. Sums of u (into
// c_u), and as selected of u^2 (c_uu), of v (c_v) and of u v (c_uv).
constexpr int kAnchorBlock = 16;

template <bool kSquare, bool kSecond, bool kProduct>
TURBID_ROW_KERNEL void AnchorSums(const float* const* u, const float* const* v, int count, int w,
                                  float* __restrict c_u, float* __restrict c_uu,
                                  float* __restrict c_v, float* __restrict c_uv) {
  int x0 = 0;
  for (; x0 + kAnchorBlock <= w; x0 += kAnchorBlock) {
    float su[kAnchorBlock] = {}, suu[kAnchorBlock] = {}, sv[kAnchorBlock] = {},
          suv[kAnchorBlock] = {};
    for (int k = 0; k < count; ++k) {
      const float* __restrict a = u[k] + x0;
      const float* __restrict b = kSecond ? v[k] + x0 : a;
      for (int i = 0; i < kAnchorBlock; ++i) {
        su[i] += a[i];
        if (kSquare) suu[i] += a[i] * a[i];
        if (kSecond) sv[i] += b[i];
        if (kProduct) suv[i] += a[i] * b[i];
      }
    }
    for (int i = 0; i < kAnchorBlock; ++i) {
      c_u[x0 + i] = su[i];
      if (kSquare) c_uu[x0 + i] = suu[i];
      if (kSecond) c_v[x0 + i] = sv[i];
      if (kProduct) c_uv[x0 + i] = suv[i];
    }
  }
  for (; x0 < w; ++x0) {  // the last < 16 columns: the same additions one column at a time
    float su = 0.0f, suu = 0.0f, sv = 0.0f, suv = 0.0f;
    for (int k = 0; k < count; ++k) {
      const float a = u[k][x0];
      const float b = kSecond ? v[k][x0] : a;
      su += a;
      if (kSquare) suu += a * a;
      if (kSecond) sv += b;
      if (kProduct) suv += a * b;
    }
    c_u[x0] = su;
    if (kSquare) c_uu[x0] = suu;
    if (kSecond) c_v[x0] = sv;
    if (kProduct) c_uv[x0] = suv;
  }
}

// Vertical window bookkeeping for output row t of a clipped (2r+1)-row window over h rows: the
// rows entering and leaving (-1: none). Row t's window is [max(t-r, 0), min(t+r, h-1)]; the
// first row primes the sums with the whole window.
int InvCount(int t, int r, int n) { return std::min(t + r, n - 1) - std::max(t - r, 0) + 1; }

// One-channel guide, one-channel source (He 2013 Alg. 1), streamed by rows: the first stage
// computes a, b for row y from the box sums of I, I^2 (and p, I p unless self-guided); the second
// stage, r rows behind, box-sums a and b and writes q. a and b live in a ring of 2r+2 rows, so
// there are no full-size temporaries besides the output. Rows are pulled in order 0..h-1.
// (Three-channel self-guided images: guided_segments.h.)
class GrayStream {
 public:
  GrayStream(const cv::Mat& guide, const cv::Mat& src, int r, float eps, bool self,
             bool running = false)
      : guide_(guide),
        src_(src),
        r_(r),
        eps_(eps),
        self_(self),
        h_(guide.rows),
        w_(guide.cols),
        pad_(r),
        window_(2 * r + 1),
        ext_len_(w_ + 2 * pad_),
        planes_a_(self ? 2 : 4),  // I, I^2 [, p, I p]
        ring_(std::min(window_ + 1, h_)),
        ext_(static_cast<size_t>(planes_a_ + 2) * ext_len_, 0.0f),
        inv_cx_(w_),
        a_ring_(ring_, w_, CV_32F),
        b_ring_(ring_, w_, CV_32F) {
    CV_Assert(guide.channels() == 1);
    for (int x = 0; x < w_; ++x) {
      inv_cx_[x] = 1.0f / static_cast<float>(InvCount(x, r_, guide.cols));
    }
    if (r_ >= 1 && r_ <= kMaxFusedRadius) fused_ = FusedKernelsFor(r_);
    // Buffers of the path in use: sums of 4 for the portable fused kernels (W >= 9); window sums
    // and doubling scratch for the unfused one.
    if (fused_.quads != nullptr) quads_.assign(static_cast<size_t>(planes_a_ + 2) * ext_len_, 0.0f);
    if (fused_.apply == nullptr) {
      sums_.assign(static_cast<size_t>(planes_a_ + 2) * w_, 0.0f);
      t0_.resize(ext_len_);
      t1_.resize(ext_len_);
      if (running) {
        running_.resize(static_cast<size_t>(w_) + window_);
        return;
      }
#ifdef TURBID_HAVE_ROLLING_QUADS
      if (enhancer_internal::UseHandWrittenAvx2()) {
        doubling_.resize(DoublingScratchFloats(w_, window_));
      }
#endif
    }
  }

  // Writes output row t (rows must be asked for in order 0, 1, ..., h-1).
  void Row(int t, float* dst) {
    const int need = std::min(t + r_, h_ - 1);
    while (next_a_ <= need) StageA(next_a_++);
    const int ka = planes_a_, kb = planes_a_ + 1;
    if (t % kAnchorRows == 0) {
      WindowRows(t, a_ring_, &rows_u_, true);
      WindowRows(t, b_ring_, &rows_v_, true);
      AnchorSums<false, true, false>(rows_u_.data(), rows_v_.data(),
                                     static_cast<int>(rows_u_.size()), w_, Ext(ka) + pad_, nullptr,
                                     Ext(kb) + pad_, nullptr);
    } else {
      const int add = t + r_ < h_ ? (t + r_) % ring_ : -1;
      const int sub = t - r_ - 1 >= 0 ? (t - r_ - 1) % ring_ : -1;
      ColumnStepPair(Ext(ka) + pad_, Ext(kb) + pad_, RingRow(a_ring_, add), RingRow(a_ring_, sub),
                     RingRow(b_ring_, add), RingRow(b_ring_, sub), w_);
    }
    const float inv_cy = 1.0f / static_cast<float>(InvCount(t, r_, h_));
    const float* guide = guide_.ptr<float>(t);
    if (fused_.apply != nullptr) {
      if (fused_.quads != nullptr) fused_.quads(Ext(ka), Ext(kb), Quad(ka), Quad(kb), w_);
      fused_.apply(Ext(ka), Ext(kb), Quad(ka), Quad(kb), guide, inv_cx_.data(), inv_cy, dst, w_);
      return;
    }
    WindowSumsOf(ka);
    WindowSumsOf(kb);
    ApplyCoefficients(Sum(ka), Sum(kb), guide, inv_cx_.data(), inv_cy, dst, w_);
  }

 private:
  float* Ext(int k) { return ext_.data() + static_cast<size_t>(k) * ext_len_; }
  // Null where the kernels form their sums of 4 themselves (they ignore the argument).
  float* Quad(int k) {
    return quads_.empty() ? nullptr : quads_.data() + static_cast<size_t>(k) * ext_len_;
  }
  float* Sum(int k) { return sums_.data() + static_cast<size_t>(k) * w_; }
  // Window sums of plane k's padded column sums into Sum(k) (radii beyond kMaxFusedRadius).
  void WindowSumsOf(int k) {
    if (!running_.empty()) {
#ifdef TURBID_HAVE_ROLLING_QUADS
      if (enhancer_internal::UseHandWrittenAvx2()) {
        RunningWindowSumsAvx2(Ext(k), w_, window_, Sum(k), running_.data());
        return;
      }
#endif
      RunningWindowSumsPortable(Ext(k), w_, window_, Sum(k), running_.data());
      return;
    }
#ifdef TURBID_HAVE_ROLLING_QUADS
    if (!doubling_.empty()) {
      DoublingWindowSumsAvx2(Ext(k), w_, window_, Sum(k), doubling_.data());
      return;
    }
#endif
    WindowSums(Ext(k), w_, window_, Sum(k), t0_.data(), t1_.data());
  }
  static const float* RingRow(const cv::Mat& ring, int slot) {
    return slot >= 0 ? ring.ptr<float>(slot) : nullptr;
  }

  // The rows of the clipped vertical window of row t, top to bottom (from the ring of a or b
  // rows when in_ring).
  void WindowRows(int t, const cv::Mat& m, std::vector<const float*>* rows, bool in_ring = false) {
    rows->clear();
    for (int y = std::max(t - r_, 0); y <= std::min(t + r_, h_ - 1); ++y)
      rows->push_back(m.ptr<float>(in_ring ? y % ring_ : y));
  }

  void StageA(int y) {
    const float* add = y + r_ < h_ ? guide_.ptr<float>(y + r_) : nullptr;
    const float* sub = y - r_ - 1 >= 0 ? guide_.ptr<float>(y - r_ - 1) : nullptr;
    if (y % kAnchorRows == 0) {
      WindowRows(y, guide_, &rows_u_);
      if (self_) {
        AnchorSums<true, false, false>(rows_u_.data(), nullptr, static_cast<int>(rows_u_.size()),
                                       w_, Ext(0) + pad_, Ext(1) + pad_, nullptr, nullptr);
      } else {
        WindowRows(y, src_, &rows_v_);
        AnchorSums<true, true, true>(rows_u_.data(), rows_v_.data(),
                                     static_cast<int>(rows_u_.size()), w_, Ext(0) + pad_,
                                     Ext(1) + pad_, Ext(2) + pad_, Ext(3) + pad_);
      }
    } else if (self_) {
      ColumnStepSelf(Ext(0) + pad_, Ext(1) + pad_, add, sub, w_);
    } else {
      ColumnStepGuided(Ext(0) + pad_, Ext(1) + pad_, Ext(2) + pad_, Ext(3) + pad_, add, sub,
                       add != nullptr ? src_.ptr<float>(y + r_) : nullptr,
                       sub != nullptr ? src_.ptr<float>(y - r_ - 1) : nullptr, w_);
    }
    const float inv_cy = 1.0f / static_cast<float>(InvCount(y, r_, h_));
    float* ar = a_ring_.ptr<float>(y % ring_);
    float* br = b_ring_.ptr<float>(y % ring_);
    if (fused_.apply != nullptr) {
      if (fused_.quads != nullptr) {
        for (int k = 0; k < planes_a_; k += 2) {
          fused_.quads(Ext(k), Ext(k + 1), Quad(k), Quad(k + 1), w_);
        }
      }
      if (self_) {
        fused_.self_coefficients(Ext(0), Ext(1), Quad(0), Quad(1), inv_cx_.data(), inv_cy, eps_, ar,
                                 br, w_);
      } else {
        const float* e[4] = {Ext(0), Ext(1), Ext(2), Ext(3)};
        const float* q[4] = {Quad(0), Quad(1), Quad(2), Quad(3)};
        fused_.guided_coefficients(e, q, inv_cx_.data(), inv_cy, eps_, ar, br, w_);
      }
      return;
    }
    for (int k = 0; k < planes_a_; ++k) WindowSumsOf(k);
    if (self_) {
      SelfCoefficients(Sum(0), Sum(1), inv_cx_.data(), inv_cy, eps_, ar, br, w_);
    } else {
      GuidedCoefficients(Sum(0), Sum(2), Sum(1), Sum(3), inv_cx_.data(), inv_cy, eps_, ar, br, w_);
    }
  }

  const cv::Mat guide_, src_;
  const int r_;
  const float eps_;
  const bool self_;
  const int h_, w_, pad_, window_, ext_len_, planes_a_, ring_;  // w_, pad_: values, not pixels
  // Per-plane buffers: column sums with r zeros each side (the clipped window); window sums.
  std::vector<float> ext_, quads_, sums_, t0_, t1_, inv_cx_;
  std::vector<float> doubling_;                // DoublingWindowSumsAvx2's levels (AVX2, radii > 12)
  std::vector<float> running_;                 // sums of 8 (GuidedFilterGrayRunning)
  std::vector<const float*> rows_u_, rows_v_;  // window rows when re-anchoring
  cv::Mat a_ring_, b_ring_;
  FusedKernels fused_;  // empty beyond kMaxFusedRadius (window sums by binary doubling)
  int next_a_ = 0;
};

cv::Mat GuidedGray(const cv::Mat& guide, const cv::Mat& src, int r, float eps, bool self,
                   bool running = false,
                   const std::function<void(int, float*)>& row_done = nullptr) {
  GrayStream stream(guide, src, r, eps, self, running);
  // The output from the recycling pool (simulator/image_pool.h): no fresh pages per call.
  cv::Mat q = internal::PooledMat(guide.size(), CV_32F);
  for (int t = 0; t < guide.rows; ++t) {
    stream.Row(t, q.ptr<float>(t));
    if (row_done) row_done(t, q.ptr<float>(t));
  }
  return q;
}

// Coefficients only (for the subsampled variant): a, b at the guide's resolution, then their box
// means. Returns {mean_a, mean_b}.
std::pair<cv::Mat, cv::Mat> GrayCoefficients(const cv::Mat& guide, const cv::Mat& src, int r,
                                             float eps) {
  const int h = guide.rows;
  const int w = guide.cols;
  cv::Mat a(h, w, CV_32F), b(h, w, CV_32F);
  BoxMeansRows({guide, src, guide.mul(guide), guide.mul(src)}, r,
               [&](int y, const std::vector<const float*>& m) {
                 float* ar = a.ptr<float>(y);
                 float* br = b.ptr<float>(y);
                 for (int x = 0; x < w; ++x) {
                   const float var = m[2][x] - m[0][x] * m[0][x];
                   const float cov = m[3][x] - m[0][x] * m[1][x];
                   const float av = cov / (var + eps);
                   ar[x] = av;
                   br[x] = m[1][x] - av * m[0][x];
                 }
               });
  cv::Mat ma(h, w, CV_32F), mb(h, w, CV_32F);
  BoxMeansRows({a, b}, r, [&](int y, const std::vector<const float*>& m) {
    std::copy(m[0], m[0] + w, ma.ptr<float>(y));
    std::copy(m[1], m[1] + w, mb.ptr<float>(y));
  });
  return {ma, mb};
}

cv::Mat Continuous(const cv::Mat& m) { return m.isContinuous() ? m : m.clone(); }

}  // namespace

bool GuidedFilterOptions::Check(std::string* why) const {
  if (radius < 0 || radius > 10000) {
    *why = "radius must be in [0, 10000], got " + std::to_string(radius);
    return false;
  }
  if (!std::isfinite(eps) || eps <= 0.0) {
    *why = "eps must be finite and > 0, got " + std::to_string(eps);
    return false;
  }
  if (subsample < 1 || subsample > 64) {
    *why = "subsample must be in [1, 64], got " + std::to_string(subsample);
    return false;
  }
  return true;
}

cv::Mat GuidedFilter(const GuidedFilterOptions& options, const cv::Mat& guide_in,
                     const cv::Mat& src_in) {
  CheckInputs(options, guide_in, src_in);
  if (options.radius == 0) return src_in.clone();
  const float eps = static_cast<float>(options.eps);
  const cv::Mat guide = Continuous(guide_in);
  std::vector<cv::Mat> src_planes;
  if (src_in.channels() == 1) {
    src_planes = {src_in};  // cv::split would copy a one-channel image
  } else {
    cv::split(src_in, src_planes);
  }
  std::vector<cv::Mat> out_planes;
  const int s = options.subsample;
  const bool sub = s > 1 && std::min(guide.rows, guide.cols) >= 2 * s;

  if (!sub) {
    if (guide.channels() == 1) {
      for (const cv::Mat& p : src_planes) {
        const bool self = src_in.channels() == 1 && guide_in.data == src_in.data;
        out_planes.push_back(GuidedGray(guide, self ? guide : p, options.radius, eps, self));
      }
    } else {
      std::vector<cv::Mat> g;
      cv::split(guide, g);
      for (const cv::Mat& p : src_planes) {
        out_planes.push_back(
            ColorApply(ColorCoefficients(g, p, options.radius, options.eps), g, options.radius));
      }
    }
  } else {
    // He & Sun 2015 Alg. 2: coefficients at 1/s, upsampled bilinearly, applied at full size.
    const cv::Size small(std::max(1, (guide.cols + s / 2) / s),
                         std::max(1, (guide.rows + s / 2) / s));
    const int rs =
        std::max(1, static_cast<int>(std::lround(static_cast<double>(options.radius) / s)));
    cv::Mat guide_small;
    cv::resize(guide, guide_small, small, 0, 0, cv::INTER_AREA);
    std::vector<cv::Mat> g, g_small;
    cv::split(guide, g);
    cv::split(guide_small, g_small);
    for (const cv::Mat& p : src_planes) {
      cv::Mat p_small;
      cv::resize(p, p_small, small, 0, 0, cv::INTER_AREA);
      std::vector<cv::Mat> coef;
      if (guide.channels() == 1) {
        auto [ma, mb] = GrayCoefficients(guide_small, p_small, rs, eps);
        coef = {ma, mb};
      } else {
        coef = ColorCoefficients(g_small, p_small, rs, options.eps);
        std::vector<cv::Mat> means(4);
        for (cv::Mat& c : means) c.create(coef[0].size(), CV_32F);
        BoxMeansRows(coef, rs, [&](int y, const std::vector<const float*>& m) {
          for (int k = 0; k < 4; ++k) std::copy(m[k], m[k] + coef[0].cols, means[k].ptr<float>(y));
        });
        coef = means;
      }
      for (cv::Mat& c : coef) cv::resize(c, c, guide.size(), 0, 0, cv::INTER_LINEAR);
      cv::Mat q = coef.back().clone();
      for (size_t c = 0; c + 1 < coef.size(); ++c) q += coef[c].mul(g[c]);
      out_planes.push_back(q);
    }
  }
  cv::Mat out;
  if (out_planes.size() == 1) return out_planes[0];
  cv::merge(out_planes, out);
  return out;
}

cv::Mat GuidedFilterGrayRunning(const cv::Mat& guide_in, const cv::Mat& src_in, int radius,
                                double eps, const std::function<void(int, float*)>& row_done) {
  GuidedFilterOptions options;
  options.radius = radius;
  options.eps = eps;
  CheckInputs(options, guide_in, src_in);
  if (guide_in.channels() != 1 || src_in.channels() != 1) {
    throw Error("guided filter (running sums): guide and source must have one channel");
  }
  if (radius <= kMaxFusedRadius) {
    cv::Mat q = GuidedFilter(options, guide_in, src_in);
    if (row_done) {
      for (int y = 0; y < q.rows; ++y) row_done(y, q.ptr<float>(y));
    }
    return q;
  }
  const cv::Mat guide = Continuous(guide_in);
  const bool self = guide_in.data == src_in.data;
  return GuidedGray(guide, self ? guide : Continuous(src_in), radius, static_cast<float>(eps), self,
                    /*running=*/true, row_done);
}

cv::Mat GuidedFilterSelf(const GuidedFilterOptions& options, const cv::Mat& image) {
  if (image.channels() == 1) return GuidedFilter(options, image, image);
  CheckInputs(options, image, image);
  if (image.channels() == 3 && options.subsample == 1 && options.radius >= 1) {
    // Interleaved, streamed, O(1) box sums per value: no per-channel planes.
    const cv::Mat src = Continuous(image);
    guided_segments::Stream stream(src, options.radius, static_cast<float>(options.eps));
    cv::Mat q(src.size(), CV_32FC3);
    for (int t = 0; t < src.rows; ++t) stream.Row(t, q.ptr<float>(t));
    return q;
  }
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (cv::Mat& p : planes) p = GuidedFilter(options, p, p);
  cv::Mat out;
  cv::merge(planes, out);
  return out;
}

void GuidedFilterSelfRows(const std::vector<GuidedFilterOptions>& options, const cv::Mat& image_in,
                          const std::function<void(int, const std::vector<const float*>&)>& emit) {
  const int channels = image_in.channels();
  if (channels != 1 && channels != 3) {
    throw Error("guided filter rows: expected a one- or three-channel image");
  }
  const cv::Mat image = Continuous(image_in);
  std::vector<std::unique_ptr<GrayStream>> streams(options.size());
  std::vector<std::unique_ptr<guided_segments::Stream>> colour(options.size());
  std::vector<cv::Mat> whole(options.size());  // variants not streamed: filtered in one go
  for (size_t k = 0; k < options.size(); ++k) {
    CheckInputs(options[k], image, image);
    const bool stream = options[k].radius >= 1 && options[k].subsample == 1;
    if (!stream) {
      whole[k] = GuidedFilterSelf(options[k], image);
    } else if (channels == 3) {
      colour[k] = std::make_unique<guided_segments::Stream>(image, options[k].radius,
                                                            static_cast<float>(options[k].eps));
    } else {
      streams[k] = std::make_unique<GrayStream>(image, image, options[k].radius,
                                                static_cast<float>(options[k].eps), true);
    }
  }
  const size_t n = static_cast<size_t>(image.cols) * channels;
  std::vector<float> rows(options.size() * n);
  std::vector<const float*> ptrs(options.size());
  for (int y = 0; y < image.rows; ++y) {
    for (size_t k = 0; k < options.size(); ++k) {
      if (streams[k] || colour[k]) {
        float* dst = rows.data() + k * n;
        if (streams[k]) {
          streams[k]->Row(y, dst);
        } else {
          colour[k]->Row(y, dst);
        }
        ptrs[k] = dst;
      } else {
        ptrs[k] = whole[k].ptr<float>(y);
      }
    }
    emit(y, ptrs);
  }
}

}  // namespace turbid
