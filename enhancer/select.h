// Order statistics for the enhancers' percentiles: the k-th smallest value of a sample, as
// std::nth_element would place it at k, by radix selection (two or three linear passes instead of
// nth_element's partitioning; the same value, so results do not change).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "core/cpu.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define TURBID_HAVE_SELECT_AVX512 1
#endif

namespace turbid::enhancer_internal {

namespace select_detail {

#ifdef TURBID_HAVE_SELECT_AVX512
// (GCC 12 warns of -Wmaybe-uninitialized inside avx512fintrin.h's own _mm512_undefined_*
// operands, GCC bug 105593; silenced for this kernel only.)
#if !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
// The keys among keys[0, count) whose digit (u >> s) & digits is `bucket`, moved to the front in
// order, sixteen at a time (vpcompressd; each block's kept keys are stored over keys already
// read, as kept <= i); returns how many.
__attribute__((target("avx512f"))) inline size_t KeepBucketAvx512(uint32_t* keys, size_t count,
                                                                  int s, uint32_t digits,
                                                                  uint32_t bucket) {
  const __m512i mask = _mm512_set1_epi32(static_cast<int>(digits));
  const __m512i want = _mm512_set1_epi32(static_cast<int>(bucket));
  const __m128i shift = _mm_cvtsi32_si128(s);
  size_t kept = 0, i = 0;
  for (; i + 16 <= count; i += 16) {
    const __m512i u = _mm512_loadu_si512(keys + i);
    const __mmask16 in =
        _mm512_cmpeq_epi32_mask(_mm512_and_si512(_mm512_srl_epi32(u, shift), mask), want);
    _mm512_storeu_si512(keys + kept, _mm512_maskz_compress_epi32(in, u));
    kept += static_cast<size_t>(__builtin_popcount(in));
  }
  for (; i < count; ++i) {
    const uint32_t u = keys[i];
    keys[kept] = u;
    kept += ((u >> s) & digits) == bucket;
  }
  return kept;
}
#if !defined(__clang__)
#pragma GCC diagnostic pop
#endif
#endif

// Radix selection of rank k among the `count` keys at `bytes` (order-preserving keys; used as
// scratch), with `Count` counters. Large candidate sets are counted in four tables, the keys dealt
// to them in turn and summed when a bucket is looked for: runs of keys in one bucket (a sample
// bunched in a few exponents) do not wait on one counter's previous increment.
template <typename Count, typename Key>
Key SelectKey(unsigned char* bytes, size_t count, size_t k) {
  constexpr int kBits = 11, kTotal = 8 * sizeof(Key);
  constexpr size_t kBuckets = size_t{1} << kBits;
  auto get = [bytes](size_t i) {
    Key u;
    std::memcpy(&u, bytes + i * sizeof(Key), sizeof u);
    return u;
  };
  auto set = [bytes](size_t i, Key u) { std::memcpy(bytes + i * sizeof(Key), &u, sizeof u); };
  // Uninitialised: each pass clears the tables it uses.
  const std::unique_ptr<Count[]> hist(new Count[4 * kBuckets]);
  Count* const h = hist.get();
  for (int shift = kTotal - kBits; count > 64; shift -= kBits) {
    const int s = std::max(shift, 0);
    const Key digits = static_cast<Key>((Key{1} << (shift + kBits - s)) - 1);
    // Four tables for large candidate sets; one for small ones (filling four costs more there).
    const size_t tables = count >= 16384 ? 4 : 1;
    std::fill(h, h + tables * kBuckets, Count{0});
    size_t i = 0;
    if (tables == 4) {
      for (; i + 4 <= count; i += 4) {
        ++h[(get(i) >> s) & digits];
        ++h[kBuckets + ((get(i + 1) >> s) & digits)];
        ++h[2 * kBuckets + ((get(i + 2) >> s) & digits)];
        ++h[3 * kBuckets + ((get(i + 3) >> s) & digits)];
      }
    }
    for (; i < count; ++i) ++h[(get(i) >> s) & digits];
    size_t bucket = 0;
    for (;; ++bucket) {
      size_t in_bucket = 0;
      for (size_t t = 0; t < tables; ++t) in_bucket += h[t * kBuckets + bucket];
      if (k < in_bucket) break;
      k -= in_bucket;
    }
    // The bucket's keys moved to the front, without a branch per key (the bucket holds a
    // fraction of them at random places: a branch would be mispredicted often).
    size_t kept = 0;
    i = 0;
#ifdef TURBID_HAVE_SELECT_AVX512
    if constexpr (sizeof(Key) == 4) {
      if (KernelCpuLevel() >= CpuLevel::kAvx512) {
        kept = KeepBucketAvx512(reinterpret_cast<uint32_t*>(bytes), count, s, digits,
                                static_cast<uint32_t>(bucket));
        i = count;
      }
    }
#endif
    for (; i < count; ++i) {
      const Key u = get(i);
      set(kept, u);
      kept += ((u >> s) & digits) == bucket;
    }
    count = kept;
    if (s == 0) return get(0);  // every key left has the same bits
  }
  std::vector<Key> rest(count);
  for (size_t i = 0; i < count; ++i) rest[i] = get(i);
  std::nth_element(rest.begin(), rest.begin() + static_cast<std::ptrdiff_t>(k), rest.end());
  return rest[k];
}

}  // namespace select_detail

// The k-th smallest of `values` (no NaN; the value std::nth_element puts at k), by radix
// selection on order-preserving integer keys of the bits, 11 bits per pass: each pass counts the
// candidates' digits, keeps the bucket holding rank k; the last few are sorted. `values` is
// used as scratch (its contents are lost), so the selection allocates nothing of its size.
template <typename Float, typename Key, typename Alloc = std::allocator<Float>>
inline Float SelectKth(std::vector<Float, Alloc>& values, size_t k) {
  static_assert(sizeof(Float) == sizeof(Key) && (sizeof(Key) == 4 || sizeof(Key) == 8));
  constexpr Key kSign = Key{1} << (8 * sizeof(Key) - 1);
  // The keys overwrite the values in place (memcpy: no type punning through pointers).
  auto* bytes = reinterpret_cast<unsigned char*>(values.data());
  const size_t count = values.size();
  for (size_t i = 0; i < count; ++i) {
    Key u;
    std::memcpy(&u, bytes + i * sizeof(Key), sizeof u);
    u = (u & kSign) != 0 ? static_cast<Key>(~u) : static_cast<Key>(u | kSign);
    std::memcpy(bytes + i * sizeof(Key), &u, sizeof u);
  }
  // 32-bit counters where they cannot overflow (the four tables then stay in L1).
  Key u = count <= UINT32_MAX ? select_detail::SelectKey<uint32_t, Key>(bytes, count, k)
                              : select_detail::SelectKey<uint64_t, Key>(bytes, count, k);
  u = (u & kSign) != 0 ? static_cast<Key>(u & ~kSign) : static_cast<Key>(~u);
  Float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

}  // namespace turbid::enhancer_internal
