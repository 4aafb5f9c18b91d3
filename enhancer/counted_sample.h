// A float sample whose percentile is wanted, counted while it is produced (`full`'s exposure
// percentile): the same value as SelectKth on the same values, with less work after the sample.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "enhancer/select.h"
#include "enhancer/simd_switch.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h>
#define TURBID_COUNTED_SAMPLE_AVX2 1
#endif

namespace turbid::enhancer_internal {

// The finite values of rows, every second one (`full`'s exposure sample), counted as they come:
// each is stored as SelectKth's order-preserving key, and the keys' top kTopBits are counted (two
// tables, alternating, so that runs of equal digits do not wait on one counter). The percentile
// then reads the keys once for those in the bucket holding the wanted rank and selects among them
// with SelectKth: the k-th smallest key is the one SelectKth finds on the whole sample, so the
// value is that of SelectKth (and PercentileOf) on the same values, bit for bit. With AVX2 (the
// hand-written kernels' switch) eight sampled values become keys at once, and the bucket's keys
// are found eight at a time; the keys, counts and selected value are the portable code's.
class CountedSample {
 public:
  // capacity: at least the number of values that will be added.
  explicit CountedSample(size_t capacity) : keys_(new uint32_t[capacity]) {
    for (auto& h : hist_) h.assign(size_t{1} << kTopBits, 0);
  }
  // Adds the finite values among row[0], row[2], row[4], ... (n values in the row).
  void AddEverySecondFinite(const float* row, int n) {
    int i = 0;
#ifdef TURBID_COUNTED_SAMPLE_AVX2
    if (UseHandWrittenAvx2()) i = AddEverySecondFiniteAvx2(row, n);
#endif
    AddEverySecondFiniteFrom(row, i, n);
  }
  bool empty() const { return n_ == 0; }
  // The value at `percentile` (%) of the values added (at least one), by rank floor(p/100 (n - 1))
  // as PercentileOf.
  double Percentile(double percentile) const {
    size_t k = static_cast<size_t>(std::floor(percentile / 100.0 * (n_ - 1)));
    uint32_t bucket = 0;
    for (;; ++bucket) {
      const size_t count = size_t{hist_[0][bucket]} + hist_[1][bucket];
      if (k < count) break;
      k -= count;
    }
    std::vector<float> values(size_t{hist_[0][bucket]} + hist_[1][bucket]);
    const uint32_t* __restrict keys = keys_.get();
    float* __restrict out = values.data();
    size_t i = 0, m = 0;
#ifdef TURBID_COUNTED_SAMPLE_AVX2
    if (UseHandWrittenAvx2()) i = BucketValuesAvx2(bucket, out, &m);
#endif
    for (size_t n = n_; i < n; ++i) {
      const uint32_t key = keys[i];
      if ((key >> (32 - kTopBits)) == bucket) out[m++] = KeyValue(key);
    }
    return enhancer_internal::SelectKth<float, uint32_t>(values, k);
  }

 private:
  static constexpr int kTopBits = 16;
  static constexpr uint32_t kSign = 0x80000000u;

  // The float whose key is `key`.
  static float KeyValue(uint32_t key) {
    const uint32_t u = (key & kSign) != 0 ? (key & ~kSign) : ~key;
    float f;
    std::memcpy(&f, &u, sizeof f);
    return f;
  }

  // AddEverySecondFinite from row[i] on (i even).
  void AddEverySecondFiniteFrom(const float* row, int i, int n) {
    uint32_t* __restrict keys = keys_.get() + n_;
    uint32_t* __restrict h0 = hist_[0].data();
    uint32_t* __restrict h1 = hist_[1].data();
    size_t m = 0;
    for (; i < n; i += 2) {
      uint32_t u;
      std::memcpy(&u, row + i, sizeof u);
      if ((u & ~kSign) >= 0x7f800000u) continue;  // not finite
      const uint32_t key = (u & kSign) != 0 ? ~u : (u | kSign);
      ++((m & 1) != 0 ? h1 : h0)[key >> (32 - kTopBits)];
      keys[m++] = key;
    }
    n_ += m;
  }

#ifdef TURBID_COUNTED_SAMPLE_AVX2
  // Sixteen row values at a time: the eight at even indices as keys (u ^ (sign-fill | sign bit)
  // is ~u for negative u, u | sign bit otherwise), stored and counted when all eight are finite,
  // else left to the scalar loop. Returns the row index reached (even).
  __attribute__((target("avx2"))) int AddEverySecondFiniteAvx2(const float* row, int n) {
    const __m256i evens_low = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
    const __m256i abs_mask = _mm256_set1_epi32(0x7fffffff);
    const __m256i inf = _mm256_set1_epi32(0x7f800000);
    const __m256i sign = _mm256_set1_epi32(static_cast<int>(kSign));
    uint32_t* const h0 = hist_[0].data();
    uint32_t* const h1 = hist_[1].data();
    uint32_t* const keys = keys_.get();
    size_t count = n_;  // kept in a register (the counters' stores could alias n_)
    int i = 0;
    for (; i + 16 <= n; i += 16) {
      const __m256i a = _mm256_permutevar8x32_epi32(
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(row + i)), evens_low);
      const __m256i b = _mm256_permutevar8x32_epi32(
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(row + i + 8)), evens_low);
      const __m256i u = _mm256_permute2x128_si256(a, b, 0x20);  // row[i], row[i + 2], ...
      const __m256i finite = _mm256_cmpgt_epi32(inf, _mm256_and_si256(u, abs_mask));
      if (_mm256_movemask_ps(_mm256_castsi256_ps(finite)) != 0xff) {
        n_ = count;
        AddEverySecondFiniteFrom(row, i, i + 16);
        count = n_;
        continue;
      }
      const __m256i key = _mm256_xor_si256(u, _mm256_or_si256(_mm256_srai_epi32(u, 31), sign));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(keys + count), key);
      // The buckets taken from the register (reading the stored keys back waited on the store).
      const __m256i top = _mm256_srli_epi32(key, 32 - kTopBits);
      const __m128i lo = _mm256_castsi256_si128(top), hi = _mm256_extracti128_si256(top, 1);
      ++h0[_mm_cvtsi128_si32(lo)];
      ++h1[_mm_extract_epi32(lo, 1)];
      ++h0[_mm_extract_epi32(lo, 2)];
      ++h1[_mm_extract_epi32(lo, 3)];
      ++h0[_mm_cvtsi128_si32(hi)];
      ++h1[_mm_extract_epi32(hi, 1)];
      ++h0[_mm_extract_epi32(hi, 2)];
      ++h1[_mm_extract_epi32(hi, 3)];
      count += 8;
    }
    n_ = count;
    return i;
  }

  // The values of the keys in `bucket`, eight keys compared at a time, into out[*m...]; returns
  // the key index reached.
  __attribute__((target("avx2"))) size_t BucketValuesAvx2(uint32_t bucket, float* out,
                                                          size_t* m) const {
    const uint32_t* keys = keys_.get();
    const __m256i want = _mm256_set1_epi32(static_cast<int>(bucket));
    size_t i = 0, k = *m;
    for (; i + 8 <= n_; i += 8) {
      const __m256i top = _mm256_srli_epi32(
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(keys + i)), 32 - kTopBits);
      unsigned mask = static_cast<unsigned>(
          _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(top, want))));
      for (; mask != 0; mask &= mask - 1) out[k++] = KeyValue(keys[i + __builtin_ctz(mask)]);
    }
    *m = k;
    return i;
  }
#endif

  std::unique_ptr<uint32_t[]> keys_;
  std::vector<uint32_t> hist_[2];
  size_t n_ = 0;
};

}  // namespace turbid::enhancer_internal
