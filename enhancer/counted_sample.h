// A float sample whose percentile is wanted, counted while it is produced (`full`'s exposure
// percentile): the same value as SelectKth on the same values, with less work after the sample.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "enhancer/select.h"

namespace turbid::enhancer_internal {

// The finite values of rows, every second one (`full`'s exposure sample), counted as they come:
// each is stored as SelectKth's order-preserving key, and the keys' top kTopBits are counted (two
// tables, alternating, so that runs of equal digits do not wait on one counter). The percentile
// then reads the keys once for those in the bucket holding the wanted rank and selects among them
// with SelectKth: the k-th smallest key is the one SelectKth finds on the whole sample, so the
// value is that of SelectKth (and PercentileOf) on the same values, bit for bit.
class CountedSample {
 public:
  // capacity: at least the number of values that will be added.
  explicit CountedSample(size_t capacity) : keys_(capacity) {
    for (auto& h : hist_) h.assign(size_t{1} << kTopBits, 0);
  }
  // Adds the finite values among row[0], row[2], row[4], ... (n values in the row).
  void AddEverySecondFinite(const float* row, int n) {
    uint32_t* __restrict keys = keys_.data() + n_;
    uint32_t* __restrict h0 = hist_[0].data();
    uint32_t* __restrict h1 = hist_[1].data();
    size_t m = 0;
    for (int i = 0; i < n; i += 2) {
      uint32_t u;
      std::memcpy(&u, row + i, sizeof u);
      if ((u & ~kSign) >= 0x7f800000u) continue;  // not finite
      const uint32_t key = (u & kSign) != 0 ? ~u : (u | kSign);
      ++((m & 1) != 0 ? h1 : h0)[key >> (32 - kTopBits)];
      keys[m++] = key;
    }
    n_ += m;
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
    const uint32_t* __restrict keys = keys_.data();
    float* __restrict out = values.data();
    size_t m = 0;
    for (size_t i = 0, n = n_; i < n; ++i) {
      const uint32_t key = keys[i];
      if ((key >> (32 - kTopBits)) != bucket) continue;
      const uint32_t u = (key & kSign) != 0 ? (key & ~kSign) : ~key;
      std::memcpy(out + m++, &u, sizeof u);
    }
    return enhancer_internal::SelectKth<float, uint32_t>(values, k);
  }

 private:
  static constexpr int kTopBits = 16;
  static constexpr uint32_t kSign = 0x80000000u;
  std::vector<uint32_t> keys_;
  std::vector<uint32_t> hist_[2];
  size_t n_ = 0;
};

}  // namespace turbid::enhancer_internal
