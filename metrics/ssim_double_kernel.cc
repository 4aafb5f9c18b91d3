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
// five moment images, then per output row runs one vertical and one horizontal symmetric 11-tap
// pass per moment and the SSIM formula. Strips keep the ring (5 x 11 x ~330 doubles) in L2.
#include "metrics/ssim_double_kernel.h"

#include <algorithm>
#include <cstdint>
#include <opencv2/core/utility.hpp>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define TURBID_SSIM_HAVE_AVX2 1
#endif

namespace turbid::ssim_internal {
namespace {

constexpr int kMoments = 5;      // x, y, x^2, y^2, xy of centred values
constexpr int kBandRows = 64;    // a tile re-reads 2r rows of support: keep bands well above r
constexpr int kStripCols = 320;  // ring of one tile: 5 * 11 * (320 + 10) * 8 B = 145 KB

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

void FormulaScalar(const double* const* m, int n, double offset, double c1, double c2,
                   double* out) {
  for (int j = 0; j < n; ++j) {
    const double dx = m[0][j], dy = m[1][j];
    const double ux = dx + offset, uy = dy + offset;
    const double vx = m[2][j] - dx * dx, vy = m[3][j] - dy * dy, vxy = m[4][j] - dx * dy;
    out[j] = (2.0 * ux * uy + c1) * (2.0 * vxy + c2) / ((ux * ux + uy * uy + c1) * (vx + vy + c2));
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
    const __m256d vx = _mm256_fnmadd_pd(dx, dx, _mm256_loadu_pd(m[2] + j));
    const __m256d vy = _mm256_fnmadd_pd(dy, dy, _mm256_loadu_pd(m[3] + j));
    const __m256d vxy = _mm256_fnmadd_pd(dx, dy, _mm256_loadu_pd(m[4] + j));
    const __m256d num = _mm256_mul_pd(_mm256_fmadd_pd(_mm256_mul_pd(two, ux), uy, vc1),
                                      _mm256_fmadd_pd(two, vxy, vc2));
    const __m256d den = _mm256_mul_pd(_mm256_fmadd_pd(ux, ux, _mm256_fmadd_pd(uy, uy, vc1)),
                                      _mm256_add_pd(_mm256_add_pd(vx, vy), vc2));
    _mm256_storeu_pd(out + j, _mm256_div_pd(num, den));
  }
  if (j < n) {
    const double* rest[kMoments] = {m[0] + j, m[1] + j, m[2] + j, m[3] + j, m[4] + j};
    FormulaScalar(rest, n - j, offset, c1, c2, out + j);
  }
}

bool UseAvx2() {
  static const bool yes = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return yes;
}
#else
bool UseAvx2() { return false; }
#endif

template <typename At>
void SymmetricFilter(At at, const double* half, int radius, double* out, int n) {
#ifdef TURBID_SSIM_HAVE_AVX2
  if (UseAvx2()) return SymmetricFilterAvx2(at, half, radius, out, n);
#endif
  SymmetricFilterScalar(at, half, radius, out, n);
}

void Formula(const double* const* m, int n, double offset, double c1, double c2, double* out) {
#ifdef TURBID_SSIM_HAVE_AVX2
  if (UseAvx2()) return FormulaAvx2(m, n, offset, c1, c2, out);
#endif
  FormulaScalar(m, n, offset, c1, c2, out);
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
  explicit TileWorker(const Job& job) : job_(job), taps_(2 * job.radius + 1) {
    const size_t support = kStripCols + 2 * job.radius;
    ring_.resize(static_cast<size_t>(kMoments) * taps_ * support);
    vertical_.resize(kMoments * support);
    filtered_.resize(kMoments * static_cast<size_t>(kStripCols));
    ssim_.resize(kStripCols);
  }

  // Output rows [row_begin, row_end) x columns [col_begin, col_end). Adds nothing up across
  // tiles: writes each cropped row's partial sum to row_sums[row].
  void Run(int row_begin, int row_end, int col_begin, int col_end, double* row_sums,
           int row_sums_stride) {
    const int r = job_.radius;
    const int width = job_.reference->cols;
    const int height = job_.reference->rows;
    const int n = col_end - col_begin;
    support_ = n + 2 * r;
    for (int v = row_begin - r; v < row_begin + r; ++v) FillRing(v, col_begin - r);
    const double* rows[2 * 64 + 1];
    const double* moments[kMoments];
    for (int i = row_begin; i < row_end; ++i) {
      FillRing(i + r, col_begin - r);
      for (int m = 0; m < kMoments; ++m) {
        for (int k = -r; k <= r; ++k) rows[k + r] = RingRow(i + k, m);
        double* vertical = vertical_.data() + m * support_;
        SymmetricFilter([&rows, r](int k) { return rows[k + r]; }, job_.half.data(), r, vertical,
                        support_);
        double* filtered = filtered_.data() + m * kStripCols;
        SymmetricFilter([vertical, r](int k) { return vertical + r + k; }, job_.half.data(), r,
                        filtered, n);
        moments[m] = filtered;
      }
      Formula(moments, n, job_.offset, job_.c1, job_.c2, ssim_.data());
      if (job_.map != nullptr) {
        float* out = job_.map->ptr<float>(i) + col_begin;
        for (int j = 0; j < n; ++j) out[j] = static_cast<float>(ssim_[j]);
      }
      if (i >= r && i < height - r) {
        const int lo = std::max(col_begin, r), hi = std::min(col_end, width - r);
        row_sums[static_cast<size_t>(i) * row_sums_stride] =
            hi > lo ? OrderedSum(ssim_.data() + (lo - col_begin), hi - lo) : 0.0;
      }
    }
  }

 private:
  double* RingRow(int virtual_row, int moment) {
    const int slot = ((virtual_row % taps_) + taps_) % taps_;
    return ring_.data() + (static_cast<size_t>(moment) * taps_ + slot) * support_;
  }

  // Columns [first, first + support_) of one row, reflected at the image edges, minus offset.
  template <typename T>
  void Centre(const cv::Mat& src, int row, int first, double* out) const {
    const T* p = src.ptr<T>(row) + job_.channel;
    const int step = src.channels();
    const int width = src.cols;
    const int last = first + support_;
    const int lo = std::max(first, 0), hi = std::min(last, width);
    const double offset = job_.offset;
    for (int j = first; j < lo; ++j)
      out[j - first] = static_cast<double>(p[Reflect(j, width) * step]) - offset;
    if (step == 1) {
      for (int j = lo; j < hi; ++j) out[j - first] = static_cast<double>(p[j]) - offset;
    } else {
      for (int j = lo; j < hi; ++j) out[j - first] = static_cast<double>(p[j * step]) - offset;
    }
    for (int j = hi; j < last; ++j)
      out[j - first] = static_cast<double>(p[Reflect(j, width) * step]) - offset;
  }

  void CentreRow(const cv::Mat& src, int row, int first, double* out) const {
    switch (src.depth()) {
      case CV_8U:
        return Centre<uint8_t>(src, row, first, out);
      case CV_16U:
        return Centre<uint16_t>(src, row, first, out);
      case CV_32F:
        return Centre<float>(src, row, first, out);
      default:
        return Centre<double>(src, row, first, out);
    }
  }

  void FillRing(int virtual_row, int first) {
    const int row = Reflect(virtual_row, job_.reference->rows);
    double* x = RingRow(virtual_row, 0);
    double* y = RingRow(virtual_row, 1);
    CentreRow(*job_.reference, row, first, x);
    CentreRow(*job_.image, row, first, y);
    double* xx = RingRow(virtual_row, 2);
    double* yy = RingRow(virtual_row, 3);
    double* xy = RingRow(virtual_row, 4);
    for (int j = 0; j < support_; ++j) {
      xx[j] = x[j] * x[j];
      yy[j] = y[j] * y[j];
      xy[j] = x[j] * y[j];
    }
  }

  const Job& job_;
  int taps_;
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
