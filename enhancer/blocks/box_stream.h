// The reflect-border box family of box_filter.h, streamed: box sums of several planes a row at a
// time (BoxStream), for two radii from one pass (BoxStreamTwoRadii), and integer box counts
// (BoxCount). Templates over the row producers and consumers, so they live in this header; the
// row kernels are in box_stream.cc.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "core/row_kernel.h"

namespace turbid::box_stream {

// ---- Box sums in cv::boxFilter's order -------------------------------------------------------
// cv::boxFilter on CV_32F (OpenCV 4.6, box_filter.simd.hpp) sums in double: per row (the row
// extended by its reflected border), a window of 3 or 5 as the direct sum s0 + s1 + ... left to
// right, any other as a running sum (s = 0, s += x_0 .. x_{k-1}, then s += (x_{i+k} - x_i) per
// step, the difference formed in double); then per column a running sum over the row sums (SUM =
// 0, SUM += h_0 .. h_{k-2}, then per output row s = SUM + h_{y+k-1}, out = float(s [* scale]), SUM
// = s - h_y). Those are serial chains, one per row and one per column. The same operations in the
// same order give the same doubles; what is new is only which independent chains run side by side:
// eight rows' running sums side by side in two four-row vectors (gray; four scalar rows in
// colour) instead of one row at a time, the column step vectorised across columns, and the row
// sums kept in a ring of k + 8 rows per plane.

// Row kernels (defined in box_stream.cc as TURBID_ROW_KERNEL clones: declared here without the
// attribute, so calls go through the one dispatcher the definitions make).
// The direct sums of a window of 3 or 5 (values cn apart), left to right.
void BoxDirect3Row(const float* __restrict s, double* __restrict d, int cn, int n);

void BoxDirect5Row(const float* __restrict s, double* __restrict d, int cn, int n);

// One output row of the column running sum: s = SUM + h_new, out = float(s), SUM = s - h_old.
void BoxColumnRow(double* __restrict sum, const double* __restrict add,
                  const double* __restrict sub, float* __restrict out, int n);

void BoxColumnRowScaled(double* __restrict sum, const double* __restrict add,
                        const double* __restrict sub, float* __restrict out, double scale, int n);

void BoxAccumulateRow(double* __restrict sum, const double* __restrict add, int n);

// The running sums of four rows at once (independent chains side by side, the sums in
// registers): for each channel c, from the first sum h_r[c], h_r[(i + 1) cn + c] = h_r[i cn + c]
// + (double(e_r[(i + k) cn + c]) - double(e_r[i cn + c])) in order of i.
// The rows come as doubles (converted beforehand by vector conversions, exact): a scalar float
// to double conversion per value was the chains' bottleneck (one per cycle).
void BoxRunning4(const double* __restrict e0, const double* __restrict e1,
                 const double* __restrict e2, const double* __restrict e3, double* __restrict h0,
                 double* __restrict h1, double* __restrict h2, double* __restrict h3, int cn, int k,
                 int steps);

// BoxRunning4 for eight rows of one channel (cn = 1) whose bordered rows are `stride` values
// apart (e + r stride): the same per-row operations in the same order, h_r[i + 1] = h_r[i] +
// (e_r[i + k] - e_r[i]), but each chain step is one vector add over four rows (two vectors: rows
// 0-3 and 4-7), so eight chains run side by side instead of four (the four scalar chains of
// BoxRunning4 are latency-bound at ~1 value per cycle). The differences of four columns are
// formed row-wise and transposed (4 x 4) into column vectors; the sums are transposed back into
// the rows, stored 32-byte aligned where the rows allow it (unaligned stores split cache lines).
void BoxRunning8Gray(const double* __restrict e, size_t stride, double* const* __restrict h, int k,
                     int steps);

void WidenRow(const float* __restrict in, double* __restrict out, int n);

void BoxRunning1(const double* e, double* h, int cn, int k, int steps);

// BoxStream's buffers, kept per thread between calls (fresh pages on every call would cost more
// than the sums): the rings of row sums, the bordered input rows, the column sums and the output
// rows. One set per thread: BoxStream calls do not nest.
struct BoxScratch {
  std::vector<double> ring, sum, ext_d;
  std::vector<float> ext, out;
};

BoxScratch& ThreadBoxScratch();

// At least `count` values of v from a 64-byte line on (std::vector's data of these sizes starts
// 16 bytes past a line, so every other 32-byte access would split one); v grows as needed.
template <typename T>
T* Aligned64(std::vector<T>& v, size_t count) {
  constexpr size_t kPad = 64 / sizeof(T);
  v.resize(std::max(v.size(), count + kPad));
  const uintptr_t p = reinterpret_cast<uintptr_t>(v.data());
  return v.data() + ((64 - p % 64) % 64) / sizeof(T);
}

// Values per buffer row: n rounded up to whole 64-byte lines (rows of an aligned block stay
// aligned).
template <typename T>
size_t LineStride(size_t n) {
  constexpr size_t kLine = 64 / sizeof(T);
  return (n + kLine - 1) / kLine * kLine;
}

// Box sums of kPlanes images of the same shape (rows x cols, cn channels) streamed a row at a
// time: produce(source_row, float* const* in) writes that row of each plane into in[p] (cols cn
// values; it may be asked for a row more than once, for the reflected border); consume(y, const
// float* const* out) receives output row y of each plane, in order of y. scale 1: sums;
// otherwise each sum times scale (cv::boxFilter's normalised mean). Only a ring of k + 8 row sums
// per plane is kept, so the planes need not exist as whole images.
// The reflected border columns of a bordered row whose interior (cols pixels of cn values) is
// already at e + radius cn: columns x < radius and x >= radius + cols of the cols + 2 radius,
// copied from the interior pixels xofs[x] (BORDER_REFLECT, as cv::borderInterpolate places them).
template <typename T>
void FillReflectedBorder(T* e, int cols, int cn, int radius, const std::vector<int>& xofs) {
  const int width = cols + 2 * radius;
  for (int x = 0; x < width; ++x) {
    if (x == radius) x = std::min(radius + cols, width);  // the interior is there
    if (x >= width) break;
    for (int c = 0; c < cn; ++c) e[x * cn + c] = e[(radius + xofs[x]) * cn + c];
  }
}

// Bordered row j (of rows + 2 radius) of every plane: produce(y, in) writes image row y =
// reflect(j - radius) into the planes' interiors, then their reflected borders are filled.
// ext_row(p) is plane p's bordered row.
template <int kPlanes, typename Produce, typename ExtRow>
void ProduceBorderedRow(Produce& produce, ExtRow&& ext_row, int j, int rows, int cols, int cn,
                        int radius, const std::vector<int>& xofs) {
  float* in[kPlanes];
  for (int p = 0; p < kPlanes; ++p) in[p] = ext_row(p) + radius * cn;
  produce(cv::borderInterpolate(j - radius, rows, cv::BORDER_REFLECT), in);
  for (int p = 0; p < kPlanes; ++p) FillReflectedBorder(ext_row(p), cols, cn, radius, xofs);
}

// The first row sum of each channel of a bordered row (windows of 3 and 5: every sum, directly).
inline void FirstRowSums(const float* e, double* h, int cn, int k, int n) {
  if (k == 3) {
    BoxDirect3Row(e, h, cn, n);
  } else if (k == 5) {
    BoxDirect5Row(e, h, cn, n);
  } else {
    for (int c = 0; c < cn; ++c) {
      double sum = 0;
      for (int i = 0; i < k; ++i) sum += static_cast<double>(e[i * cn + c]);
      h[c] = sum;
    }
  }
}

// The running row sums of `count` bordered rows (windows other than 3 and 5): row b's widened
// values at ext_d(b) (rows `stride` apart), its sums at slot(b), the first already there. Eight
// gray rows side by side (BoxRunning8Gray), else four (BoxRunning4), then one at a time.
template <typename ExtD, typename Slot>
void RunningRowSums(ExtD&& ext_d, size_t stride, Slot&& slot, int count, int cn, int k, int cols) {
  int b = 0;
  for (; cn == 1 && b + 8 <= count; b += 8) {
    double* h[8];
    for (int r = 0; r < 8; ++r) h[r] = slot(b + r);
    BoxRunning8Gray(ext_d(b), stride, h, k, cols - 1);
  }
  for (; b + 4 <= count; b += 4) {
    BoxRunning4(ext_d(b), ext_d(b + 1), ext_d(b + 2), ext_d(b + 3), slot(b), slot(b + 1),
                slot(b + 2), slot(b + 3), cn, k, cols - 1);
  }
  for (; b < count; ++b) BoxRunning1(ext_d(b), slot(b), cn, k, cols - 1);
}

// The per-thread buffers of one BoxStream call, every row starting on a 64-byte line (rows
// padded to whole lines): `ring_rows` rows of row sums, `sum_rows` of column sums (zeroed), the
// planes' bordered rows of one batch (float; double when `widen`) and one output row per plane.
struct BoxBuffers {
  size_t rn = 0, on = 0, en = 0, edn = 0;  // values per row: sums, outputs, bordered f / d
  double* ring = nullptr;
  double* sums = nullptr;
  float* ext = nullptr;
  double* ext_d = nullptr;
  float* outs = nullptr;
  int batch = 0;
  float* ExtRow(int p, int b) const { return ext + (static_cast<size_t>(p) * batch + b) * en; }
  double* ExtDRow(int p, int b) const { return ext_d + (static_cast<size_t>(p) * batch + b) * edn; }
};

inline BoxBuffers MakeBoxBuffers(int planes, int n, int ext_n, int batch, size_t ring_rows,
                                 size_t sum_rows, bool widen) {
  BoxScratch& scratch = ThreadBoxScratch();
  BoxBuffers b;
  b.batch = batch;
  b.rn = LineStride<double>(n);
  b.on = LineStride<float>(n);
  b.en = LineStride<float>(ext_n);
  b.edn = LineStride<double>(ext_n);
  b.ring = Aligned64(scratch.ring, ring_rows * b.rn);
  b.sums = Aligned64(scratch.sum, sum_rows * b.rn);
  std::fill(b.sums, b.sums + sum_rows * b.rn, 0.0);
  b.ext = Aligned64(scratch.ext, static_cast<size_t>(planes) * batch * b.en);
  if (widen) b.ext_d = Aligned64(scratch.ext_d, static_cast<size_t>(planes) * batch * b.edn);
  b.outs = Aligned64(scratch.out, static_cast<size_t>(planes) * b.on);
  return b;
}

// Reflected border columns of a row of `cols` pixels extended by `radius` on each side
// (BORDER_REFLECT, as cv::borderInterpolate places them).
inline std::vector<int> ReflectedColumns(int cols, int radius) {
  std::vector<int> xofs(cols + 2 * radius);
  for (int j = 0; j < cols + 2 * radius; ++j)
    xofs[j] = cv::borderInterpolate(j - radius, cols, cv::BORDER_REFLECT);
  return xofs;
}

template <int kPlanes, typename Produce, typename Consume>
void BoxStream(int rows, int cols, int cn, int radius, double scale, Produce&& produce,
               Consume&& consume) {
  const int k = 2 * radius + 1;
  const int n = cols * cn;
  const int ext_n = (cols + k - 1) * cn;  // values per bordered row
  // Rows per batch: BoxRunning8Gray's eight chains in gray, BoxRunning4's four in colour (a
  // smaller ring).
  const int batch = cn == 1 ? 8 : 4;
  const int capacity = k + batch;
  const int total_rows = rows + k - 1;  // bordered rows j = 0 .. rows + k - 2
  const std::vector<int> xofs = ReflectedColumns(cols, radius);
  const bool running = k != 3 && k != 5;
  const BoxBuffers buf = MakeBoxBuffers(kPlanes, n, ext_n, batch,
                                        static_cast<size_t>(kPlanes) * capacity, kPlanes, running);
  const size_t ring_n = static_cast<size_t>(capacity) * buf.rn;
  auto slot = [&](int p, int j) {
    return buf.ring + p * ring_n + static_cast<size_t>(j % capacity) * buf.rn;
  };
  int produced = 0;  // bordered rows whose row sums are in the rings
  auto produce_batch = [&](int count) {
    for (int b = 0; b < count; ++b) {
      const int j = produced + b;
      ProduceBorderedRow<kPlanes>(
          produce, [&](int p) { return buf.ExtRow(p, b); }, j, rows, cols, cn, radius, xofs);
      for (int p = 0; p < kPlanes; ++p) {
        FirstRowSums(buf.ExtRow(p, b), slot(p, j), cn, k, n);
        if (running) WidenRow(buf.ExtRow(p, b), buf.ExtDRow(p, b), ext_n);
      }
    }
    for (int p = 0; running && p < kPlanes; ++p) {
      RunningRowSums([&](int b) { return buf.ExtDRow(p, b); }, buf.edn,
                     [&](int b) { return slot(p, produced + b); }, count, cn, k, cols);
    }
    produced += count;
  };
  auto need = [&](int j) {
    while (produced <= j) produce_batch(std::min(batch, total_rows - produced));
  };
  for (int j = 0; j < k - 1; ++j) {
    need(j);
    for (int p = 0; p < kPlanes; ++p) BoxAccumulateRow(buf.sums + p * buf.rn, slot(p, j), n);
  }
  const float* out[kPlanes];
  for (int p = 0; p < kPlanes; ++p) out[p] = buf.outs + p * buf.on;
  for (int y = 0; y < rows; ++y) {
    need(y + k - 1);
    for (int p = 0; p < kPlanes; ++p) {
      double* sum = buf.sums + p * buf.rn;
      float* o = buf.outs + p * buf.on;
      if (scale != 1.0) {
        BoxColumnRowScaled(sum, slot(p, y + k - 1), slot(p, y), o, scale, n);
      } else {
        BoxColumnRow(sum, slot(p, y + k - 1), slot(p, y), o, n);
      }
    }
    consume(y, out);
  }
}

// One window of BoxStreamTwoRadii: its ring of row sums, column sums and progress.
struct BoxWindow {
  int k = 0, capacity = 0, total = 0, produced = 0, accumulated = 0, emitted = 0;
  double* ring = nullptr;
  double* sum = nullptr;
};

// BoxStreamTwoRadii's column steps of window w that the rows produced so far allow, in order: the
// first k - 1 rows into the column sums, then one output row per further row (plane 0 written at
// first_plane(y), the others into `other_rows`, `on` values apart).
template <int kPlanes, typename Slot, typename Consume, typename FirstPlane>
void BoxWindowColumns(BoxWindow& w, int rows, int n, size_t rn, size_t on, float* other_rows,
                      Slot&& slot, Consume& consume, FirstPlane& first_plane) {
  while (w.accumulated < w.k - 1 && w.accumulated < w.produced) {
    for (int p = 0; p < kPlanes; ++p) BoxAccumulateRow(w.sum + p * rn, slot(p, w.accumulated), n);
    ++w.accumulated;
  }
  while (w.accumulated == w.k - 1 && w.emitted < rows && w.emitted + w.k - 1 < w.produced) {
    const int y = w.emitted;
    const float* outs[kPlanes];
    for (int p = 0; p < kPlanes; ++p) {
      float* o = p == 0 ? first_plane(y) : other_rows + p * on;
      BoxColumnRow(w.sum + p * rn, slot(p, y + w.k - 1), slot(p, y), o, n);
      outs[p] = o;
    }
    consume(y, outs);
    ++w.emitted;
  }
}

// BoxStream for two radii at once (sums, scale 1): the same box sums of the same planes over
// windows of radius `large` and `small` < large, from one pass over the input rows. The small
// window's bordered rows are a run of the large one's (bordered row j of the small window is row
// j + (large - small) of the large one's, the same source row, and its bordered columns are a
// run of the large one's), so each input row is produced and widened once. Each radius keeps its
// own ring of row sums and column sums and makes the same double operations in the same order as
// BoxStream; consume_large(y, out) and consume_small(y, out) each receive their rows in order of
// y (interleaved with each other). first_large(y) / first_small(y): where output row y of the
// first plane is written (out[0] points there).
template <int kPlanes, typename Produce, typename ConsumeLarge, typename ConsumeSmall,
          typename FirstLarge, typename FirstSmall>
void BoxStreamTwoRadii(int rows, int cols, int cn, int large, int small, Produce&& produce,
                       ConsumeLarge&& consume_large, ConsumeSmall&& consume_small,
                       FirstLarge&& first_large, FirstSmall&& first_small) {
  CV_Assert(small >= 1 && small < large);
  // Rows per batch: BoxRunning8Gray's eight chains in gray, BoxRunning4's four in colour (a
  // smaller ring).
  const int batch = cn == 1 ? 8 : 4;
  const int n = cols * cn;
  const int kl = 2 * large + 1;
  const int ext_n = (cols + kl - 1) * cn;
  const int offset = large - small;
  const std::vector<int> xofs = ReflectedColumns(cols, large);
  BoxWindow win[2];
  win[0].k = kl;
  win[1].k = 2 * small + 1;
  size_t ring_rows = 0;
  for (BoxWindow& w : win) {
    w.capacity = w.k + batch;
    w.total = rows + w.k - 1;
    ring_rows += static_cast<size_t>(kPlanes) * w.capacity;
  }
  const BoxBuffers buf = MakeBoxBuffers(kPlanes, n, ext_n, batch, ring_rows, 2 * kPlanes, true);
  win[0].ring = buf.ring;
  win[1].ring = buf.ring + static_cast<size_t>(kPlanes) * win[0].capacity * buf.rn;
  win[0].sum = buf.sums;
  win[1].sum = buf.sums + kPlanes * buf.rn;
  auto slot = [&](const BoxWindow& w, int p, int j) {
    return w.ring + (static_cast<size_t>(p) * w.capacity + j % w.capacity) * buf.rn;
  };
  // The row sums of bordered rows (count of them, from the batch's row `first`) of window w,
  // whose rows start `shift` values into the large window's bordered rows.
  auto row_sums = [&](BoxWindow& w, int first, int count, int shift) {
    for (int p = 0; p < kPlanes; ++p) {
      for (int b = first; b < first + count; ++b) {
        FirstRowSums(buf.ExtRow(p, b) + shift, slot(w, p, w.produced + b - first), cn, w.k, n);
      }
      if (w.k == 3 || w.k == 5) continue;
      RunningRowSums([&](int i) { return buf.ExtDRow(p, first + i) + shift; }, buf.edn,
                     [&](int i) { return slot(w, p, w.produced + i); }, count, cn, w.k, cols);
    }
    w.produced += count;
  };
  auto columns = [&](BoxWindow& w, auto& consume, auto& first_plane) {
    BoxWindowColumns<kPlanes>(
        w, rows, n, buf.rn, buf.on, buf.outs, [&](int p, int j) { return slot(w, p, j); }, consume,
        first_plane);
  };
  const int total = win[0].total;
  for (int j0 = 0; j0 < total; j0 += batch) {
    const int count = std::min(batch, total - j0);
    for (int b = 0; b < count; ++b) {
      ProduceBorderedRow<kPlanes>(
          produce, [&](int p) { return buf.ExtRow(p, b); }, j0 + b, rows, cols, cn, large, xofs);
      for (int p = 0; p < kPlanes; ++p) WidenRow(buf.ExtRow(p, b), buf.ExtDRow(p, b), ext_n);
    }
    row_sums(win[0], 0, count, 0);
    // The small window's rows among these: bordered rows j - offset in [0, its total).
    const int first = std::max(0, offset - j0);
    const int last = std::min(count, offset + win[1].total - j0);  // exclusive
    if (last > first) row_sums(win[1], first, last - first, offset * cn);
    columns(win[1], consume_small, first_small);
    columns(win[0], consume_large, first_large);
  }
}

// A whole image through BoxStream.
template <typename Consume>
void BoxStreamImage(const cv::Mat& src, int radius, double scale, Consume&& consume) {
  const size_t bytes = sizeof(float) * src.cols * src.channels();
  BoxStream<1>(
      src.rows, src.cols, src.channels(), radius, scale,
      [&](int y, float* const* in) { std::memcpy(in[0], src.ptr<float>(y), bytes); },
      std::forward<Consume>(consume));
}

// Box counts of [a > 0] over (2 radius + 1)^2 windows, reflected borders, streamed: Add(a) takes
// the source row of the next bordered row (in BoxStream's order: bordered rows 0, 1, ...),
// Output(y, out) writes output row y (in order of y, once rows up to y + 2 radius are in). The
// counts are integers, exact in any order of summation, so they equal the double box sums of the
// 0 / 1 indicator that they replace (and cost integer adds instead of a third double plane).
class BoxCount {
 public:
  BoxCount(int cols, int cn, int radius)
      : cols_(cols), cn_(cn), k_(2 * radius + 1), n_(cols * cn), capacity_(k_ + 8) {
    xofs_.resize(cols + k_ - 1);
    for (int j = 0; j < cols + k_ - 1; ++j)
      xofs_[j] = cv::borderInterpolate(j - radius, cols, cv::BORDER_REFLECT);
    bordered_.resize(static_cast<size_t>(cols + k_ - 1) * cn);
    prefix_.resize(bordered_.size() + 1);
    ring_.resize(static_cast<size_t>(capacity_) * n_);
    vertical_.assign(n_, 0);
  }
  void Add(const float* a) {
    // The bordered indicator row, then its window sums: direct for small windows, else as
    // differences of prefix sums (integers: any order gives the same counts).
    const int ext_n = (cols_ + k_ - 1) * cn_;
    int32_t* e = bordered_.data();
    IndicatorRow(a, e + (k_ / 2) * cn_, n_);
    FillReflectedBorder(e, cols_, cn_, k_ / 2, xofs_);
    int32_t* h = ring_.data() + static_cast<size_t>(added_ % capacity_) * n_;
    if (k_ <= 9) {
      WindowSumsDirect(e, h, cn_, k_, n_);
    } else {
      int32_t* prefix = prefix_.data();
      PrefixSums(e, prefix, ext_n);
      // Per channel c the window of value i = x cn + c is i, i + cn, ..., i + (k - 1) cn; with
      // one channel the prefix sums give it directly.
      if (cn_ == 1) {
        WindowSumsPrefix(prefix, h, k_, n_);
      } else {
        WindowSumsDirect(e, h, cn_, k_, n_);
      }
    }
    ++added_;
  }
  void Output(int y, float* out) {
    CV_Assert(added_ >= y + k_ && y + k_ + 8 > added_);
    if (y == 0) {
      std::fill(vertical_.begin(), vertical_.end(), 0);
      for (int j = 0; j < k_; ++j) AddRows(vertical_.data(), Row(j), nullptr, n_);
    } else {
      AddRows(vertical_.data(), Row(y + k_ - 1), Row(y - 1), n_);
    }
    IntToFloatRow(vertical_.data(), out, n_);
  }

 private:
  TURBID_ROW_KERNEL static void IndicatorRow(const float* __restrict a, int32_t* __restrict out,
                                             int n) {
    for (int i = 0; i < n; ++i) out[i] = a[i] > 0.0f ? 1 : 0;
  }
  TURBID_ROW_KERNEL static void WindowSumsDirect(const int32_t* __restrict e, int32_t* __restrict h,
                                                 int cn, int k, int n) {
    for (int i = 0; i < n; ++i) h[i] = 0;
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < n; ++i) h[i] += e[i + j * cn];
  }
  // prefix[0] = 0, prefix[i + 1] = prefix[i] + e[i]: eight values per step as an in-register
  // scan (shifts by 1, 2 and 4 lanes, plus the running total; integers, so the same sums as the
  // serial loop, which ran at about one value per cycle).
  TURBID_ROW_KERNEL static void PrefixSums(const int32_t* __restrict e, int32_t* __restrict prefix,
                                           int n) {
    using V8i = int32_t __attribute__((vector_size(32)));
    const V8i zero = {0, 0, 0, 0, 0, 0, 0, 0};
    V8i total = zero;
    prefix[0] = 0;
    int i = 0;
    for (; i + 8 <= n; i += 8) {
      V8i v;
      std::memcpy(&v, e + i, sizeof(v));
      v += __builtin_shufflevector(zero, v, 0, 8, 9, 10, 11, 12, 13, 14);
      v += __builtin_shufflevector(zero, v, 0, 1, 8, 9, 10, 11, 12, 13);
      v += __builtin_shufflevector(zero, v, 0, 1, 2, 3, 8, 9, 10, 11);
      v += total;
      std::memcpy(prefix + i + 1, &v, sizeof(v));
      total = __builtin_shufflevector(v, v, 7, 7, 7, 7, 7, 7, 7, 7);
    }
    for (; i < n; ++i) prefix[i + 1] = prefix[i] + e[i];
  }
  TURBID_ROW_KERNEL static void WindowSumsPrefix(const int32_t* __restrict prefix,
                                                 int32_t* __restrict h, int k, int n) {
    for (int i = 0; i < n; ++i) h[i] = prefix[i + k] - prefix[i];
  }
  TURBID_ROW_KERNEL static void AddRows(int32_t* __restrict v, const int32_t* __restrict add,
                                        const int32_t* __restrict sub, int n) {
    if (sub == nullptr) {
      for (int i = 0; i < n; ++i) v[i] += add[i];
    } else {
      for (int i = 0; i < n; ++i) v[i] += add[i] - sub[i];
    }
  }
  TURBID_ROW_KERNEL static void IntToFloatRow(const int32_t* __restrict v, float* __restrict out,
                                              int n) {
    for (int i = 0; i < n; ++i) out[i] = static_cast<float>(v[i]);
  }
  const int32_t* Row(int j) const { return ring_.data() + static_cast<size_t>(j % capacity_) * n_; }
  int cols_, cn_, k_, n_, capacity_;
  int added_ = 0;
  std::vector<int> xofs_;
  std::vector<int32_t> bordered_, prefix_, ring_, vertical_;
};

}  // namespace turbid::box_stream
