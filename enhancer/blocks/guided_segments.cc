#include "enhancer/blocks/guided_segments.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <utility>

#include "core/cpu.h"

namespace turbid::guided_segments {
namespace {

// Portable vector of 8 floats (plain loops; no FMA contraction is relied on either way).
struct Portable {
  static constexpr int kLanes = 8;
  struct V {
    float v[8];
  };
  static V Load(const float* p) {
    V r;
    std::memcpy(r.v, p, sizeof(r.v));
    return r;
  }
  static void Store(float* p, const V& x) { std::memcpy(p, x.v, sizeof(x.v)); }
  template <typename F>
  static V Map(const V& a, const V& b, F f) {
    V r;
    for (int k = 0; k < 8; ++k) r.v[k] = f(a.v[k], b.v[k]);
    return r;
  }
  static V Add(const V& a, const V& b) {
    return Map(a, b, [](float x, float y) { return x + y; });
  }
  static V Sub(const V& a, const V& b) {
    return Map(a, b, [](float x, float y) { return x - y; });
  }
  static V Mul(const V& a, const V& b) {
    return Map(a, b, [](float x, float y) { return x * y; });
  }
  static V Div(const V& a, const V& b) {
    return Map(a, b, [](float x, float y) { return x / y; });
  }
  static V Set1(float x) {
    V r;
    std::fill(r.v, r.v + 8, x);
    return r;
  }
  static V MulAdd(const V& a, const V& b, const V& c) { return Add(Mul(a, b), c); }
  using M = int;
  static M ShiftBy(int m) { return m; }
  static V Shifted(M m, const V& x) {
    V r;
    for (int k = 0; k < 8; ++k) r.v[k] = k + m >= 0 && k + m < 8 ? x.v[k + m] : 0.0f;
    return r;
  }
  static V NegMulAdd(const V& a, const V& b, const V& c) { return Sub(c, Mul(a, b)); }
};

#include "enhancer/blocks/guided_segments_kernels.h"  // NOLINT(build/include): the kernels, here

void StageAPortable(const Geometry& g, float* c_i, float* c_ii, const float* add, const float* sub,
                    bool update, const float* inv_x, float inv_y, float eps, float* a, float* b) {
  StageAKernel<Portable>(g, c_i, c_ii, add, sub, update, inv_x, inv_y, eps, a, b);
}

void StageBPortable(const Geometry& g, float* c_a, float* c_b, const float* add_a,
                    const float* sub_a, const float* add_b, const float* sub_b, bool update,
                    const float* inv_x, float inv_y, const float* guide, float* q) {
  StageBKernel<Portable>(g, c_a, c_b, add_a, sub_a, add_b, sub_b, update, inv_x, inv_y, guide, q);
}

void DirectPortable(size_t n, const float* const* rows0, const float* const* rows1, int count,
                    float* c0, float* c1) {
  DirectColumnsKernel<Portable>(n, rows0, rows1, count, c0, c1);
}

void TransposeInPortable(const Geometry& g, const float* const* src, float* seg) {
  for (int k = 0; k < g.K; ++k) {
    for (int j = 0; j < g.L * 3; ++j) seg[j * g.K + k] = src[k][j];
  }
}

void TransposeOutPortable(const Geometry& g, const float* seg, float* out, int limit) {
  for (int k = 0; k < g.K; ++k) {
    const int base = k * g.L * 3;
    const int count = std::min(g.L * 3, limit - base);
    for (int j = 0; j < count; ++j) out[base + j] = seg[j * g.K + k];
  }
}

// The window's pixel count along one axis of n pixels at position p (clipped window).
int Count(int p, int r, int n) { return std::min(p + r, n - 1) - std::max(p - r, 0) + 1; }

constexpr int kAnchorRows = 64;  // vertical sums recomputed directly every this many rows

}  // namespace

void Buffer::Assign(size_t count) {
  storage.assign(count + 16, 0.0f);
  const uintptr_t p = reinterpret_cast<uintptr_t>(storage.data());
  data = storage.data() + ((64 - p % 64) % 64) / sizeof(float);
}

Geometry MakeGeometry(int cols, int r, int lanes) {
  Geometry g;
  g.K = lanes;
  g.cols = cols;
  g.r = r;
  g.L = (cols + 8 * lanes - 1) / (8 * lanes) * 8;
  g.lc = g.L + 2 * r;
  return g;
}

Kernels PortableKernels() {
  Kernels k;
  k.stage_a = StageAPortable;
  k.stage_b = StageBPortable;
  k.direct = DirectPortable;
  k.transpose_in = TransposeInPortable;
  k.transpose_out = TransposeOutPortable;
  k.lanes = Portable::kLanes;
  return k;
}

Kernels ChosenKernels() {
  const CpuLevel level = KernelCpuLevel();
  const Kernels avx512 = level >= CpuLevel::kAvx512 ? Avx512Kernels() : Kernels{};
  if (avx512.stage_a != nullptr) return avx512;
  const Kernels avx2 = level >= CpuLevel::kAvx2Fma ? Avx2FmaKernels() : Kernels{};
  return avx2.stage_a != nullptr ? avx2 : PortableKernels();
}

Input::Input(const cv::Mat& image, int halo)
    : image_(image),
      k_(ChosenKernels()),
      g_(MakeGeometry(image.cols, halo, k_.lanes)),
      ring_(2 * halo + 2) {
  CV_Assert(image.type() == CV_32FC3 && image.isContinuous() && halo >= 1);
  stride_ = static_cast<size_t>(g_.L) * 3 * g_.K;
  edges_.Assign(static_cast<size_t>(g_.K * g_.L) * 3);
  seg_.Assign(ring_ * stride_);
}

const float* Input::Row(int y) {
  while (next_ <= y) {
    const int t = next_++;
    const float* row = image_.ptr<float>(t);
    const float* src[16];
    for (int k = 0; k < g_.K; ++k) {
      const int p0 = k * g_.L, p1 = p0 + g_.L;  // the segment's pixels [p0, p1)
      if (p1 <= g_.cols) {
        src[k] = row + static_cast<ptrdiff_t>(p0) * 3;  // inside the image: read in place
        continue;
      }
      // Past the image's end: the pixels inside it copied, the rest stays zero.
      float* e = edges_.data + static_cast<size_t>(k) * g_.L * 3;
      if (g_.cols > p0) {
        std::memcpy(e, row + static_cast<ptrdiff_t>(p0) * 3, sizeof(float) * (g_.cols - p0) * 3);
      }
      src[k] = e;
    }
    k_.transpose_in(g_, src, seg_.data + static_cast<size_t>(t % ring_) * stride_);
  }
  CV_DbgAssert(y > next_ - 1 - ring_);
  return seg_.data + static_cast<size_t>(y % ring_) * stride_;
}

void Input::ToNatural(const float* seg, float* dst) const {
  k_.transpose_out(g_, seg, dst, g_.cols * 3);
}

Stream::Stream(std::unique_ptr<Input> own, Input* input, int r, float eps)
    : own_(std::move(own)),
      input_(input != nullptr ? input : own_.get()),
      r_(r),
      h_(input_->rows()),
      eps_(eps),
      k_(ChosenKernels()),
      g_(MakeGeometry(input_->image().cols, r, k_.lanes)) {
  CV_Assert(r >= 1 && r <= input_->halo() && input_->lanes() == g_.K);
  const int K = g_.K, col = 3 * K;  // lanes, floats a column
  ring_ = 2 * r + 2;
  c_stride_ = static_cast<size_t>(g_.lc) * col;
  ab_stride_ = static_cast<size_t>(g_.L) * col;
  a_.Assign(ring_ * ab_stride_);
  b_.Assign(ring_ * ab_stride_);
  c_i_.Assign(c_stride_);
  c_ii_.Assign(c_stride_);
  c_a_.Assign(c_stride_);
  c_b_.Assign(c_stride_);
  q_seg_.Assign(static_cast<size_t>(g_.L) * col);
  inv_x_.Assign(static_cast<size_t>(g_.L) * K);
  for (int k = 0; k < K; ++k) {
    for (int s = 0; s < g_.L; ++s) {
      const int p = k * g_.L + s;
      inv_x_.data[s * K + k] = p < g_.cols ? 1.0f / static_cast<float>(Count(p, r, g_.cols)) : 0.0f;
    }
  }
}

template <typename Row0, typename Row1>
void Stream::Direct(int t, float* c0, float* c1, Row0 row0, Row1 row1) {
  constexpr bool kSquare = std::is_same_v<Row1, std::nullptr_t>;
  rows0_.clear();
  rows1_.clear();
  for (int y = std::max(t - r_, 0); y <= std::min(t + r_, h_ - 1); ++y) {
    rows0_.push_back(row0(y));
    if constexpr (!kSquare) rows1_.push_back(row1(y));
  }
  const size_t main = static_cast<size_t>(r_) * 3 * g_.K;  // the columns s in [0, L)
  k_.direct(ab_stride_, rows0_.data(), kSquare ? nullptr : rows1_.data(),
            static_cast<int>(rows0_.size()), c0 + main, c1 + main);
}

void Stream::StageA(int y) {
  input_->Row(std::min(y + r_, h_ - 1));  // transposed up to there
  const bool anchor = y % kAnchorRows == 0;
  if (anchor) {
    Direct(
        y, c_i_.data, c_ii_.data, [&](int yy) { return InRow(yy); }, nullptr);
  }
  const float* add = y + r_ < h_ ? InRow(y + r_) : nullptr;
  const float* sub = y - r_ - 1 >= 0 ? InRow(y - r_ - 1) : nullptr;
  const float inv_y = 1.0f / static_cast<float>(Count(y, r_, h_));
  k_.stage_a(g_, c_i_.data, c_ii_.data, add, sub, !anchor, inv_x_.data, inv_y, eps_, ARow(y),
             BRow(y));
}

const float* Stream::RowSegments(int t) {
  const int need = std::min(t + r_, h_ - 1);
  while (next_a_ <= need) StageA(next_a_++);
  const bool anchor = t % kAnchorRows == 0;
  if (anchor) {
    Direct(
        t, c_a_.data, c_b_.data, [&](int yy) { return static_cast<const float*>(ARow(yy)); },
        [&](int yy) { return static_cast<const float*>(BRow(yy)); });
  }
  const bool has_add = t + r_ < h_, has_sub = t - r_ - 1 >= 0;
  const float inv_y = 1.0f / static_cast<float>(Count(t, r_, h_));
  k_.stage_b(g_, c_a_.data, c_b_.data, has_add ? ARow(t + r_) : nullptr,
             has_sub ? ARow(t - r_ - 1) : nullptr, has_add ? BRow(t + r_) : nullptr,
             has_sub ? BRow(t - r_ - 1) : nullptr, !anchor, inv_x_.data, inv_y, InRow(t),
             q_seg_.data);
  return q_seg_.data;
}

}  // namespace turbid::guided_segments
