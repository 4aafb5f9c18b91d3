#include "metrics/simd_dispatch.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

// The same loops compiled twice; the AVX2 + FMA copy is chosen at run time when the CPU has both
// (checked once). Results of the two copies differ in the last float bits (FMA contraction), so
// scores can differ by ~1e-7 between machines; on one machine they are deterministic.
namespace turbid::simd {

// An optimisation barrier on a double: a product passed through it cannot be contracted with a
// following addition into an FMA (this file is compiled with -ffp-contract=fast), for kernels
// that must round exactly as their scalar reference.
#if defined(__x86_64__) && defined(__GNUC__)
#define TURBID_NO_CONTRACT(...) __asm__("" : "+x"(__VA_ARGS__))
#else
#define TURBID_NO_CONTRACT(...) __asm__("" : "+m"(__VA_ARGS__))
#endif

namespace base {
#include "metrics/simd_kernels.inc"

// Plain references of the fused SSIM kernels (the AVX2 copies below add in the same order).
void SymmetricColumnPair(const float* const* rows, const float* weights, int taps, float* out0,
                         float* out1, int n) {
  const int r = taps / 2;
  for (int j = 0; j < n; ++j) {
    float a0 = weights[r] * rows[r][j];
    float a1 = weights[r] * rows[r + 1][j];
    for (int k = 1; k <= r; ++k) {
      a0 += weights[r + k] * (rows[r - k][j] + rows[r + k][j]);
      a1 += weights[r + k] * (rows[r + 1 - k][j] + rows[r + 1 + k][j]);
    }
    out0[j] = a0;
    out1[j] = a1;
  }
}

void SymmetricColumnQuad(const float* const* rows, const float* weights, int taps,
                         float* const* out, int n) {
  SymmetricColumnPair(rows, weights, taps, out[0], out[1], n);
  SymmetricColumnPair(rows + 2, weights, taps, out[2], out[3], n);
}

void SsimHorizontalFormula(const float* const* moments, const float* weights, int taps, int n,
                           double offset, double c1, double c2, double* out) {
  const int r = taps / 2;
  for (int j = 0; j < n; ++j) {
    float m[4];
    for (int q = 0; q < 4; ++q) {
      const float* p = moments[q] + j;
      float a = weights[r] * p[0];
      for (int k = 1; k <= r; ++k) a += weights[r + k] * (p[-k] + p[k]);
      m[q] = a;
    }
    SsimFormulaRow(&m[0], &m[1], &m[2], &m[3], 1, offset, c1, c2, out + j);
  }
}
}  // namespace base

#if defined(__x86_64__) && defined(__GNUC__)
#define TURBID_HAVE_AVX2_COPY 1
#if defined(__clang__)  // the sanitizer build (CMakeLists.txt, TURBID_SANITIZE)
#pragma clang attribute push(__attribute__((target("avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,fma")
#endif
namespace avx2 {
#include "metrics/simd_kernels.inc"

// Vertical pass, two output rows: rows[r - k] + rows[r + k] feeds row 0 and rows[r + 1 - k] +
// rows[r + 2 + k - 1] row 1; walking k outwards, each input row is loaded once for both outputs
// (taps + 1 loads per two outputs instead of 2 * taps). 16 columns per step: four independent
// chains keep both FMA pipes busy while the loads stream from L2.
template <int kRadius>
void SymmetricColumnPairFast(const float* const* rows, const float* weights, int taps, float* out0,
                             float* out1, int n) {
  const int r = kRadius > 0 ? kRadius : taps / 2;
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    __m256 lo_prev[2], hi[2], acc0[2], acc1[2];
    const __m256 wc = _mm256_broadcast_ss(weights + r);
    for (int l = 0; l < 2; ++l) {
      lo_prev[l] = _mm256_loadu_ps(rows[r] + j + 8 * l);
      hi[l] = _mm256_loadu_ps(rows[r + 1] + j + 8 * l);
      acc0[l] = _mm256_mul_ps(wc, lo_prev[l]);
      acc1[l] = _mm256_mul_ps(wc, hi[l]);
    }
    for (int k = 1; k <= r; ++k) {
      const __m256 w = _mm256_broadcast_ss(weights + r + k);
      const float* lo_row = rows[r - k] + j;
      const float* hi_row = rows[r + 1 + k] + j;
      for (int l = 0; l < 2; ++l) {
        const __m256 lo = _mm256_loadu_ps(lo_row + 8 * l);
        const __m256 hi_next = _mm256_loadu_ps(hi_row + 8 * l);
        acc0[l] = _mm256_fmadd_ps(w, _mm256_add_ps(lo, hi[l]), acc0[l]);
        acc1[l] = _mm256_fmadd_ps(w, _mm256_add_ps(lo_prev[l], hi_next), acc1[l]);
        lo_prev[l] = lo;
        hi[l] = hi_next;
      }
    }
    for (int l = 0; l < 2; ++l) {
      _mm256_storeu_ps(out0 + j + 8 * l, acc0[l]);
      _mm256_storeu_ps(out1 + j + 8 * l, acc1[l]);
    }
  }
  for (; j < n; ++j) {
    float a0 = weights[r] * rows[r][j];
    float a1 = weights[r] * rows[r + 1][j];
    for (int k = 1; k <= r; ++k) {
      a0 = std::fma(weights[r + k], rows[r - k][j] + rows[r + k][j], a0);
      a1 = std::fma(weights[r + k], rows[r + 1 - k][j] + rows[r + 1 + k][j], a1);
    }
    out0[j] = a0;
    out1[j] = a1;
  }
}

// Four output rows from taps + 3 input rows, 8 columns at a time: the input vectors are loaded once
// (from L2: the ring of four moments does not fit L1) and reused from registers or L1 for all four
// rows, which cuts the L2 traffic of the vertical pass from 6 to 3.5 loads per output.
template <int kRadius>
void SymmetricColumnQuadFast(const float* const* rows, const float* weights, float* const* out,
                             int n) {
  constexpr int kTaps = 2 * kRadius + 1;
  __m256 w[kRadius + 1];
  for (int k = 0; k <= kRadius; ++k) w[k] = _mm256_broadcast_ss(weights + kRadius + k);
  const auto row_sum = [&](const __m256* v, int t) {
    __m256 acc = _mm256_mul_ps(w[0], v[kRadius + t]);
    for (int k = 1; k <= kRadius; ++k)
      acc = _mm256_fmadd_ps(w[k], _mm256_add_ps(v[kRadius + t - k], v[kRadius + t + k]), acc);
    return acc;
  };
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    __m256 v[kTaps + 3];
    for (int s = 0; s < kTaps + 3; ++s) v[s] = _mm256_loadu_ps(rows[s] + j);
    for (int t = 0; t < 4; ++t) _mm256_storeu_ps(out[t] + j, row_sum(v, t));
  }
  for (; j < n; ++j)
    for (int t = 0; t < 4; ++t) {
      float acc = weights[kRadius] * rows[kRadius + t][j];
      for (int k = 1; k <= kRadius; ++k)
        acc = std::fma(weights[kRadius + k], rows[kRadius + t - k][j] + rows[kRadius + t + k][j],
                       acc);
      out[t][j] = acc;
    }
}

// SSIM of eight columns from their moments, in float: the moments themselves are float sums, so
// the formula in double would only carry their rounding further, at twice the cost and two double
// divides. As in SsimFormulaRow, the denominators are numerator + difference terms
// (ux^2 + uy^2 = 2 ux uy + (ux - uy)^2, vx + vy = 2 vxy + var(x - y)): identical inputs then give
// exactly 1, and the offset never cancels in ux - uy.
inline __m256 FormulaPs(__m256 dx, __m256 dy, __m256 mxy, __m256 mdd, __m256 offset, __m256 c1,
                        __m256 c2) {
  const __m256 two = _mm256_set1_ps(2.0f);
  const __m256 ux = _mm256_add_ps(dx, offset);
  const __m256 uy = _mm256_add_ps(dy, offset);
  const __m256 vxy = _mm256_fnmadd_ps(dx, dy, mxy);
  const __m256 a1 = _mm256_fmadd_ps(_mm256_mul_ps(two, ux), uy, c1);
  const __m256 a2 = _mm256_fmadd_ps(two, vxy, c2);
  const __m256 d = _mm256_sub_ps(dx, dy);
  const __m256 d2 = _mm256_mul_ps(d, d);
  const __m256 b1 = _mm256_add_ps(a1, d2);
  const __m256 b2 = _mm256_add_ps(a2, _mm256_sub_ps(mdd, d2));
  return _mm256_div_ps(_mm256_mul_ps(a1, a2), _mm256_mul_ps(b1, b2));
}

// The filtered moment q of eight columns at p: every column takes this arithmetic, whichever block
// it falls in.
template <int kRadius>
inline __m256 HorizontalTaps(const float* p, const float* weights, int r) {
  __m256 m = _mm256_mul_ps(_mm256_broadcast_ss(weights + r), _mm256_loadu_ps(p));
  for (int k = 1; k <= r; ++k)
    m = _mm256_fmadd_ps(_mm256_broadcast_ss(weights + r + k),
                        _mm256_add_ps(_mm256_loadu_ps(p - k), _mm256_loadu_ps(p + k)), m);
  return m;
}

inline void StoreSsim(__m256 s, double* out) {
  _mm256_storeu_pd(out, _mm256_cvtps_pd(_mm256_castps256_ps128(s)));
  _mm256_storeu_pd(out + 4, _mm256_cvtps_pd(_mm256_extractf128_ps(s, 1)));
}

// Horizontal pass of the four moments, 16 columns at a time (two blocks of 8 whose windows overlap,
// so the loads at offsets 8 - r .. r serve both), straight into the formula: the filtered moments
// never leave registers. A ragged end is done as (overlapping) blocks of 8, so every column takes
// the same arithmetic wherever the column range starts.
template <int kRadius>
void SsimHorizontalFormulaFast(const float* const* moments, const float* weights, int taps, int n,
                               double offset, double c1, double c2, double* out) {
  const int r = kRadius > 0 ? kRadius : taps / 2;
  if (n < 8) {
    // Fewer than 8 columns: the same vector arithmetic on a zero-extended copy, so that a narrow
    // column range gives bit for bit what the wide one gives for the same columns.
    constexpr int kMaxRadius = 64;
    alignas(32) float copy[4][8 + 2 * kMaxRadius] = {};
    const float* rows[4];
    for (int q = 0; q < 4; ++q) {
      std::copy(moments[q] - r, moments[q] + n + r, copy[q]);
      rows[q] = copy[q] + r;
    }
    double block[8];
    SsimHorizontalFormulaFast<kRadius>(rows, weights, taps, 8, offset, c1, c2, block);
    std::copy(block, block + n, out);
    return;
  }
  const __m256 o = _mm256_set1_ps(static_cast<float>(offset));
  const __m256 vc1 = _mm256_set1_ps(static_cast<float>(c1));
  const __m256 vc2 = _mm256_set1_ps(static_cast<float>(c2));
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    __m256 m0[4], m1[4];
    for (int q = 0; q < 4; ++q) {
      m0[q] = HorizontalTaps<kRadius>(moments[q] + j, weights, r);
      m1[q] = HorizontalTaps<kRadius>(moments[q] + j + 8, weights, r);
    }
    StoreSsim(FormulaPs(m0[0], m0[1], m0[2], m0[3], o, vc1, vc2), out + j);
    StoreSsim(FormulaPs(m1[0], m1[1], m1[2], m1[3], o, vc1, vc2), out + j + 8);
  }
  for (; j < n; j += 8) {
    const int b = std::min(j, n - 8);
    __m256 m[4];
    for (int q = 0; q < 4; ++q) m[q] = HorizontalTaps<kRadius>(moments[q] + b, weights, r);
    StoreSsim(FormulaPs(m[0], m[1], m[2], m[3], o, vc1, vc2), out + b);
  }
}

// Four thresholds per step, aligned so that each chunk of sums is loaded from the address it was
// last stored to (store forwarding works); lanes outside [first, last] add +0 (a no-op on sums
// >= 0). Most intervals fit in two aligned chunks: those (and empty ones) take a fixed,
// branch-free path, so that interval lengths cost no mispredicted loop exits. Vertical and
// horizontal pairs alternate, so two independent chains are in flight.
inline void AddWeberChunk(const double* p, const double* q, int s, __m256d lo, __m256d hi,
                          double* sums, double* counts) {
  const __m256d lane = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
  const __m256d index = _mm256_add_pd(_mm256_set1_pd(s), lane);
  const __m256d inside =
      _mm256_and_pd(_mm256_cmp_pd(index, lo, _CMP_GE_OQ), _mm256_cmp_pd(index, hi, _CMP_LE_OQ));
  const __m256d term =
      _mm256_and_pd(_mm256_min_pd(_mm256_loadu_pd(p + s), _mm256_loadu_pd(q + s)), inside);
  _mm256_store_pd(sums + s, _mm256_add_pd(_mm256_load_pd(sums + s), term));
  _mm256_store_pd(counts + s, _mm256_add_pd(_mm256_load_pd(counts + s),
                                            _mm256_and_pd(_mm256_set1_pd(1.0), inside)));
}

inline void AddWeberPair(const double* p, const double* q, int first, int last, double* sums,
                         double* counts) {
  const int base = first & ~3;
  const __m256d lo = _mm256_set1_pd(first);
  const __m256d hi = _mm256_set1_pd(last);
  if (last < base + 8) {  // includes empty intervals (last < first): all lanes add 0
    AddWeberChunk(p, q, base, lo, hi, sums, counts);
    AddWeberChunk(p, q, base + 4, lo, hi, sums, counts);
    return;
  }
  for (int s = base; s <= last; s += 4) AddWeberChunk(p, q, s, lo, hi, sums, counts);
}

void WeberWindowSumsFast(const double* table, int table_stride, const uint8_t* value,
                         const uint8_t* tests, int stride, int size, int s_min, int s_max,
                         double* sums_v, double* sums_h, double* counts_v, double* counts_h) {
  for (int i = 0; i < size; ++i) {
    for (int j = 0; j < size; ++j) {
      // Signed: the neighbours k - 1 and k - stride lie before `value` for the first row and
      // column (the maps are padded), and an unsigned offset would wrap.
      const ptrdiff_t k = static_cast<ptrdiff_t>(i) * stride + j;
      const uint8_t* t = tests + 4 * k;
      const double* p = table + value[k] * table_stride;
      AddWeberPair(p, table + value[k - 1] * table_stride, std::max<int>(t[0], s_min),
                   std::min(t[1] - 1, s_max), sums_v, counts_v);
      AddWeberPair(p, table + value[k - stride] * table_stride, std::max<int>(t[2], s_min),
                   std::min(t[3] - 1, s_max), sums_h, counts_h);
    }
  }
}

// AddPackedPairs(): two 4-wide chunks per pair from an aligned base, the lanes of the pair's
// interval picked by a mask from a table (no per-chunk compares).
struct PackedTables {
  alignas(32) uint64_t masks[4 * 9][8];  // row (first & 3) · 9 + n: lanes [first & 3, n) of 8
};
constexpr PackedTables MakePackedTables() {
  PackedTables t{};
  for (int f = 0; f < 4; ++f)
    for (int n = 0; n <= 8; ++n)
      for (int l = 0; l < 8; ++l) t.masks[f * 9 + n][l] = (l >= f && l < n) ? ~uint64_t{0} : 0;
  return t;
}
constexpr PackedTables kPacked = MakePackedTables();

// 128 + min(W(s, p), W(s, q)) = 129 − max(min(p/s, s/p), min(q/s, s/q)) for the 4 thresholds
// from s, as the smaller of two rows of a table of 129 − min(v/s, s/v) (a division and a
// subtraction per entry, each correctly rounded: within the rounding that AddPackedPairs()
// allows): two loads and a minimum per chunk. Computing the terms instead (v and 1/v per pixel, s
// and 1/s per lane: four products, two minima, a maximum and a subtraction per chunk) took ~20 %
// more instructions in this kernel. The table (540 KB) is read only at the rows of the window's
// values and the columns of its thresholds, which neighbouring windows share.
// Called once, by PackedTermTable().
const double* BuildPackedTermTable() {
  static std::vector<double> t(256 * kPackedStride + 8);  // + 8: room to align to 64 bytes
  double* row0 = t.data() + (8 - reinterpret_cast<uintptr_t>(t.data()) % 64 / 8) % 8;
  for (int v = 0; v < 256; ++v) {
    for (int s = 0; s < kPackedStride; ++s) {
      const double ratio =
          v == 0 || s == 0 ? 0.0 : std::min(static_cast<double>(v) / s, static_cast<double>(s) / v);
      row0[v * kPackedStride + s] = 129.0 - ratio;
    }
  }
  return row0;
}
inline const double* PackedTermTable() {
  static const double* const table = BuildPackedTermTable();
  return table;
}
struct TablePair {
  const double* p;
  const double* q;
  TablePair(const double* table, int p8, int q8)
      : p(table + p8 * kPackedStride), q(table + q8 * kPackedStride) {}
  __m256d Terms(int s) const { return _mm256_min_pd(_mm256_load_pd(p + s), _mm256_load_pd(q + s)); }
};

template <typename Pair>
inline void AddPackedPair(const Pair& pair, int first, int last, int clip_lo, int clip_hi,
                          double* acc) {
  const int base = first & ~3;
  // Lanes from base up to last: <= 3 for an empty interval (last = first − 1); negative (huge
  // as unsigned) only when last < first − 1, which no caller passes and for which the loop below
  // adds nothing.
  const unsigned n = static_cast<unsigned>(last - base + 1);
  if (__builtin_expect(n <= 8, 1)) {  // 92 % of the pairs: the long path out of the way
    const double* m = reinterpret_cast<const double*>(kPacked.masks[(first & 3) * 9 + n]);
    const __m256d t0 = _mm256_and_pd(pair.Terms(base), _mm256_load_pd(m));
    const __m256d t1 = _mm256_and_pd(pair.Terms(base + 4), _mm256_load_pd(m + 4));
    _mm256_store_pd(acc + base, _mm256_add_pd(_mm256_load_pd(acc + base), t0));
    _mm256_store_pd(acc + base + 4, _mm256_add_pd(_mm256_load_pd(acc + base + 4), t1));
    return;
  }
  first = std::max(first, clip_lo);
  last = std::min(last, clip_hi);
  const __m256d lane = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
  const __m256d lo = _mm256_set1_pd(first);
  const __m256d hi = _mm256_set1_pd(last);
  for (int s = first & ~3; s <= last; s += 4) {
    const __m256d index = _mm256_add_pd(_mm256_set1_pd(s), lane);
    const __m256d inside =
        _mm256_and_pd(_mm256_cmp_pd(index, lo, _CMP_GE_OQ), _mm256_cmp_pd(index, hi, _CMP_LE_OQ));
    const __m256d term = _mm256_and_pd(pair.Terms(s), inside);
    _mm256_store_pd(acc + s, _mm256_add_pd(_mm256_load_pd(acc + s), term));
  }
}

// The pairs of one pixel (kPaper: the paper variant, whose pair values are its interval's ends).
template <bool kPaper>
__attribute__((always_inline)) inline void AddPackedPixel(const double* table, const uint8_t* value,
                                                          const uint8_t* t, int stride, int clip_lo,
                                                          int clip_hi, double* acc) {
  if constexpr (kPaper) {
    AddPackedPair(TablePair(table, t[0], t[1]), t[0], t[1] - 1, clip_lo, clip_hi, acc);
    AddPackedPair(TablePair(table, t[2], t[3]), t[2], t[3] - 1, clip_lo, clip_hi, acc);
  } else {  // intervals set by other pixels, not clipped to the window (-6 % instructions)
    AddPackedPair(TablePair(table, value[0], value[-1]), t[0], t[1] - 1, clip_lo, clip_hi, acc);
    AddPackedPair(TablePair(table, value[0], value[-stride]), t[2], t[3] - 1, clip_lo, clip_hi,
                  acc);
  }
}

// A block of kRows × kCols pixels with its pixel loops unrolled (no loop branches to mispredict
// as the block shapes alternate).
template <bool kPaper, int kRows, int kCols>
__attribute__((always_inline)) inline void AddPackedPixels(const double* table,
                                                           const uint8_t* value,
                                                           const uint8_t* tests, int stride,
                                                           int clip_lo, int clip_hi, double* acc) {
#pragma GCC unroll 8
  for (int i = 0; i < kRows; ++i) {
#pragma GCC unroll 8
    for (int j = 0; j < kCols; ++j) {
      const ptrdiff_t k = static_cast<ptrdiff_t>(i) * stride + j;
      AddPackedPixel<kPaper>(table, value + k, tests + 4 * k, stride, clip_lo, clip_hi, acc);
    }
  }
}

template <bool kPaper>
__attribute__((always_inline)) inline void AddPackedPairsInline(const double* table,
                                                                const uint8_t* value,
                                                                const uint8_t* tests, int stride,
                                                                int rows, int cols, int clip_lo,
                                                                int clip_hi, double* acc) {
  // The window's blocks (visible_edge_search.cc) are 2 pixels high and 2, 4 or 6 wide.
  if (rows == 2) {
    switch (cols) {
      case 2:
        return AddPackedPixels<kPaper, 2, 2>(table, value, tests, stride, clip_lo, clip_hi, acc);
      case 4:
        return AddPackedPixels<kPaper, 2, 4>(table, value, tests, stride, clip_lo, clip_hi, acc);
      case 6:
        return AddPackedPixels<kPaper, 2, 6>(table, value, tests, stride, clip_lo, clip_hi, acc);
      default:
        break;
    }
  }
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      const ptrdiff_t k = static_cast<ptrdiff_t>(i) * stride + j;
      AddPackedPixel<kPaper>(table, value + k, tests + 4 * k, stride, clip_lo, clip_hi, acc);
    }
  }
}

void AddPackedPairsFast(const uint8_t* value, const uint8_t* tests, int stride, int rows, int cols,
                        bool paper, int clip_lo, int clip_hi, double* acc) {
  if (paper)
    AddPackedPairsInline<true>(PackedTermTable(), value, tests, stride, rows, cols, clip_lo,
                               clip_hi, acc);
  else
    AddPackedPairsInline<false>(PackedTermTable(), value, tests, stride, rows, cols, clip_lo,
                                clip_hi, acc);
}

void AddPackedBlocksFast(const uint8_t* value, const uint8_t* tests, int stride, bool paper,
                         const PackedBlock* blocks, int n_blocks) {
  // The accumulators to zero, in one loop over the union of their ranges (four stores per chunk;
  // unused slots repeat the first accumulator) instead of a memset call each.
  double* zero[4] = {};
  int n_zero = 0, lo = kPackedStride, hi = 0;
  for (int b = 0; b < n_blocks; ++b) {
    const PackedBlock& k = blocks[b];
    if (!k.zero_first) continue;
    if (n_zero == 4) {  // more than four: flush the first four
      for (int s = lo & ~3; s < hi + 8; s += 4)
        for (double* a : zero) _mm256_store_pd(a + s, _mm256_setzero_pd());
      n_zero = 0, lo = kPackedStride, hi = 0;
    }
    zero[n_zero++] = k.acc;
    lo = std::min(lo, k.clip_lo);
    hi = std::max(hi, k.clip_hi);
  }
  __m256d z = _mm256_setzero_pd();
  asm("" : "+x"(z));  // not known to be zero: no memset call per accumulator
  // One loop per count of accumulators, so that none is stored twice.
  switch (n_zero) {
    case 4:
      for (int s = lo & ~3; s < hi + 8; s += 4) {
        _mm256_store_pd(zero[0] + s, z);
        _mm256_store_pd(zero[1] + s, z);
        _mm256_store_pd(zero[2] + s, z);
        _mm256_store_pd(zero[3] + s, z);
      }
      break;
    case 3:
      for (int s = lo & ~3; s < hi + 8; s += 4) {
        _mm256_store_pd(zero[0] + s, z);
        _mm256_store_pd(zero[1] + s, z);
        _mm256_store_pd(zero[2] + s, z);
      }
      break;
    case 2:
      for (int s = lo & ~3; s < hi + 8; s += 4) {
        _mm256_store_pd(zero[0] + s, z);
        _mm256_store_pd(zero[1] + s, z);
      }
      break;
    case 1:
      for (int s = lo & ~3; s < hi + 8; s += 4) _mm256_store_pd(zero[0] + s, z);
      break;
    default:
      break;
  }
  const double* table = PackedTermTable();
  for (int b = 0; b < n_blocks; ++b) {
    const PackedBlock& k = blocks[b];
    const ptrdiff_t at = static_cast<ptrdiff_t>(k.row) * stride + k.col;
    if (paper)
      AddPackedPairsInline<true>(table, value + at, tests + 4 * at, stride, k.rows, k.cols,
                                 k.clip_lo, k.clip_hi, k.acc);
    else
      AddPackedPairsInline<false>(table, value + at, tests + 4 * at, stride, k.rows, k.cols,
                                  k.clip_lo, k.clip_hi, k.acc);
  }
}

// PackedContrasts() and PackedContrastsWithStrip(): with a strip (n_add >= 0), strip += Σ adds
// on the strip's range first, chunk by chunk, and the strip is the last part of each sum.
// kParts, kAdds >= 0: n_parts and n_add known at compile time (the part loops unrolled).
template <int kParts = -1, int kAdds = -1>
PackedMaximum PackedContrastsChunks(const double* const* parts, int n_parts, double* strip,
                                    const double* const* adds, int n_add, int strip_lo,
                                    int strip_hi, int s_min, int s_max, double tie_width,
                                    double* contrast) {
  if constexpr (kParts >= 0) n_parts = kParts;
  if constexpr (kAdds >= 0) n_add = kAdds;
  const int first_chunk = s_min & ~3;
  auto complete = [&](int s) {
    __m256d v = _mm256_load_pd(strip + s);
    for (int m = 0; m < n_add; ++m) v = _mm256_add_pd(v, _mm256_load_pd(adds[m] + s));
    _mm256_store_pd(strip + s, v);
    return v;
  };
  if (strip != nullptr)
    for (int s = strip_lo & ~3; s < first_chunk; s += 4) complete(s);
  const __m256d lane = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
  const __m256d lo = _mm256_set1_pd(s_min);
  const __m256d hi = _mm256_set1_pd(s_max);
  const __m256d none = _mm256_set1_pd(-1.0);
  __m256d best = none;
  int s = first_chunk;
  for (; s <= s_max; s += 4) {
    __m256d sum = _mm256_load_pd(parts[0] + s);
    for (int m = 1; m < n_parts; ++m) sum = _mm256_add_pd(sum, _mm256_load_pd(parts[m] + s));
    if (strip != nullptr) sum = _mm256_add_pd(sum, complete(s));
    const __m256d count =
        _mm256_round_pd(_mm256_mul_pd(sum, _mm256_set1_pd(1.0 / 128.0)), _MM_FROUND_TO_NEG_INF);
    // Exact, fused or not: count · 128 is exact and the difference exact (Sterbenz).
    const __m256d rest = _mm256_sub_pd(sum, _mm256_mul_pd(count, _mm256_set1_pd(128.0)));
    const __m256d index = _mm256_add_pd(_mm256_set1_pd(s), lane);
    const __m256d valid = _mm256_and_pd(
        _mm256_and_pd(_mm256_cmp_pd(index, lo, _CMP_GE_OQ), _mm256_cmp_pd(index, hi, _CMP_LE_OQ)),
        _mm256_cmp_pd(count, _mm256_setzero_pd(), _CMP_GT_OQ));
    const __m256d c = _mm256_blendv_pd(none, _mm256_div_pd(rest, count), valid);
    _mm256_store_pd(contrast + s, c);
    best = _mm256_max_pd(best, c);
  }
  if (strip != nullptr)
    for (; s <= strip_hi; s += 4) complete(s);
  const __m128d half = _mm_max_pd(_mm256_castpd256_pd128(best), _mm256_extractf128_pd(best, 1));
  PackedMaximum out;
  out.best = std::max(_mm_cvtsd_f64(half), _mm_cvtsd_f64(_mm_unpackhi_pd(half, half)));
  out.first = s_min;
  if (out.best < 0.0) return out;
  const __m256d limit = _mm256_set1_pd(out.best - tie_width);
  for (int s = first_chunk; s <= s_max; s += 4) {
    const int bits =
        _mm256_movemask_pd(_mm256_cmp_pd(_mm256_load_pd(contrast + s), limit, _CMP_GE_OQ));
    if (bits == 0) continue;
    if (out.near == 0) out.first = s + __builtin_ctz(bits);
    out.near += __builtin_popcount(bits);
  }
  return out;
}

PackedMaximum PackedContrastsFast(const double* const* parts, int n_parts, int s_min, int s_max,
                                  double tie_width, double* contrast) {
  return PackedContrastsChunks(parts, n_parts, nullptr, nullptr, 0, 0, -1, s_min, s_max, tie_width,
                               contrast);
}

PackedMaximum PackedContrastsWithStripFast(const double* const* parts, int n_parts, double* strip,
                                           const double* const* adds, int n_add, int strip_lo,
                                           int strip_hi, int s_min, int s_max, double tie_width,
                                           double* contrast) {
  // A window's calls (visible_edge_search.cc): 1 to 3 parts and one add fewer.
  if (n_add == n_parts - 1) {
    switch (n_parts) {
      case 1:
        return PackedContrastsChunks<1, 0>(parts, n_parts, strip, adds, n_add, strip_lo, strip_hi,
                                           s_min, s_max, tie_width, contrast);
      case 2:
        return PackedContrastsChunks<2, 1>(parts, n_parts, strip, adds, n_add, strip_lo, strip_hi,
                                           s_min, s_max, tie_width, contrast);
      case 3:
        return PackedContrastsChunks<3, 2>(parts, n_parts, strip, adds, n_add, strip_lo, strip_hi,
                                           s_min, s_max, tie_width, contrast);
      default:
        break;
    }
  }
  return PackedContrastsChunks(parts, n_parts, strip, adds, n_add, strip_lo, strip_hi, s_min, s_max,
                               tie_width, contrast);
}

// Four pixels per step: the chroma and l² gathered from tables, the division and the square
// root in 4-lane double (each correctly rounded, as the scalar ones).
void UciqeSaturationFast(const uint8_t* lab, int n, const double* chroma, double* out,
                         double* chr_out) {
  // l² = (L / 255)² for the 256 values of L, rounded as the scalar code does.
  static const std::array<double, 256> l_squared = [] {
    std::array<double, 256> t{};
    for (int v = 0; v < 256; ++v) {
      const double l = v / 255.0;
      double l2 = l * l;
      TURBID_NO_CONTRACT(l2);
      t[v] = l2;
    }
    return t;
  }();
  const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const uint8_t* p = lab + 3 * k;
    const __m128i l8 = _mm_setr_epi32(p[0], p[3], p[6], p[9]);
    const __m128i ab = _mm_setr_epi32(p[1] * 256 + p[2], p[4] * 256 + p[5], p[7] * 256 + p[8],
                                      p[10] * 256 + p[11]);
    const __m256d l2 = _mm256_mask_i32gather_pd(_mm256_setzero_pd(), l_squared.data(), l8, all, 8);
    const __m256d chr = _mm256_mask_i32gather_pd(_mm256_setzero_pd(), chroma, ab, all, 8);
    _mm256_storeu_pd(chr_out + k, chr);
    __m256d chr2 = _mm256_mul_pd(chr, chr);
    TURBID_NO_CONTRACT(chr2);  // no FMA: the sum is rounded after each product
    const __m256d sum = _mm256_add_pd(chr2, l2);
    _mm256_storeu_pd(out + k, _mm256_div_pd(chr, _mm256_sqrt_pd(sum)));
  }
  UciqeSaturation(lab + 3 * k, n - k, chroma, out + k, chr_out + k);
}

void UciqeSpreadFast(const uint8_t* lab, int n, const double* chroma, double mean, double* out) {
  const __m256d m = _mm256_set1_pd(mean);
  const __m256d one = _mm256_set1_pd(1.0);
  const __m256d sign = _mm256_set1_pd(-0.0);
  int k = 0;
  for (; k + 4 <= n; k += 4) {
    const uint8_t* p = lab + 3 * k;
    const __m128i ab = _mm_setr_epi32(p[1] * 256 + p[2], p[4] * 256 + p[5], p[7] * 256 + p[8],
                                      p[10] * 256 + p[11]);
    const __m256d chr = _mm256_mask_i32gather_pd(_mm256_setzero_pd(), chroma, ab,
                                                 _mm256_castsi256_pd(_mm256_set1_epi64x(-1)), 8);
    const __m256d q = _mm256_div_pd(m, chr);
    __m256d q2 = _mm256_mul_pd(q, q);
    TURBID_NO_CONTRACT(q2);  // no FMA: 1 − q² rounded after the product
    _mm256_storeu_pd(out + k, _mm256_andnot_pd(sign, _mm256_sub_pd(one, q2)));
  }
  UciqeSpread(lab + 3 * k, n - k, chroma, mean, out + k);
}

// Eight pixels per step. Zen 4 and most x86 cores serve a gather at about one element per cycle,
// a third of what plain loads reach (measured: a gather version took ~1.8× as long), so the look-ups
// are loads: per pixel, X, Y, Z as one 128-bit sum of its three {X, Y, Z, 0} term rows, then f(t)
// of each; L, a, b, the clamping packs and the interleaving are vector code over the 8 pixels. Each step stores 2 × 16 bytes of which 24 are its pixels, so it runs while two more
// pixels follow; the portable loop does the rest.
void BgrToLab8Fast(const uint8_t* bgr, int n, const Lab8Tables& t, uint8_t* lab) {
  const __m256i l_scale = _mm256_set1_epi32(kLab8LScale);
  const __m256i l_shift = _mm256_set1_epi32(kLab8LShift);
  const __m256i ab_shift = _mm256_set1_epi32(kLab8AbShift);
  const __m256i c500 = _mm256_set1_epi32(500);
  const __m256i c200 = _mm256_set1_epi32(200);
  // L0..L3 a0..a3 b0..b3 (after the packs, per 128-bit lane) → L0 a0 b0 L1 a1 b1 ...
  const __m256i interleave = _mm256_setr_epi8(0, 4, 8, 1, 5, 9, 2, 6, 10, 3, 7, 11, -1, -1, -1, -1,
                                              0, 4, 8, 1, 5, 9, 2, 6, 10, 3, 7, 11, -1, -1, -1, -1);
  int k = 0;
  for (; k + 10 <= n; k += 8) {
    alignas(32) int32_t f[3][8];
    for (int i = 0; i < 8; ++i) {
      // X, Y, Z of one pixel in one 128-bit sum of its three term rows.
      const uint8_t* p = bgr + 3 * (k + i);
      const __m128i sum = _mm_srai_epi32(
          _mm_add_epi32(
              _mm_add_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(t.xyz[0][p[0]])),
                            _mm_load_si128(reinterpret_cast<const __m128i*>(t.xyz[1][p[1]]))),
              _mm_load_si128(reinterpret_cast<const __m128i*>(t.xyz[2][p[2]]))),
          12);
      f[0][i] = t.cbrt[_mm_cvtsi128_si32(sum)];
      f[1][i] = t.cbrt[_mm_extract_epi32(sum, 1)];
      f[2][i] = t.cbrt[_mm_extract_epi32(sum, 2)];
    }
    const __m256i x = _mm256_load_si256(reinterpret_cast<const __m256i*>(f[0]));
    const __m256i y = _mm256_load_si256(reinterpret_cast<const __m256i*>(f[1]));
    const __m256i z = _mm256_load_si256(reinterpret_cast<const __m256i*>(f[2]));
    const __m256i l =
        _mm256_srai_epi32(_mm256_add_epi32(_mm256_mullo_epi32(y, l_scale), l_shift), 15);
    const __m256i a = _mm256_srai_epi32(
        _mm256_add_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(x, y), c500), ab_shift), 15);
    const __m256i b = _mm256_srai_epi32(
        _mm256_add_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(y, z), c200), ab_shift), 15);
    const __m256i la = _mm256_packus_epi32(l, a);  // u16: L0-3 a0-3 | L4-7 a4-7
    const __m256i b0 = _mm256_packus_epi32(b, _mm256_setzero_si256());  // u16: b0-3 0 | b4-7 0
    const __m256i bytes = _mm256_shuffle_epi8(_mm256_packus_epi16(la, b0), interleave);
    uint8_t* out = lab + 3 * k;
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out), _mm256_castsi256_si128(bytes));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 12), _mm256_extracti128_si256(bytes, 1));
  }
  avx2::BgrToLab8(bgr + 3 * k, n - k, t, lab + 3 * k);
}
// IfsttarStrongRow() 16 pixels at a time: the interleaved tests split into planes by a byte
// shuffle, a word permutation and 64-bit unpacks, then IfsttarStrongPair()'s arithmetic in 16-bit
// lanes (every value <= 256 compares as signed; the products and shifts, up to 255 · 256, as
// unsigned through a sign flip). The same integers as the portable loop, so the same flags.
inline __m256i LessU16(__m256i u, __m256i v) {  // u < v, unsigned 16-bit
  const __m256i flip = _mm256_set1_epi16(static_cast<short>(0x8000));
  return _mm256_cmpgt_epi16(_mm256_xor_si256(v, flip), _mm256_xor_si256(u, flip));
}

inline __m256i IfsttarStrongPairs(__m256i x, __m256i y, __m256i first, __m256i end, __m256i k,
                                  __m256i k_ratio) {
  const __m256i one = _mm256_set1_epi16(1);
  const __m256i p = _mm256_min_epu16(x, y), q = _mm256_max_epu16(x, y);
  const __m256i a = _mm256_max_epu16(first, one);
  const __m256i b_k = _mm256_mullo_epi16(_mm256_sub_epi16(end, one), k_ratio);
  const __m256i below = _mm256_and_si256(
      _mm256_cmpgt_epi16(p, a), LessU16(_mm256_slli_epi16(a, 8), _mm256_mullo_epi16(p, k_ratio)));
  const __m256i above = _mm256_and_si256(_mm256_cmpgt_epi16(end, _mm256_add_epi16(q, one)),
                                         LessU16(_mm256_slli_epi16(q, 8), b_k));
  // a <= q and e > p: not (a > q) and e > p.
  const __m256i middle = _mm256_andnot_si256(
      _mm256_cmpgt_epi16(a, q),
      _mm256_and_si256(_mm256_cmpgt_epi16(end, p),
                       LessU16(_mm256_slli_epi16(p, 8), _mm256_mullo_epi16(q, k))));
  return _mm256_and_si256(_mm256_cmpgt_epi16(end, a),
                          _mm256_or_si256(below, _mm256_or_si256(above, middle)));
}

// The tests of 8 pixels as {first v} × 8, {end v} × 8 | {first h} × 8, {end h} × 8.
inline __m256i TestPlanes(const uint8_t* t) {
  // Per 128-bit lane of 4 pixels: {first v} × 4, {end v} × 4, {first h} × 4, {end h} × 4.
  const __m256i group = _mm256_setr_epi8(0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15, 0, 4,
                                         8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15);
  const __m256i g =
      _mm256_shuffle_epi8(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(t)), group);
  return _mm256_permutevar8x32_epi32(g, _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7));
}

inline __m256i Widen(__m128i bytes) { return _mm256_cvtepu8_epi16(bytes); }

void IfsttarStrongRowFast(const uint8_t* tests, const uint8_t* row, const uint8_t* up, int n, int k,
                          int k_ratio, uint8_t* strong) {
  const __m256i k16 = _mm256_set1_epi16(static_cast<short>(k));
  const __m256i kr16 = _mm256_set1_epi16(static_cast<short>(k_ratio));
  // Steps of 16 pixels; a ragged end as one more step ending at n (flags recomputed, the same).
  for (int c = 1; c < n; c += 16) {
    if (c + 16 > n) {
      if (n < 17) break;
      c = n - 16;
    }
    const __m256i t0 = TestPlanes(tests + 4 * c), t1 = TestPlanes(tests + 4 * c + 32);
    const __m256i firsts = _mm256_unpacklo_epi64(t0, t1);  // first v × 16 | first h × 16
    const __m256i ends = _mm256_unpackhi_epi64(t0, t1);    // end v × 16 | end h × 16
    const __m256i x = Widen(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row + c)));
    const __m256i left = Widen(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row + c - 1)));
    const __m256i upper = Widen(_mm_loadu_si128(reinterpret_cast<const __m128i*>(up + c)));
    const __m256i vertical = IfsttarStrongPairs(x, left, Widen(_mm256_castsi256_si128(firsts)),
                                                Widen(_mm256_castsi256_si128(ends)), k16, kr16);
    const __m256i horizontal =
        IfsttarStrongPairs(x, upper, Widen(_mm256_extracti128_si256(firsts, 1)),
                           Widen(_mm256_extracti128_si256(ends, 1)), k16, kr16);
    const __m256i flags =
        _mm256_and_si256(_mm256_or_si256(vertical, horizontal), _mm256_set1_epi16(1));
    const __m256i packed = _mm256_packus_epi16(flags, flags);  // per lane: 8 flags twice
    _mm_storeu_si128(reinterpret_cast<__m128i*>(strong + c),
                     _mm256_castsi256_si128(_mm256_permute4x64_epi64(packed, 0x08)));
  }
  if (n >= 17) return;
  const uint16_t k_16 = static_cast<uint16_t>(k), kr_16 = static_cast<uint16_t>(k_ratio);
  for (int c = 1; c < n; ++c) {
    strong[c] = static_cast<uint8_t>(
        IfsttarStrongPair(row[c], row[c - 1], tests[4 * c], tests[4 * c + 1], k_16, kr_16) |
        IfsttarStrongPair(row[c], up[c], tests[4 * c + 2], tests[4 * c + 3], k_16, kr_16));
  }
}

// Bits 1..6 of the result: the sign bits of 32-bit words 0..5 of x.
inline unsigned SignBits6(__m256i x) {
  return (static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(x))) & 0x3Fu) << 1;
}

// SeparatedPairRows() with one 32-byte comparison per row: byte b of `le` is 0xFF when tests
// byte b <= s0; a pair {first, end} is separated when le(first) and not le(end), which the 32-bit
// shift lines up per pixel; bytes 0 (vertical) and 2 (horizontal) of each pixel, moved to the
// top of their word, then give the pixels' bits by movemask.
void SeparatedPairRowsFast(const uint8_t* tests, int stride, int s0, unsigned* rows) {
  const __m256i s = _mm256_set1_epi8(static_cast<char>(s0));
  for (int nn = 1; nn < 7; ++nn) {
    const __m256i t = _mm256_loadu_si256(
        reinterpret_cast<const __m256i*>(tests + 4 * static_cast<size_t>(nn - 1) * stride));
    const __m256i le = _mm256_cmpeq_epi8(_mm256_max_epu8(t, s), s);
    const __m256i sep = _mm256_andnot_si256(_mm256_srli_epi32(le, 8), le);
    const unsigned vertical = SignBits6(_mm256_slli_epi32(sep, 24));
    const unsigned horizontal = SignBits6(_mm256_slli_epi32(sep, 8));
    rows[nn] |= vertical | (vertical >> 1) | horizontal;
    rows[nn - 1] |= horizontal;
  }
}

}  // namespace avx2
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif

#if defined(TURBID_HAVE_AVX2_COPY)
#define TURBID_HAVE_AVX512_COPY 1
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f,avx2,fma")
#endif
// 16-lane copies of the two SSIM kernels that do most of the work. Every lane takes exactly the
// arithmetic of the 8-lane AVX2 kernels (same operations in the same order), so the results are
// bit for bit the same; what changes is the instruction count (on Zen 4 a 512-bit operation is one
// instruction for two 256-bit halves), which is what limits these loops.
namespace avx512 {

template <int kRadius>
void SymmetricColumnQuadFast(const float* const* rows, const float* weights, float* const* out,
                             int n) {
  constexpr int kTaps = 2 * kRadius + 1;
  __m512 w[kRadius + 1];
  for (int k = 0; k <= kRadius; ++k) w[k] = _mm512_set1_ps(weights[kRadius + k]);
  const auto row_sum = [&](const __m512* v, int t) {
    __m512 acc = _mm512_mul_ps(w[0], v[kRadius + t]);
    for (int k = 1; k <= kRadius; ++k)
      acc = _mm512_fmadd_ps(w[k], _mm512_add_ps(v[kRadius + t - k], v[kRadius + t + k]), acc);
    return acc;
  };
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    __m512 v[kTaps + 3];
    for (int s = 0; s < kTaps + 3; ++s) v[s] = _mm512_loadu_ps(rows[s] + j);
    for (int t = 0; t < 4; ++t) _mm512_storeu_ps(out[t] + j, row_sum(v, t));
  }
  if (j < n) {
    const float* rest[kTaps + 3];
    float* rest_out[4];
    for (int s = 0; s < kTaps + 3; ++s) rest[s] = rows[s] + j;
    for (int t = 0; t < 4; ++t) rest_out[t] = out[t] + j;
    avx2::SymmetricColumnQuadFast<kRadius>(rest, weights, rest_out, n - j);
  }
}

inline __m512 FormulaPs(__m512 dx, __m512 dy, __m512 mxy, __m512 mdd, __m512 offset, __m512 c1,
                        __m512 c2) {
  const __m512 two = _mm512_set1_ps(2.0f);
  const __m512 ux = _mm512_add_ps(dx, offset);
  const __m512 uy = _mm512_add_ps(dy, offset);
  const __m512 vxy = _mm512_fnmadd_ps(dx, dy, mxy);
  const __m512 a1 = _mm512_fmadd_ps(_mm512_mul_ps(two, ux), uy, c1);
  const __m512 a2 = _mm512_fmadd_ps(two, vxy, c2);
  const __m512 d = _mm512_sub_ps(dx, dy);
  const __m512 d2 = _mm512_mul_ps(d, d);
  const __m512 b1 = _mm512_add_ps(a1, d2);
  const __m512 b2 = _mm512_add_ps(a2, _mm512_sub_ps(mdd, d2));
  return _mm512_div_ps(_mm512_mul_ps(a1, a2), _mm512_mul_ps(b1, b2));
}

template <int kRadius>
inline __m512 HorizontalTaps(const float* p, const float* weights) {
  __m512 m = _mm512_mul_ps(_mm512_set1_ps(weights[kRadius]), _mm512_loadu_ps(p));
  for (int k = 1; k <= kRadius; ++k)
    m = _mm512_fmadd_ps(_mm512_set1_ps(weights[kRadius + k]),
                        _mm512_add_ps(_mm512_loadu_ps(p - k), _mm512_loadu_ps(p + k)), m);
  return m;
}

// (The zero-masking forms: GCC 12 warns about the unmasked ones' undefined pass-through.)
inline void StoreSsim(__m512 s, double* out) {
  const __m256d lo = _mm512_maskz_extractf64x4_pd(0xF, _mm512_castps_pd(s), 0);
  _mm512_storeu_pd(out, _mm512_maskz_cvtps_pd(0xFF, _mm256_castpd_ps(lo)));
  const __m256d hi = _mm512_maskz_extractf64x4_pd(0xF, _mm512_castps_pd(s), 1);
  _mm512_storeu_pd(out + 8, _mm512_maskz_cvtps_pd(0xFF, _mm256_castpd_ps(hi)));
}

template <int kRadius>
void SsimHorizontalFormulaFast(const float* const* moments, const float* weights, int taps, int n,
                               double offset, double c1, double c2, double* out) {
  if (n < 16)
    return avx2::SsimHorizontalFormulaFast<kRadius>(moments, weights, taps, n, offset, c1, c2, out);
  const __m512 o = _mm512_set1_ps(static_cast<float>(offset));
  const __m512 vc1 = _mm512_set1_ps(static_cast<float>(c1));
  const __m512 vc2 = _mm512_set1_ps(static_cast<float>(c2));
  for (int j0 = 0; j0 < n; j0 += 16) {
    const int j = std::min(j0, n - 16);
    __m512 m[4];
    for (int q = 0; q < 4; ++q) m[q] = HorizontalTaps<kRadius>(moments[q] + j, weights);
    StoreSsim(FormulaPs(m[0], m[1], m[2], m[3], o, vc1, vc2), out + j);
  }
}

}  // namespace avx512
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif

namespace {
SimdLevel CpuSimdLevel() {
#ifdef TURBID_HAVE_AVX2_COPY
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma"))
    return SimdLevel::kBaseline;
  return __builtin_cpu_supports("avx512f") ? SimdLevel::kAvx512 : SimdLevel::kAvx2;
#else
  return SimdLevel::kBaseline;
#endif
}

std::atomic<int> simd_level_cap{static_cast<int>(SimdLevel::kAvx512)};
// min(CPU level, cap), or −1 before the first use: one relaxed load per dispatched call (the
// window kernels are called a few times per 7×7 window).
std::atomic<int> active_level{-1};

int ComputeActiveLevel() {
  static const SimdLevel cpu = CpuSimdLevel();
  const int level = std::min(static_cast<int>(cpu), simd_level_cap.load(std::memory_order_relaxed));
  active_level.store(level, std::memory_order_relaxed);
  return level;
}

inline SimdLevel ActiveLevel() {
  const int level = active_level.load(std::memory_order_relaxed);
  return static_cast<SimdLevel>(level >= 0 ? level : ComputeActiveLevel());
}

inline bool UseAvx2() { return ActiveLevel() >= SimdLevel::kAvx2; }
inline bool UseAvx512() { return ActiveLevel() >= SimdLevel::kAvx512; }
}  // namespace

SimdLevel ActiveSimdLevel() { return ActiveLevel(); }

void SetSimdLevelCap(SimdLevel cap) {
  simd_level_cap.store(static_cast<int>(cap), std::memory_order_relaxed);
  ComputeActiveLevel();
}

#ifdef TURBID_HAVE_AVX2_COPY
#define TURBID_DISPATCH(call) return UseAvx2() ? avx2::call : base::call
#else
#define TURBID_DISPATCH(call) return base::call
#endif

void SymmetricColumnPair(const float* const* rows, const float* weights, int taps, float* out0,
                         float* out1, int n) {
#ifdef TURBID_HAVE_AVX2_COPY
  // The default window (sigma 1.5, truncate 3.5: 11 taps) with the tap loop unrolled.
  if (UseAvx2() && taps == 11)
    return avx2::SymmetricColumnPairFast<5>(rows, weights, taps, out0, out1, n);
  if (UseAvx2()) return avx2::SymmetricColumnPairFast<0>(rows, weights, taps, out0, out1, n);
#endif
  base::SymmetricColumnPair(rows, weights, taps, out0, out1, n);
}

void SymmetricColumnQuad(const float* const* rows, const float* weights, int taps,
                         float* const* out, int n) {
#ifdef TURBID_HAVE_AVX2_COPY
#ifdef TURBID_HAVE_AVX512_COPY
  if (UseAvx512() && taps == 11) return avx512::SymmetricColumnQuadFast<5>(rows, weights, out, n);
#endif
  if (UseAvx2() && taps == 11) return avx2::SymmetricColumnQuadFast<5>(rows, weights, out, n);
  if (UseAvx2()) {
    SymmetricColumnPair(rows, weights, taps, out[0], out[1], n);
    return SymmetricColumnPair(rows + 2, weights, taps, out[2], out[3], n);
  }
#endif
  base::SymmetricColumnQuad(rows, weights, taps, out, n);
}

void SsimHorizontalFormula(const float* const* moments, const float* weights, int taps, int n,
                           double offset, double c1, double c2, double* out) {
#ifdef TURBID_HAVE_AVX512_COPY
  if (UseAvx512() && taps == 11)
    return avx512::SsimHorizontalFormulaFast<5>(moments, weights, taps, n, offset, c1, c2, out);
#endif
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return taps == 11
               ? avx2::SsimHorizontalFormulaFast<5>(moments, weights, taps, n, offset, c1, c2, out)
               : avx2::SsimHorizontalFormulaFast<0>(moments, weights, taps, n, offset, c1, c2, out);
#endif
  base::SsimHorizontalFormula(moments, weights, taps, n, offset, c1, c2, out);
}

void CentredMomentsU8(const uint8_t* x, const uint8_t* y, int step, float offset, float* cx,
                      float* cy, float* xy, float* dd, int n) {
  TURBID_DISPATCH(CentredMomentsU8(x, y, step, offset, cx, cy, xy, dd, n));
}

double OrderedSum(const double* values, int n) { TURBID_DISPATCH(OrderedSum(values, n)); }

uint64_t SquaredDifferenceSumU8(const uint8_t* a, const uint8_t* b, size_t n) {
  TURBID_DISPATCH(SquaredDifferenceSumU8(a, b, n));
}

double SquaredDifferenceSumF32(const float* a, const float* b, size_t n) {
  TURBID_DISPATCH(SquaredDifferenceSumF32(a, b, n));
}

void WeberWindowSums(const double* table, int table_stride, const uint8_t* value,
                     const uint8_t* tests, int stride, int size, int s_min, int s_max,
                     double* sums_v, double* sums_h, double* counts_v, double* counts_h) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return avx2::WeberWindowSumsFast(table, table_stride, value, tests, stride, size, s_min, s_max,
                                     sums_v, sums_h, counts_v, counts_h);
#endif
  base::WeberWindowSums(table, table_stride, value, tests, stride, size, s_min, s_max, sums_v,
                        sums_h, counts_v, counts_h);
}

void AddPackedPairs(const uint8_t* value, const uint8_t* tests, int stride, int rows, int cols,
                    bool paper, int clip_lo, int clip_hi, double* acc) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return avx2::AddPackedPairsFast(value, tests, stride, rows, cols, paper, clip_lo, clip_hi, acc);
#endif
  base::AddPackedPairs(value, tests, stride, rows, cols, paper, clip_lo, clip_hi, acc);
}

void AddPackedBlocks(const uint8_t* value, const uint8_t* tests, int stride, bool paper,
                     const PackedBlock* blocks, int n_blocks) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::AddPackedBlocksFast(value, tests, stride, paper, blocks, n_blocks);
#endif
  base::AddPackedBlocks(value, tests, stride, paper, blocks, n_blocks);
}

PackedMaximum PackedContrasts(const double* const* parts, int n_parts, int s_min, int s_max,
                              double tie_width, double* contrast) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return avx2::PackedContrastsFast(parts, n_parts, s_min, s_max, tie_width, contrast);
#endif
  return base::PackedContrasts(parts, n_parts, s_min, s_max, tie_width, contrast);
}

PackedMaximum PackedContrastsWithStrip(const double* const* parts, int n_parts, double* strip,
                                       const double* const* adds, int n_add, int strip_lo,
                                       int strip_hi, int s_min, int s_max, double tie_width,
                                       double* contrast) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2())
    return avx2::PackedContrastsWithStripFast(parts, n_parts, strip, adds, n_add, strip_lo,
                                              strip_hi, s_min, s_max, tie_width, contrast);
#endif
  return base::PackedContrastsWithStrip(parts, n_parts, strip, adds, n_add, strip_lo, strip_hi,
                                        s_min, s_max, tie_width, contrast);
}

void IfsttarStrongRow(const uint8_t* tests, const uint8_t* row, const uint8_t* up, int n, int k,
                      int k_ratio, uint8_t* strong) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::IfsttarStrongRowFast(tests, row, up, n, k, k_ratio, strong);
#endif
  base::IfsttarStrongRow(tests, row, up, n, k, k_ratio, strong);
}

void SeparatedPairRows(const uint8_t* tests, int stride, int s0, unsigned* rows) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::SeparatedPairRowsFast(tests, stride, s0, rows);
#endif
  base::SeparatedPairRows(tests, stride, s0, rows);
}

void OctaveGrayU8(const uint8_t* bgr, int n, uint8_t* gray) {
  TURBID_DISPATCH(OctaveGrayU8(bgr, n, gray));
}

void BgrToLab8(const uint8_t* bgr, int n, const Lab8Tables& tables, uint8_t* lab) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::BgrToLab8Fast(bgr, n, tables, lab);
#endif
  base::BgrToLab8(bgr, n, tables, lab);
}

void UciqeSaturation(const uint8_t* lab, int n, const double* chroma, double* saturation,
                     double* chr) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::UciqeSaturationFast(lab, n, chroma, saturation, chr);
#endif
  base::UciqeSaturation(lab, n, chroma, saturation, chr);
}

void UciqeSpread(const uint8_t* lab, int n, const double* chroma, double mean, double* out) {
#ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::UciqeSpreadFast(lab, n, chroma, mean, out);
#endif
  base::UciqeSpread(lab, n, chroma, mean, out);
}

}  // namespace turbid::simd
