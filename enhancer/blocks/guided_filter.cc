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

#if defined(__x86_64__)
#include <immintrin.h>
#endif

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

// The same sums of 4 (one plane pair) for `count` positions from the given pointers: the
// chunked interleaved stream (GrayStream::Chunked) forms them piece by piece.
template <int S>
TURBID_ROW_KERNEL void QuadSumsRange(const float* __restrict e0, const float* __restrict e1,
                                     float* __restrict q0, float* __restrict q1, int count) {
  for (int x = 0; x < count; ++x) {
    q0[x] = e0[x] + e0[x + S] + e0[x + 2 * S] + e0[x + 3 * S];
    q1[x] = e1[x] + e1[x + S] + e1[x + 2 * S] + e1[x + 3 * S];
  }
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define TURBID_AVX2 __attribute__((target("avx2")))

// The interleaved (three-channel) stream's column-sum step of two planes fused with their sums of
// 4 (QuadSumsRange<3>), so the updated column sums are not read back: for x in [0, n) the update
// c[x] = c[x] + (add[x] - sub[x]) (kSquare: the second plane's terms are add[x]^2 and sub[x]^2,
// as ColumnStepSelf; else its own rows, as ColumnStepPair; kAdd / kSub: which rows there are, the
// expressions of those kernels' other branches), and the sums of 4 at positions x - 16 for
// x in [0, n8), n8 = n rounded down to 8: q[j] = ((c[j] + c[j + 3]) + c[j + 6]) + c[j + 9]. Each
// vector of sums is formed in registers from the three last vectors of column sums (shifted by
// lane permutations) once the one holding c[j + 9] is updated. c[-16 .. -1] must be final
// (earlier chunks or the zero padding). Same operations in the same order as the two separate
// passes, so bit-identical. Returns n8.
// Sums of 4 at j .. j + 7 from the column sums v0 = c[j ..], v1 = c[j + 8 ..], v2 = c[j + 16 ..]:
// the operands c[j + 3 ..], c[j + 6 ..], c[j + 9 ..] by lane shifts of the pairs (v0, v1), (v1,
// v2).
TURBID_AVX2 inline __m256 Quad3(__m256 v0, __m256 v1, __m256 v2) {
  const __m256i a = _mm256_castps_si256(v0), b = _mm256_castps_si256(v1);
  const __m256i t = _mm256_permute2f128_si256(a, b, 0x21);  // v0's high half, v1's low half
  const __m256i u = _mm256_permute2f128_si256(b, _mm256_castps_si256(v2), 0x21);
  const __m256 s3 = _mm256_castsi256_ps(_mm256_alignr_epi8(t, a, 12));
  const __m256 s6 = _mm256_castsi256_ps(_mm256_alignr_epi8(b, t, 8));
  const __m256 s9 = _mm256_castsi256_ps(_mm256_alignr_epi8(u, b, 4));
  return _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(v0, s3), s6), s9);
}

// One vector of a column-sum update (the rows' squares when kSquare); returns the new sums.
template <bool kSquare, bool kAdd, bool kSub>
TURBID_AVX2 inline __m256 ColumnStep8(float* c, const float* add, const float* sub) {
  const __m256 cv = _mm256_loadu_ps(c);
  __m256 a = _mm256_setzero_ps(), s = _mm256_setzero_ps();
  if (kAdd) a = _mm256_loadu_ps(add);
  if (kSub) s = _mm256_loadu_ps(sub);
  if (kSquare) {
    a = _mm256_mul_ps(a, a);
    s = _mm256_mul_ps(s, s);
  }
  const __m256 v = kAdd && kSub ? _mm256_add_ps(cv, _mm256_sub_ps(a, s))
                   : kAdd       ? _mm256_add_ps(cv, a)
                                : _mm256_sub_ps(cv, s);
  _mm256_storeu_ps(c, v);
  return v;
}

template <bool kSquare, bool kAdd, bool kSub>
TURBID_AVX2 int ColumnStepQuads3(float* c0, float* c1, const float* add0, const float* sub0,
                                 const float* add1, const float* sub1, float* q0, float* q1,
                                 int n) {
  if (!kAdd) add0 = add1 = c0;  // unused: any valid pointer (no arithmetic on null)
  if (!kSub) sub0 = sub1 = c0;
  __m256 a0 = _mm256_loadu_ps(c0 - 16), a1 = _mm256_loadu_ps(c0 - 8);
  __m256 b0 = _mm256_loadu_ps(c1 - 16), b1 = _mm256_loadu_ps(c1 - 8);
  int x = 0;
  for (; x + 8 <= n; x += 8) {
    const __m256 a2 = ColumnStep8<false, kAdd, kSub>(c0 + x, add0 + x, sub0 + x);
    const __m256 b2 = kSquare ? ColumnStep8<true, kAdd, kSub>(c1 + x, add0 + x, sub0 + x)
                              : ColumnStep8<false, kAdd, kSub>(c1 + x, add1 + x, sub1 + x);
    _mm256_storeu_ps(q0 + x - 16, Quad3(a0, a1, a2));
    _mm256_storeu_ps(q1 + x - 16, Quad3(b0, b1, b2));
    a0 = a1, a1 = a2, b0 = b1, b1 = b2;
  }
  const int n8 = x;
  for (; x < n; ++x) {  // the last < 8 values: the update only
    const float a = kAdd ? add0[x] : 0.0f, s = kSub ? sub0[x] : 0.0f;
    const float a2 = kSquare ? a * a : (kAdd ? add1[x] : 0.0f);
    const float s2 = kSquare ? s * s : (kSub ? sub1[x] : 0.0f);
    c0[x] = kAdd && kSub ? c0[x] + (a - s) : kAdd ? c0[x] + a : c0[x] - s;
    c1[x] = kAdd && kSub ? c1[x] + (a2 - s2) : kAdd ? c1[x] + a2 : c1[x] - s2;
  }
  return n8;
}

// ColumnStepQuads3 for the rows present (add / sub null: none), as ColumnStepSelf (kSquare) or
// ColumnStepPair; returns 0 without doing anything when neither row is there (the column sums do
// not change, and the sums of 4 are left to QuadSumsRange).
template <bool kSquare>
TURBID_AVX2 int ColumnStepQuads3Rows(float* c0, float* c1, const float* add0, const float* sub0,
                                     const float* add1, const float* sub1, float* q0, float* q1,
                                     int n) {
  if (add0 != nullptr && sub0 != nullptr) {
    return ColumnStepQuads3<kSquare, true, true>(c0, c1, add0, sub0, add1, sub1, q0, q1, n);
  }
  if (add0 != nullptr) {
    return ColumnStepQuads3<kSquare, true, false>(c0, c1, add0, sub0, add1, sub1, q0, q1, n);
  }
  if (sub0 != nullptr) {
    return ColumnStepQuads3<kSquare, false, true>(c0, c1, add0, sub0, add1, sub1, q0, q1, n);
  }
  return 0;
}
#undef TURBID_AVX2
#endif

// Values per chunk of the interleaved stream's running steps (GrayStream::Chunked): the chunk's
// rows of column sums, sums of 4 and coefficients stay within L1.
constexpr int kChunkValues = 384;

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
// `channels` 3: a self-guided interleaved image, each channel its own guide, every step the
// one-channel filter's arithmetic on each channel (the values of a row are processed together,
// the horizontal sums taking every third value); radius 1..kMaxFusedRadius only.
class GrayStream {
 public:
  GrayStream(const cv::Mat& guide, const cv::Mat& src, int r, float eps, bool self,
             int channels = 1, bool running = false)
      : guide_(guide),
        src_(src),
        r_(r),
        eps_(eps),
        self_(self),
        h_(guide.rows),
        w_(guide.cols * channels),
        pad_(r * channels),
        window_(2 * r + 1),
        ext_len_(w_ + 2 * pad_),
        planes_a_(self ? 2 : 4),  // I, I^2 [, p, I p]
        ring_(std::min(window_ + 1, h_)),
        ext_(static_cast<size_t>(planes_a_ + 2) * ext_len_, 0.0f),
        inv_cx_(w_),
        a_ring_(ring_, w_, CV_32F),
        b_ring_(ring_, w_, CV_32F) {
    CV_Assert(channels == 1 || (channels == 3 && self && r >= 1 && r <= kMaxFusedRadius));
    for (int x = 0; x < w_; ++x) {
      inv_cx_[x] = 1.0f / static_cast<float>(InvCount(x / channels, r_, guide.cols));
    }
    if (r_ >= 1 && r_ <= kMaxFusedRadius) {
      fused_ = FusedKernelsFor(r_, channels);
    }
    // Buffers of the path in use: sums of 4 for the portable fused kernels (W >= 9); window sums
    // and doubling scratch for the unfused one.
    if (fused_.quads != nullptr) quads_.assign(static_cast<size_t>(planes_a_ + 2) * ext_len_, 0.0f);
    chunked_ = channels == 3 && fused_.apply != nullptr;
#ifdef TURBID_HAVE_COLUMN_QUADS3
    fuse_quads_ = chunked_ && !quads_.empty() && enhancer_internal::UseHandWrittenAvx2();
#endif
    if (fused_.apply == nullptr) {
      sums_.assign(static_cast<size_t>(planes_a_ + 2) * w_, 0.0f);
      t0_.resize(ext_len_);
      t1_.resize(ext_len_);
      if (running) {
        CV_Assert(channels == 1);
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

  // Whether stage A prefetches the input row of its next step (default on; off for a stream
  // whose rows another stream of the same image has fetched already).
  void SetPrefetchNextRow(bool on) { prefetch_next_ = on; }

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
      if (chunked_) {
        const float* a_add = RingRow(a_ring_, add);
        const float* a_sub = RingRow(a_ring_, sub);
        const float* b_add = RingRow(b_ring_, add);
        const float* b_sub = RingRow(b_ring_, sub);
        const float inv_cy = 1.0f / static_cast<float>(InvCount(t, r_, h_));
        const float* guide = guide_.ptr<float>(t);
        Chunked(
            ka,
            [&](int c0, int n) {
              return ColumnChunk<false>(ka, c0, n, a_add, a_sub, b_add, b_sub);
            },
            [&](int o0, int n) {
              SplitAtBorders(o0, n, [&](int x0, int m, bool uniform) {
                (uniform ? fused_.apply_uniform : fused_.apply)(
                    Ext(ka) + x0, Ext(kb) + x0, Offset(Quad(ka), x0), Offset(Quad(kb), x0),
                    guide + x0, inv_cx_.data() + x0, inv_cy, dst + x0, m);
              });
            });
        return;
      }
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
  template <typename T>
  static T* Offset(T* p, int n) {
    return p == nullptr ? nullptr : p + n;
  }
  // The sums of 4 formed with the column-sum update of a chunk trail its first column by this many
  // padded positions (ColumnStepQuads3 reads the 16 column sums before the chunk).
  static constexpr int kQuadLag = 16;
  // The chunk's column-sum update of planes k, k + 1 (kSquare: stage A's I and I^2 from one row
  // pair; else stage B's a and b) on values [c0, c0 + n); where fuse_quads_, with the sums of 4 at
  // padded positions [max(pad + c0 - kQuadLag, 0), + m) (ColumnStepQuads3; returns m). Its first
  // kQuadLag - pad - c0 values, if any, are updated alone (the kernel reads the 16 column sums
  // before where it starts, which must lie in the padding or earlier chunks).
  template <bool kSquare>
  int ColumnChunk(int k, int c0, int n, const float* add0, const float* sub0, const float* add1,
                  const float* sub1) {
    auto plain = [&](int from, int count) {
      float* e0 = Ext(k) + pad_ + from;
      float* e1 = Ext(k + 1) + pad_ + from;
      if (kSquare) {
        ColumnStepSelf(e0, e1, Offset(add0, from), Offset(sub0, from), count);
      } else {
        ColumnStepPair(e0, e1, Offset(add0, from), Offset(sub0, from), Offset(add1, from),
                       Offset(sub1, from), count);
      }
    };
#ifdef TURBID_HAVE_COLUMN_QUADS3
    const int lead = std::max(kQuadLag - pad_ - c0, 0);
    if (fuse_quads_ && lead < n) {
      if (lead > 0) plain(c0, lead);
      const int from = c0 + lead;
      // The sums of 4 are written from 16 positions before the first column updated here.
      static_assert(kQuadLag == 16, "ColumnStepQuads3's lag");
      return ColumnStepQuads3Rows<kSquare>(
          Ext(k) + pad_ + from, Ext(k + 1) + pad_ + from, Offset(add0, from), Offset(sub0, from),
          Offset(add1, from), Offset(sub1, from), Quad(k) + pad_ + from, Quad(k + 1) + pad_ + from,
          n - lead);  // the update is done (0: no sums formed)
    }
#endif
    plain(c0, n);
    return 0;
  }
  // One running step of the interleaved stream (stage A: planes 0, 1; stage B: a, b), chunk by
  // chunk along the row so that what a chunk's column-sum update writes is still in L1 when the
  // sums of 4 and the window sums read it: update(c0, n) updates the column sums of values
  // [c0, c0 + n) and returns m > 0 when it also formed the sums of 4 at padded positions
  // [pad + c0 - kQuadLag, pad + c0 - kQuadLag + m) (ColumnStepQuads3), else 0; then the missing
  // sums of 4 of planes k, k + 1 and window(o0, n) the outputs [o0, o0 + n) whose windows lie
  // within the updated columns (output x reads the padded sums up to x + 2 pad, i.e. columns up to
  // x + pad; the sums of 4 it reads end sooner). Every value gets the arithmetic of the whole-row
  // passes, so the results are bit-identical to them.
  template <typename Update, typename Window>
  void Chunked(int k, Update&& update, Window&& window) {
    constexpr int kS = 3;                                   // values per pixel
    const int quads_end = w_ + 4 * kS * (window_ / 4 - 1);  // positions QuadSumsPair forms
    int quads_done = 0, out_done = 0;
    for (int c0 = 0; c0 < w_; c0 += kChunkValues) {
      const int c1 = std::min(c0 + kChunkValues, w_);
      const int fused = update(c0, c1 - c0);
      const bool last = c1 == w_;
      if (!quads_.empty()) {
        if (fused > 0) {  // the update formed the sums of 4 at [f0, f0 + fused)
          const int f0 = std::max(pad_ + c0 - kQuadLag, 0);
          if (f0 > quads_done) {  // those before it read only final column sums
            QuadSumsRange<kS>(Ext(k) + quads_done, Ext(k + 1) + quads_done, Quad(k) + quads_done,
                              Quad(k + 1) + quads_done, f0 - quads_done);
          }
          quads_done = std::max(quads_done, f0 + fused);
        }
        // The sum of 4 at i reads the padded sums i .. i + 3 kS.
        const int q1 = last ? quads_end : std::min(pad_ + c1 - 3 * kS, quads_end);
        if (q1 > quads_done) {
          QuadSumsRange<kS>(Ext(k) + quads_done, Ext(k + 1) + quads_done, Quad(k) + quads_done,
                            Quad(k + 1) + quads_done, q1 - quads_done);
          quads_done = q1;
        }
      }
      const int o1 = last ? w_ : c1 - pad_;
      if (o1 > out_done) {
        window(out_done, o1 - out_done);
        out_done = o1;
      }
    }
  }
  // Values [o0, o0 + n) cut where the window counts along x change: f(x0, m, uniform) on each
  // piece, uniform where every value lies at least r pixels from both borders (count 2r + 1).
  template <typename F>
  void SplitAtBorders(int o0, int n, F&& f) {
    const int lo = std::min(pad_, w_), hi = std::max(w_ - pad_, lo), end = o0 + n;
    const int cuts[4] = {o0, std::clamp(lo, o0, end), std::clamp(hi, o0, end), end};
    for (int i = 0; i < 3; ++i) {
      if (cuts[i + 1] > cuts[i]) f(cuts[i], cuts[i + 1] - cuts[i], i == 1);
    }
  }
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
    } else if (chunked_) {
      const float inv_cy = 1.0f / static_cast<float>(InvCount(y, r_, h_));
      float* ar = a_ring_.ptr<float>(y % ring_);
      float* br = b_ring_.ptr<float>(y % ring_);
      // The next step's new row follows this one's in memory (a continuous image): fetched into
      // L2 while this row is worked on (else its first reads wait for memory; the hardware
      // prefetchers stop at page boundaries).
      const char* next = prefetch_next_ && add != nullptr && y + r_ + 1 < h_
                             ? reinterpret_cast<const char*>(add + w_)
                             : nullptr;
      Chunked(
          0,
          [&](int c0, int n) {
            if (next != nullptr) {
              const char* end = next + sizeof(float) * (c0 + n);
              for (const char* p = next + sizeof(float) * c0; p < end; p += 64) {
                __builtin_prefetch(p, 0, 2);
              }
            }
            return ColumnChunk<true>(0, c0, n, add, sub, nullptr, nullptr);
          },
          [&](int o0, int n) {
            SplitAtBorders(o0, n, [&](int x0, int m, bool uniform) {
              (uniform ? fused_.self_coefficients_uniform : fused_.self_coefficients)(
                  Ext(0) + x0, Ext(1) + x0, Offset(Quad(0), x0), Offset(Quad(1), x0),
                  inv_cx_.data() + x0, inv_cy, eps_, ar + x0, br + x0, m);
            });
          });
      return;
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
  FusedKernels fused_;    // empty beyond kMaxFusedRadius (window sums by binary doubling)
  bool chunked_ = false;  // interleaved colour: the running steps chunk by chunk (Chunked)
  [[maybe_unused]] bool fuse_quads_ = false;  // chunked, sums of 4, AVX2: ColumnStepQuads3
  bool prefetch_next_ = true;  // stage A prefetches the next input row (SetPrefetchNextRow)
  int next_a_ = 0;
};

cv::Mat GuidedGray(const cv::Mat& guide, const cv::Mat& src, int r, float eps, bool self,
                   bool running = false,
                   const std::function<void(int, float*)>& row_done = nullptr) {
  GrayStream stream(guide, src, r, eps, self, 1, running);
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
                                                static_cast<float>(options[k].eps), true, channels);
    }
  }
  // The next input row is prefetched by the stream that reads furthest ahead (the largest
  // radius) only: the others read it a few rows later, from L2.
  int widest = -1;
  for (size_t k = 0; k < options.size(); ++k) {
    if (streams[k] && (widest < 0 || options[k].radius > options[widest].radius)) {
      widest = static_cast<int>(k);
    }
  }
  for (size_t k = 0; k < options.size(); ++k) {
    if (streams[k]) streams[k]->SetPrefetchNextRow(static_cast<int>(k) == widest);
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
