// Order statistics for the enhancers' percentiles: the k-th smallest value of a sample, as
// std::nth_element would place it at k, by radix selection (two or three linear passes instead of
// nth_element's partitioning; the same value, so results do not change).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

namespace turbid::enhancer_internal {

// The k-th smallest of `values` (no NaN; the value std::nth_element puts at k), by radix
// selection on order-preserving integer keys of the bits, 11 bits per pass: each pass counts the
// candidates' digits, keeps the bucket holding rank k; the last few are sorted. `values` is
// used as scratch (its contents are lost), so the selection allocates nothing of its size.
template <typename Float, typename Key, typename Alloc = std::allocator<Float>>
inline Float SelectKth(std::vector<Float, Alloc>& values, size_t k) {
  static_assert(sizeof(Float) == sizeof(Key) && (sizeof(Key) == 4 || sizeof(Key) == 8));
  constexpr int kBits = 11, kTotal = 8 * sizeof(Key);
  constexpr Key kSign = Key{1} << (kTotal - 1);
  // The keys overwrite the values in place (memcpy: no type punning through pointers).
  auto* bytes = reinterpret_cast<unsigned char*>(values.data());
  auto get = [bytes](size_t i) {
    Key u;
    std::memcpy(&u, bytes + i * sizeof(Key), sizeof u);
    return u;
  };
  auto set = [bytes](size_t i, Key u) { std::memcpy(bytes + i * sizeof(Key), &u, sizeof u); };
  size_t count = values.size();
  for (size_t i = 0; i < count; ++i) {
    const Key u = get(i);
    set(i, (u & kSign) != 0 ? static_cast<Key>(~u) : static_cast<Key>(u | kSign));
  }
  std::vector<size_t> hist(size_t{1} << kBits);
  bool all_equal = false;
  for (int shift = kTotal - kBits; count > 64; shift -= kBits) {
    const int s = std::max(shift, 0);
    const Key digits = static_cast<Key>((Key{1} << (shift + kBits - s)) - 1);
    std::fill(hist.begin(), hist.end(), 0);
    for (size_t i = 0; i < count; ++i) ++hist[(get(i) >> s) & digits];
    size_t bucket = 0;
    while (k >= hist[bucket]) k -= hist[bucket++];
    size_t kept = 0;
    for (size_t i = 0; i < count; ++i) {
      const Key u = get(i);
      if (((u >> s) & digits) == bucket) set(kept++, u);
    }
    count = kept;
    if (s == 0) {
      all_equal = true;  // every key left has the same bits
      break;
    }
  }
  Key u = get(all_equal ? 0 : k);
  if (!all_equal) {
    std::vector<Key> rest(count);
    for (size_t i = 0; i < count; ++i) rest[i] = get(i);
    std::nth_element(rest.begin(), rest.begin() + static_cast<std::ptrdiff_t>(k), rest.end());
    u = rest[k];
  }
  u = (u & kSign) != 0 ? static_cast<Key>(u & ~kSign) : static_cast<Key>(~u);
  Float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

}  // namespace turbid::enhancer_internal
