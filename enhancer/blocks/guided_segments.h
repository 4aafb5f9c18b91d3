// The self-guided filter of an interleaved three-channel image (each channel its own guide, He 2013
// Alg. 1) with O(1) box sums per value in both directions, streamed by rows (issue 29 item 6).
//
// Layout: a row of `cols` pixels is cut into K segments of L pixels (K = 8, or 16 on the AVX-512
// path; L a multiple of 8, K L >= cols); segment k is lane k of every K-float vector. A "segment
// row" holds, per column s of the segment and per channel c, one vector: lane k = pixel k L + s,
// channel c (zero outside [0, cols)). In this layout the horizontal box sums are running sums
// along s, lane by lane, with no shuffles: S(s) = S(s - 1) + c(s + r) - c(s - r - 1). Only the
// column sums carry a halo of r columns each side, and it is not computed: column s < 0 or
// s >= L of segment k is a column of segment k - 1 or k + 1, one lane shift of the computed ones
// (so every value is computed once). Input rows are transposed into the layout once, output rows
// back once (8 x 8 transposes; 16 x 16 with 16 lanes).
//
// Per stream: stage A keeps running column sums of I and I^2 over the window's rows (float,
// recomputed directly every kAnchorRows rows so rounding cannot drift), forms the window sums
// (re-started from a direct sum every 64 columns), and a = var / (var + eps), b = m (1 - a) into a
// ring of 2r + 2 segment rows; stage B, r rows behind, does the same for a and b and writes
// q = (sum a * I + sum b) / N. Window: clipped to the image, N the number of pixels inside it (as
// GuidedFilter). Equal to the whole-image filter to float rounding (tests: a double-precision
// transcription; the AVX2 and AVX-512 paths use FMA and a refined reciprocal). Results do not
// depend on threads (one stream, one thread); the lane count (the kernels chosen per process by
// core/cpu.h's level) moves them within float rounding.
#pragma once

#include <cstddef>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

namespace turbid::guided_segments {

// Zero-filled floats from a 64-byte line on (each segment column is 3 K floats: every vector is
// aligned to its size).
struct Buffer {
  std::vector<float> storage;
  float* data = nullptr;
  void Assign(size_t count);
};

// The geometry shared by the row kernels (all counts in columns of the segment layout, one
// column = 3 channels x K lanes = 3 K floats).
struct Geometry {
  int K = 8;     // lanes: segments per row (8 or 16)
  int cols = 0;  // image width in pixels
  int r = 0;     // radius
  int L = 0;     // pixels per segment (multiple of 8)
  int lc = 0;    // columns of the column sums: s in [-r, L + r) (input, a, b, q rows: L columns)
};

Geometry MakeGeometry(int cols, int r, int lanes = 8);

// Row kernels of one path (portable loops, AVX2 + FMA, or AVX-512 with 16 lanes) for geometries
// of `lanes` lanes. Arrays are segment rows (3 K floats a column). Stage A: column sums c_i, c_ii
// (lc columns, column r + s holding s) updated on s in [0, L) with segment rows add / sub (L
// columns; either null: absent; update false: the sums are current already), their halo filled
// from the neighbouring lanes, window sums over s in [j - r, j + r] for j in [0, L), coefficients
// into a, b (L columns); inv_x: 1 / (window count along x) per column and lane (0 outside the
// image, which makes a = b = 0 there). Stage B: the same on c_a, c_b (lc columns) from rows of a
// and b, output for s in [0, L) with guide (the input segment row) into q.
struct Kernels {
  int lanes = 8;
  void (*stage_a)(const Geometry& g, float* c_i, float* c_ii, const float* add, const float* sub,
                  bool update, const float* inv_x, float inv_y, float eps, float* a,
                  float* b) = nullptr;
  void (*stage_b)(const Geometry& g, float* c_a, float* c_b, const float* add_a, const float* sub_a,
                  const float* add_b, const float* sub_b, bool update, const float* inv_x,
                  float inv_y, const float* guide, float* q) = nullptr;
  // Direct column sums of `count` segment rows of n floats (n a multiple of 4 K): c0 = sum of
  // rows0[y], c1 = sum of rows1[y], or of rows0[y]^2 where rows1 is null; y in order.
  void (*direct)(size_t n, const float* const* rows0, const float* const* rows1, int count,
                 float* c0, float* c1) = nullptr;
  // Natural rows -> segment row of L columns: src[k] (k < K) holds segment k's L pixels from
  // pixel k L on (zeros past the image).
  void (*transpose_in)(const Geometry& g, const float* const* src, float* seg) = nullptr;
  // Segment row of L columns -> natural row: the first `limit` values of the K L pixels.
  void (*transpose_out)(const Geometry& g, const float* seg, float* out, int limit) = nullptr;
};

Kernels PortableKernels();
// AVX2 + FMA kernels where this build has them (GCC or Clang on x86-64), else null members.
Kernels Avx2FmaKernels();
// AVX-512 (F, DQ, VL, BW) + FMA kernels, 16 lanes, where this build has them, else null members.
Kernels Avx512Kernels();
// The kernels this process uses: AVX-512 (16 lanes) or AVX2 + FMA where KernelCpuLevel() allows,
// else portable.
Kernels ChosenKernels();

// The rows of an image (CV_32FC3, continuous) in the segment layout (L columns), for filters of
// radius <= halo; transposed once each, on demand, kept in a ring of 2 halo + 2 rows. One Input can
// feed several Streams of the same image.
class Input {
 public:
  Input(const cv::Mat& image, int halo);
  // Segment row y, transposing the rows up to y first; y at most
  // 2 halo + 1 rows behind the last row asked for.
  const float* Row(int y);
  int halo() const { return g_.r; }
  int lanes() const { return g_.K; }
  int rows() const { return image_.rows; }
  const cv::Mat& image() const { return image_; }
  // A segment row of L columns (an output) -> natural row `dst` (cols * 3 floats).
  void ToNatural(const float* seg, float* dst) const;

 private:
  const cv::Mat image_;
  Kernels k_;
  Geometry g_;
  int ring_;
  size_t stride_;
  Buffer edges_;  // segments reaching past the image: their pixels, zero-padded
  Buffer seg_;    // the ring of segment rows
  int next_ = 0;
};

// The streamed filter (radius r >= 1, eps > 0) of one image: owning its Input, or reading a
// shared one (halo >= r). Row(t, dst) writes output row t (cols * 3 floats); RowSegments(t) gives
// it in the segment layout (L columns of lanes() lanes, valid until the next call); rows in order
// 0, 1, ...
class Stream {
 public:
  Stream(const cv::Mat& image, int r, float eps)
      : Stream(std::make_unique<Input>(image, r), nullptr, r, eps) {}
  Stream(Input* input, int r, float eps) : Stream(nullptr, input, r, eps) {}
  void Row(int t, float* dst) { input_->ToNatural(RowSegments(t), dst); }
  const float* RowSegments(int t);
  // Floats per segment row of output (L columns x 3 K).
  size_t SegmentFloats() const { return static_cast<size_t>(g_.L) * 3 * g_.K; }
  int lanes() const { return g_.K; }
  int L() const { return g_.L; }

 private:
  Stream(std::unique_ptr<Input> own, Input* input, int r, float eps);
  const float* InRow(int y) { return input_->Row(y); }
  float* ARow(int y) { return a_.data + static_cast<size_t>(y % ring_) * ab_stride_; }
  float* BRow(int y) { return b_.data + static_cast<size_t>(y % ring_) * ab_stride_; }
  void StageA(int y);
  // Direct column sums over the window of row t (rows from row0(y), row1(y); row1 null: squares)
  // into columns [0, L) of c0, c1.
  template <typename Row0, typename Row1>
  void Direct(int t, float* c0, float* c1, Row0 row0, Row1 row1);

  std::unique_ptr<Input> own_;
  Input* input_;
  const int r_, h_;
  const float eps_;
  Kernels k_;
  Geometry g_;
  int ring_;
  size_t c_stride_, ab_stride_;
  Buffer a_, b_;                             // rings of segment rows of a and b
  Buffer c_i_, c_ii_, c_a_, c_b_;            // column sums
  Buffer inv_x_;                             // 1 / window count along x, per column and lane
  Buffer q_seg_;                             // one output row in the segment layout
  std::vector<const float*> rows0_, rows1_;  // the rows of a direct sum
  int next_a_ = 0;
};

}  // namespace turbid::guided_segments
