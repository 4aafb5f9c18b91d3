// AVX2 + FMA copies of the visible-edge row kernels (split from simd_dispatch.cc, which picks them
// at run time; declarations in simd_edges_avx2.h). Each gives the portable loop's results bit for
// bit (tests/metrics/simd_dispatch_test.cc and the visible-edge tests run both).
#include "metrics/simd_edges_avx2.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

// As in simd_dispatch.cc: an optimisation barrier so a product is not contracted into an FMA
// (this file is compiled with -ffp-contract=fast, like simd_dispatch.cc).
#define TURBID_NO_CONTRACT(...) __asm__("" : "+x"(__VA_ARGS__))

#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,fma")
#endif
namespace turbid::simd::avx2 {

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
  IfsttarStrongRow(tests, row, up, n, k, k_ratio, strong);  // the portable loop's AVX2 copy
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
}  // namespace turbid::simd::avx2
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif
