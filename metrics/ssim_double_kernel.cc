// Why double: SSIM's variances are differences of windowed moments, sigma^2 = E[x^2] - E[x]^2.
// In float32 each term carries a rounding of ~6e-8 * E[x^2]; on a flat patch of value c that is
// an error of ~6e-8 * c^2 in sigma^2, which the contrast term divides by C2 = (0.03 R)^2. For
// non-integer data (k / 255, renders) this reaches 1e-5 per pixel and ~1e-6 on image means, the
// same order as the tolerance. 8-bit data escape it because their centred products are exact in
// float; for everything else the fused pass accumulates in float64 (products of float32 or 16-bit
// values are exact in double), which leaves ~1e-15 relative error at about twice the float cost.
//
// Layout: the output is cut into tiles (row band x column strip). A tile converts each input row
// of its support once (centred, with scipy 'reflect' borders) into a ring of 2r + 1 rows of the
// four moment images (x, y, xy and (x - y)^2: the formula needs only the sum of the variances,
// var(x) + var(y) = 2 cov(x, y) + var(x - y)), then per output row runs one vertical and one
// horizontal symmetric 11-tap pass per moment and the SSIM formula. Strips keep the ring
// (4 x 11 x ~330 doubles) in L2.
#include "metrics/ssim_double_kernel.h"

#include <algorithm>
#include <cstdint>
#include <opencv2/core/utility.hpp>

#include "metrics/simd_dispatch.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define TURBID_SSIM_HAVE_AVX2 1
#endif

namespace turbid::ssim_internal {
namespace {

constexpr int kMoments = 4;      // x, y, xy of centred values and (x - y)^2
constexpr int kBandRows = 64;    // a tile re-reads 2r rows of support: keep bands well above r
constexpr int kStripCols = 320;  // ring of one tile: 4 * 11 * (320 + 10) * 8 B = 116 KB

// scipy.ndimage mode 'reflect' (= OpenCV BORDER_REFLECT): -1 -> 0, n -> n - 1. One reflection is
// enough because the caller requires n >= 2r + 1.
inline int Reflect(int i, int n) {
  if (i < 0) return -i - 1;
  if (i >= n) return 2 * n - i - 1;
  return i;
}

// out[j] = half[0] * at(0)[j] + sum_k half[k] * (at(-k)[j] + at(k)[j]), j < n. The symmetric
// form halves the multiplies (scipy's correlate1d does the same for symmetric weights).
template <typename At>
void SymmetricFilterScalar(At at, const double* half, int radius, double* out, int n) {
  for (int j = 0; j < n; ++j) {
    double s = half[0] * at(0)[j];
    for (int k = 1; k <= radius; ++k) s += half[k] * (at(-k)[j] + at(k)[j]);
    out[j] = s;
  }
}

// m: E[x - o], E[y - o], the centred E[(x - o)(y - o)] and E[(x - y)^2]. With d = ux - uy, the
// denominators are ux^2 + uy^2 + c1 = (2 ux uy + c1) + d^2 and vx + vy + c2 = (2 vxy + c2) +
// (E[(x - y)^2] - d^2): identical images give exactly 1.
void FormulaScalar(const double* const* m, int n, double offset, double c1, double c2,
                   double* out) {
  for (int j = 0; j < n; ++j) {
    const double dx = m[0][j], dy = m[1][j];
    const double ux = dx + offset, uy = dy + offset, d = dx - dy;
    const double vxy = m[2][j] - dx * dy;
    const double a1 = 2.0 * ux * uy + c1, a2 = 2.0 * vxy + c2;
    out[j] = (a1 * a2) / ((a1 + d * d) * (a2 + (m[3][j] - d * d)));
  }
}

#ifdef TURBID_SSIM_HAVE_AVX2
// 16 columns = 4 independent FMA chains per block; the loads (two per tap pair) are the limit.
template <typename At>
__attribute__((target("avx2,fma"))) void SymmetricFilterAvx2(At at, const double* half, int radius,
                                                             double* out, int n) {
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    const __m256d w0 = _mm256_broadcast_sd(half);
    const double* c = at(0) + j;
    __m256d a0 = _mm256_mul_pd(w0, _mm256_loadu_pd(c));
    __m256d a1 = _mm256_mul_pd(w0, _mm256_loadu_pd(c + 4));
    __m256d a2 = _mm256_mul_pd(w0, _mm256_loadu_pd(c + 8));
    __m256d a3 = _mm256_mul_pd(w0, _mm256_loadu_pd(c + 12));
    for (int k = 1; k <= radius; ++k) {
      const __m256d w = _mm256_broadcast_sd(half + k);
      const double* lo = at(-k) + j;
      const double* hi = at(k) + j;
      a0 = _mm256_fmadd_pd(w, _mm256_add_pd(_mm256_loadu_pd(lo), _mm256_loadu_pd(hi)), a0);
      a1 = _mm256_fmadd_pd(w, _mm256_add_pd(_mm256_loadu_pd(lo + 4), _mm256_loadu_pd(hi + 4)), a1);
      a2 = _mm256_fmadd_pd(w, _mm256_add_pd(_mm256_loadu_pd(lo + 8), _mm256_loadu_pd(hi + 8)), a2);
      a3 =
          _mm256_fmadd_pd(w, _mm256_add_pd(_mm256_loadu_pd(lo + 12), _mm256_loadu_pd(hi + 12)), a3);
    }
    _mm256_storeu_pd(out + j, a0);
    _mm256_storeu_pd(out + j + 4, a1);
    _mm256_storeu_pd(out + j + 8, a2);
    _mm256_storeu_pd(out + j + 12, a3);
  }
  for (; j + 4 <= n; j += 4) {
    __m256d a = _mm256_mul_pd(_mm256_broadcast_sd(half), _mm256_loadu_pd(at(0) + j));
    for (int k = 1; k <= radius; ++k)
      a = _mm256_fmadd_pd(_mm256_broadcast_sd(half + k),
                          _mm256_add_pd(_mm256_loadu_pd(at(-k) + j), _mm256_loadu_pd(at(k) + j)),
                          a);
    _mm256_storeu_pd(out + j, a);
  }
  for (; j < n; ++j) {
    double s = half[0] * at(0)[j];
    for (int k = 1; k <= radius; ++k) s = __builtin_fma(half[k], at(-k)[j] + at(k)[j], s);
    out[j] = s;
  }
}

__attribute__((target("avx2,fma"))) void FormulaAvx2(const double* const* m, int n, double offset,
                                                     double c1, double c2, double* out) {
  const __m256d off = _mm256_set1_pd(offset), vc1 = _mm256_set1_pd(c1), vc2 = _mm256_set1_pd(c2),
                two = _mm256_set1_pd(2.0);
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    const __m256d dx = _mm256_loadu_pd(m[0] + j), dy = _mm256_loadu_pd(m[1] + j);
    const __m256d ux = _mm256_add_pd(dx, off), uy = _mm256_add_pd(dy, off);
    const __m256d d = _mm256_sub_pd(dx, dy), d2 = _mm256_mul_pd(d, d);
    const __m256d vxy = _mm256_fnmadd_pd(dx, dy, _mm256_loadu_pd(m[2] + j));
    const __m256d a1 = _mm256_fmadd_pd(_mm256_mul_pd(two, ux), uy, vc1);
    const __m256d a2 = _mm256_fmadd_pd(two, vxy, vc2);
    const __m256d b1 = _mm256_add_pd(a1, d2);
    const __m256d b2 = _mm256_add_pd(a2, _mm256_sub_pd(_mm256_loadu_pd(m[3] + j), d2));
    _mm256_storeu_pd(out + j, _mm256_div_pd(_mm256_mul_pd(a1, a2), _mm256_mul_pd(b1, b2)));
  }
  if (j < n) {
    const double* rest[kMoments] = {m[0] + j, m[1] + j, m[2] + j, m[3] + j};
    FormulaScalar(rest, n - j, offset, c1, c2, out + j);
  }
}

// 8-lane copies (AVX-512F): every lane takes the AVX2 copies' arithmetic in the same order, so
// the results are bit for bit the same, in half the instructions (what limits these loops).
template <typename At>
__attribute__((target("avx512f,avx2,fma"))) void SymmetricFilterAvx512(At at, const double* half,
                                                                       int radius, double* out,
                                                                       int n) {
  int j = 0;
  for (; j + 32 <= n; j += 32) {
    const __m512d w0 = _mm512_set1_pd(half[0]);
    const double* c = at(0) + j;
    __m512d a[4];
    for (int l = 0; l < 4; ++l) a[l] = _mm512_mul_pd(w0, _mm512_loadu_pd(c + 8 * l));
    for (int k = 1; k <= radius; ++k) {
      const __m512d w = _mm512_set1_pd(half[k]);
      const double* lo = at(-k) + j;
      const double* hi = at(k) + j;
      for (int l = 0; l < 4; ++l)
        a[l] = _mm512_fmadd_pd(
            w, _mm512_add_pd(_mm512_loadu_pd(lo + 8 * l), _mm512_loadu_pd(hi + 8 * l)), a[l]);
    }
    for (int l = 0; l < 4; ++l) _mm512_storeu_pd(out + j + 8 * l, a[l]);
  }
  for (; j + 8 <= n; j += 8) {
    __m512d a = _mm512_mul_pd(_mm512_set1_pd(half[0]), _mm512_loadu_pd(at(0) + j));
    for (int k = 1; k <= radius; ++k)
      a = _mm512_fmadd_pd(_mm512_set1_pd(half[k]),
                          _mm512_add_pd(_mm512_loadu_pd(at(-k) + j), _mm512_loadu_pd(at(k) + j)),
                          a);
    _mm512_storeu_pd(out + j, a);
  }
  if (j < n)
    SymmetricFilterAvx2([&at, j](int k) { return at(k) + j; }, half, radius, out + j, n - j);
}

__attribute__((target("avx512f,avx2,fma"))) void FormulaAvx512(const double* const* m, int n,
                                                               double offset, double c1, double c2,
                                                               double* out) {
  const __m512d off = _mm512_set1_pd(offset), vc1 = _mm512_set1_pd(c1), vc2 = _mm512_set1_pd(c2),
                two = _mm512_set1_pd(2.0);
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    const __m512d dx = _mm512_loadu_pd(m[0] + j), dy = _mm512_loadu_pd(m[1] + j);
    const __m512d ux = _mm512_add_pd(dx, off), uy = _mm512_add_pd(dy, off);
    const __m512d d = _mm512_sub_pd(dx, dy), d2 = _mm512_mul_pd(d, d);
    const __m512d vxy = _mm512_fnmadd_pd(dx, dy, _mm512_loadu_pd(m[2] + j));
    const __m512d a1 = _mm512_fmadd_pd(_mm512_mul_pd(two, ux), uy, vc1);
    const __m512d a2 = _mm512_fmadd_pd(two, vxy, vc2);
    const __m512d b1 = _mm512_add_pd(a1, d2);
    const __m512d b2 = _mm512_add_pd(a2, _mm512_sub_pd(_mm512_loadu_pd(m[3] + j), d2));
    _mm512_storeu_pd(out + j, _mm512_div_pd(_mm512_mul_pd(a1, a2), _mm512_mul_pd(b1, b2)));
  }
  if (j < n) {
    const double* rest[kMoments] = {m[0] + j, m[1] + j, m[2] + j, m[3] + j};
    FormulaAvx2(rest, n - j, offset, c1, c2, out + j);
  }
}

// Four output rows of the vertical pass with radius 5 from 14 consecutive input rows: each input
// vector is loaded once for all four rows (3.5 loads per output instead of 11). Every column
// takes the arithmetic of SymmetricFilterAvx2 / Avx512, in the same order.
__attribute__((target("avx2,fma"))) void VerticalQuad5Avx2(const double* const* rows,
                                                           const double* half, double* const* out,
                                                           int n) {
  constexpr int kR = 5;
  __m256d w[kR + 1];
  for (int k = 0; k <= kR; ++k) w[k] = _mm256_broadcast_sd(half + k);
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    __m256d v[2 * kR + 4];
    for (int q = 0; q < 2 * kR + 4; ++q) v[q] = _mm256_loadu_pd(rows[q] + j);
    for (int t = 0; t < 4; ++t) {
      __m256d a = _mm256_mul_pd(w[0], v[kR + t]);
      for (int k = 1; k <= kR; ++k)
        a = _mm256_fmadd_pd(w[k], _mm256_add_pd(v[kR + t - k], v[kR + t + k]), a);
      _mm256_storeu_pd(out[t] + j, a);
    }
  }
  for (; j < n; ++j)
    for (int t = 0; t < 4; ++t) {
      double a = half[0] * rows[kR + t][j];
      for (int k = 1; k <= kR; ++k)
        a = __builtin_fma(half[k], rows[kR + t - k][j] + rows[kR + t + k][j], a);
      out[t][j] = a;
    }
}

__attribute__((target("avx512f,avx2,fma"))) void VerticalQuad5Avx512(const double* const* rows,
                                                                     const double* half,
                                                                     double* const* out, int n) {
  constexpr int kR = 5;
  __m512d w[kR + 1];
  for (int k = 0; k <= kR; ++k) w[k] = _mm512_set1_pd(half[k]);
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    __m512d v[2 * kR + 4];
    for (int q = 0; q < 2 * kR + 4; ++q) v[q] = _mm512_loadu_pd(rows[q] + j);
    for (int t = 0; t < 4; ++t) {
      __m512d a = _mm512_mul_pd(w[0], v[kR + t]);
      for (int k = 1; k <= kR; ++k)
        a = _mm512_fmadd_pd(w[k], _mm512_add_pd(v[kR + t - k], v[kR + t + k]), a);
      _mm512_storeu_pd(out[t] + j, a);
    }
  }
  if (j < n) {
    const double* rest[2 * kR + 4];
    double* rest_out[4];
    for (int q = 0; q < 2 * kR + 4; ++q) rest[q] = rows[q] + j;
    for (int t = 0; t < 4; ++t) rest_out[t] = out[t] + j;
    VerticalQuad5Avx2(rest, half, rest_out, n - j);
  }
}

bool UseAvx512() { return simd::ActiveSimdLevel() >= simd::SimdLevel::kAvx512; }
bool UseAvx2() { return simd::ActiveSimdLevel() >= simd::SimdLevel::kAvx2; }
#else
bool UseAvx2() { return false; }
#endif

template <typename At>
void SymmetricFilter(At at, const double* half, int radius, double* out, int n) {
#ifdef TURBID_SSIM_HAVE_AVX2
  if (UseAvx512()) return SymmetricFilterAvx512(at, half, radius, out, n);
  if (UseAvx2()) return SymmetricFilterAvx2(at, half, radius, out, n);
#endif
  SymmetricFilterScalar(at, half, radius, out, n);
}

void Formula(const double* const* m, int n, double offset, double c1, double c2, double* out) {
#ifdef TURBID_SSIM_HAVE_AVX2
  if (UseAvx512()) return FormulaAvx512(m, n, offset, c1, c2, out);
  if (UseAvx2()) return FormulaAvx2(m, n, offset, c1, c2, out);
#endif
  FormulaScalar(m, n, offset, c1, c2, out);
}

// Four vertical output rows at once where a vectorised radius-5 kernel exists; false otherwise
// (the caller then filters row by row, with the same arithmetic per column).
bool VerticalQuad(const double* const* rows, const double* half, int radius, double* const* out,
                  int n) {
#ifdef TURBID_SSIM_HAVE_AVX2
  if (radius == 5 && UseAvx512()) return VerticalQuad5Avx512(rows, half, out, n), true;
  if (radius == 5 && UseAvx2()) return VerticalQuad5Avx2(rows, half, out, n), true;
#endif
  (void)rows, (void)half, (void)radius, (void)out, (void)n;
  return false;
}

// Sum in a fixed 4-lane order: deterministic, and the same on every CPU.
double OrderedSum(const double* v, int n) {
  double lane[4] = {0.0, 0.0, 0.0, 0.0};
  int j = 0;
  for (; j + 4 <= n; j += 4)
    for (int l = 0; l < 4; ++l) lane[l] += v[j + l];
  double sum = (lane[0] + lane[1]) + (lane[2] + lane[3]);
  for (; j < n; ++j) sum += v[j];
  return sum;
}

// out[m][at + j] for j < n of the centred values x - o, y - o (element j at x[j * step]): x, y,
// xy and (x - y)^2. Plain loops; the AVX2 copy is the same code vectorised (no contraction: the
// file is compiled without it, and only xy and d * d are products).
template <typename T, int kStep>
void CentredMomentsLoop(const T* x, const T* y, double offset, double* const* out, int at, int n) {
  double* __restrict cx = out[0] + at;
  double* __restrict cy = out[1] + at;
  double* __restrict xy = out[2] + at;
  double* __restrict dd = out[3] + at;
  for (int j = 0; j < n; ++j) {
    const double a = static_cast<double>(x[j * kStep]) - offset;
    const double b = static_cast<double>(y[j * kStep]) - offset;
    const double d = a - b;
    cx[j] = a;
    cy[j] = b;
    xy[j] = a * b;
    dd[j] = d * d;
  }
}

#ifdef TURBID_SSIM_HAVE_AVX2
template <typename T, int kStep>
__attribute__((target("avx2"))) void CentredMomentsLoopAvx2(const T* x, const T* y, double offset,
                                                            double* const* out, int at, int n) {
  CentredMomentsLoop<T, kStep>(x, y, offset, out, at, n);
}
#endif

template <typename T>
void CentredMoments(const T* x, const T* y, int step, double offset, double* const* out, int at,
                    int n) {
#ifdef TURBID_SSIM_HAVE_AVX2
  if (step == 1 && UseAvx2()) return CentredMomentsLoopAvx2<T, 1>(x, y, offset, out, at, n);
  if (step == 3 && UseAvx2()) return CentredMomentsLoopAvx2<T, 3>(x, y, offset, out, at, n);
#endif
  if (step == 1) return CentredMomentsLoop<T, 1>(x, y, offset, out, at, n);
  if (step == 3) return CentredMomentsLoop<T, 3>(x, y, offset, out, at, n);
  double* cx = out[0] + at;
  double* cy = out[1] + at;
  double* xy = out[2] + at;
  double* dd = out[3] + at;
  for (int j = 0; j < n; ++j) {
    const double a = static_cast<double>(x[j * step]) - offset;
    const double b = static_cast<double>(y[j * step]) - offset;
    const double d = a - b;
    cx[j] = a;
    cy[j] = b;
    xy[j] = a * b;
    dd[j] = d * d;
  }
}

struct Job {
  const cv::Mat* reference;
  const cv::Mat* image;
  int channel;
  std::vector<double> half;  // taps[r], taps[r + 1], ..., taps[2r]
  int radius;
  double offset, c1, c2;
  cv::Mat* map;  // CV_32F or nullptr
};

// Scratch of one worker, reused for every tile it runs.
class TileWorker {
 public:
  explicit TileWorker(const Job& job)
      : job_(job), taps_(2 * job.radius + 1), slots_(taps_ + kGroup - 1) {
    const size_t support = kStripCols + 2 * job.radius;
    ring_.resize(static_cast<size_t>(kMoments) * slots_ * support);
    vertical_.resize(static_cast<size_t>(kGroup) * kMoments * support);
    filtered_.resize(kMoments * static_cast<size_t>(kStripCols));
    ssim_.resize(kStripCols);
  }

  // Output rows [row_begin, row_end) x columns [col_begin, col_end). Adds nothing up across
  // tiles: writes each cropped row's partial sum to row_sums[row]. Rows go in groups of four
  // through the vertical pass where VerticalQuad has a kernel, else one by one; every row takes
  // the same arithmetic either way.
  void Run(int row_begin, int row_end, int col_begin, int col_end, double* row_sums,
           int row_sums_stride) {
    const int r = job_.radius;
    support_ = col_end - col_begin + 2 * r;
    int next_fill = row_begin - r;
    const double* rows[2 * 64 + kGroup];
    for (int i = row_begin; i < row_end;) {
      int group = i + kGroup <= row_end ? kGroup : 1;
      for (; next_fill <= i + group - 1 + r; ++next_fill) FillRing(next_fill, col_begin - r);
      for (int m = 0; m < kMoments; ++m) {
        for (int k = 0; k < taps_ + group - 1; ++k) rows[k] = RingRow(i - r + k, m);
        double* out[kGroup];
        for (int t = 0; t < kGroup; ++t) out[t] = Vertical(t, m);
        if (group == kGroup && VerticalQuad(rows, job_.half.data(), r, out, support_)) continue;
        group = 1;
        SymmetricFilter([&rows, r](int k) { return rows[k + r]; }, job_.half.data(), r, out[0],
                        support_);
      }
      for (int t = 0; t < group; ++t)
        FinishRow(i + t, t, col_begin, col_end, row_sums, row_sums_stride);
      i += group;
    }
  }

 private:
  static constexpr int kGroup = 4;  // output rows per vertical pass

  double* Vertical(int t, int m) {
    return vertical_.data() + (static_cast<size_t>(t) * kMoments + m) * support_;
  }

  // Horizontal pass and formula of output row `row`, whose vertical pass is in Vertical(t, ·).
  void FinishRow(int row, int t, int col_begin, int col_end, double* row_sums,
                 int row_sums_stride) {
    const int r = job_.radius;
    const int width = job_.reference->cols;
    const int height = job_.reference->rows;
    const int n = col_end - col_begin;
    const double* moments[kMoments];
    for (int m = 0; m < kMoments; ++m) {
      const double* vertical = Vertical(t, m);
      double* filtered = filtered_.data() + m * kStripCols;
      SymmetricFilter([vertical, r](int k) { return vertical + r + k; }, job_.half.data(), r,
                      filtered, n);
      moments[m] = filtered;
    }
    Formula(moments, n, job_.offset, job_.c1, job_.c2, ssim_.data());
    if (job_.map != nullptr) {
      float* out = job_.map->ptr<float>(row) + col_begin;
      for (int j = 0; j < n; ++j) out[j] = static_cast<float>(ssim_[j]);
    }
    if (row >= r && row < height - r) {
      const int lo = std::max(col_begin, r), hi = std::min(col_end, width - r);
      row_sums[static_cast<size_t>(row) * row_sums_stride] =
          hi > lo ? OrderedSum(ssim_.data() + (lo - col_begin), hi - lo) : 0.0;
    }
  }

  double* RingRow(int virtual_row, int moment) {
    const int slot = ((virtual_row % slots_) + slots_) % slots_;
    return ring_.data() + (static_cast<size_t>(moment) * slots_ + slot) * support_;
  }

  // Columns [first, first + support_) of one row of both images, reflected at the image edges,
  // minus offset, into the four moment rows of `virtual_row`.
  void FillRing(int virtual_row, int first) {
    const int row = Reflect(virtual_row, job_.reference->rows);
    double* out[kMoments];
    for (int m = 0; m < kMoments; ++m) out[m] = RingRow(virtual_row, m);
    switch (job_.reference->depth()) {
      case CV_8U:
        return FillRow<uint8_t>(row, first, out);
      case CV_16U:
        return FillRow<uint16_t>(row, first, out);
      case CV_32F:
        return FillRow<float>(row, first, out);
      default:
        return FillRow<double>(row, first, out);
    }
  }

  template <typename T>
  void FillRow(int row, int first, double* const* out) const {
    const T* x = job_.reference->ptr<T>(row) + job_.channel;
    const T* y = job_.image->ptr<T>(row) + job_.channel;
    const int step = job_.reference->channels();
    const int width = job_.reference->cols;
    const int last = first + support_;
    const int lo = std::max(first, 0), hi = std::min(last, width);
    // Reflected borders one column at a time, the interior as one run of columns.
    for (int j = first; j < lo; ++j)
      CentredMoments(x + Reflect(j, width) * step, y + Reflect(j, width) * step, 1, job_.offset,
                     out, j - first, 1);
    CentredMoments(x + lo * step, y + lo * step, step, job_.offset, out, lo - first, hi - lo);
    for (int j = hi; j < last; ++j)
      CentredMoments(x + Reflect(j, width) * step, y + Reflect(j, width) * step, 1, job_.offset,
                     out, j - first, 1);
  }

  const Job& job_;
  int taps_;
  int slots_;  // ring rows: one group's input rows
  int support_ = 0;
  std::vector<double> ring_;
  std::vector<double> vertical_;
  std::vector<double> filtered_;
  std::vector<double> ssim_;
};

}  // namespace

double FusedDoubleSsimChannel(const cv::Mat& reference, const cv::Mat& image, int channel,
                              const std::vector<double>& taps, double offset, double c1, double c2,
                              cv::Mat* map) {
  Job job;
  job.reference = &reference;
  job.image = &image;
  job.channel = channel;
  job.radius = static_cast<int>(taps.size() / 2);
  job.half.assign(taps.begin() + job.radius, taps.end());
  job.offset = offset;
  job.c1 = c1;
  job.c2 = c2;
  job.map = map;
  const int r = job.radius;
  const int width = reference.cols, height = reference.rows;
  // Without a map only the cropped region is ever averaged, so the border is not computed.
  const int row_begin = map ? 0 : r, row_end = map ? height : height - r;
  const int col_begin = map ? 0 : r, col_end = map ? width : width - r;
  const int bands = (row_end - row_begin + kBandRows - 1) / kBandRows;
  const int strips = (col_end - col_begin + kStripCols - 1) / kStripCols;
  std::vector<double> row_sums(static_cast<size_t>(height) * strips, 0.0);
  cv::parallel_for_(cv::Range(0, bands * strips), [&](const cv::Range& tiles) {
    TileWorker worker(job);
    for (int t = tiles.start; t < tiles.end; ++t) {
      const int b = t / strips, s = t % strips;
      const int rb = row_begin + b * kBandRows, re = std::min(row_end, rb + kBandRows);
      const int cb = col_begin + s * kStripCols, ce = std::min(col_end, cb + kStripCols);
      worker.Run(rb, re, cb, ce, row_sums.data() + s, strips);
    }
  });
  // Partial sums added in (row, strip) order whatever the thread count: deterministic.
  double sum = 0.0;
  for (int i = r; i < height - r; ++i)
    for (int s = 0; s < strips; ++s) sum += row_sums[static_cast<size_t>(i) * strips + s];
  return sum / (static_cast<double>(width - 2 * r) * (height - 2 * r));
}

}  // namespace turbid::ssim_internal
