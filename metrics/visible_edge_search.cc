#include "metrics/visible_edge_search.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace turbid::visible_edges {
namespace {

constexpr int kPairRows = 6;  // pixels (1..6, 1..6) of a 7×7 window carry its pairs

// 1.0 / n for the pair counts of a window (at most 72), the same quotients as a division.
const double* InverseCounts() {
  static const std::array<double, 2 * 36 + 1> table = [] {
    std::array<double, 2 * 36 + 1> t{};
    for (int n = 1; n < static_cast<int>(t.size()); ++n) t[n] = 1.0 / n;
    return t;
  }();
  return table.data();
}

}  // namespace

const double* WeberTable() {
  static const std::vector<double> table = [] {
    std::vector<double> t(256 * kTableStride, 0.0);
    for (int v = 0; v < 256; ++v) {
      for (int s = 1; s <= kMaxThreshold; ++s) {
        t[v * kTableStride + s] =
            std::abs(static_cast<double>(s) - v) / std::max<double>(s, static_cast<double>(v));
      }
    }
    return t;
  }();
  return table.data();
}

void ThresholdSearch::ExactContrasts(const Window& w) {
  for (double* a : {sum_vertical_, sum_horizontal_, count_vertical_, count_horizontal_})
    std::fill(a + (w.s_min & ~3), a + w.s_max + 8, 0.0);
  simd::WeberWindowSums(WeberTable(), kTableStride, w.value, w.tests, w.stride, kPairRows, w.s_min,
                        w.s_max, sum_vertical_, sum_horizontal_, count_vertical_,
                        count_horizontal_);
  const double* inverse = InverseCounts();
  for (int s = w.s_min; s <= w.s_max; ++s) {
    const int count = static_cast<int>(count_vertical_[s] + count_horizontal_[s]);
    contrast_[s] = count == 0 ? -1.0 : inverse[count] * (sum_vertical_[s] + sum_horizontal_[s]);
  }
}

Choice ThresholdSearch::ExactSearch(const Window& w) {
  ExactContrasts(w);
  // First argmax over the thresholds that separate a pair (C is 0 elsewhere in the code).
  double best = 0.0;
  int s0 = w.s_min;
  for (int s = w.s_min; s <= w.s_max; ++s) {
    if (contrast_[s] > best) {
      best = contrast_[s];
      s0 = s;
    }
  }
  return {best > half_threshold_, s0, true};
}

simd::PackedMaximum ThresholdSearch::PackedSearch(const Window& w, const Window* next) {
  constexpr int kRows = kPairRows;
  // Pixel columns 0-1 of the window (shared with the window 4 pixels left), 2-3 (its own) and
  // 4-5 (shared with `next`).
  const bool have_left = right_value_ == w.value && right_tests_ == w.tests &&
                         right_lo_ <= w.s_min && w.s_max <= right_hi_;
  const double* left = shared_[right_];
  const int first_chunk = w.s_min & ~3;
  std::fill(window_ + first_chunk, window_ + w.s_max + 8, 0.0);
  std::fill(window_ + kStride + first_chunk, window_ + kStride + w.s_max + 8, 0.0);
  const int own_begin = have_left ? 2 : 0;
  const int own_end = next != nullptr ? 4 : 6;
  simd::AddPackedPairs(w.value + own_begin, w.tests + 4 * own_begin, w.stride, kRows,
                       own_end - own_begin, w.own_intervals, w.s_min, w.s_max, window_);
  double* right = shared_[1 - right_];
  if (next != nullptr) {
    const int lo = std::min(w.s_min, next->s_min);
    const int hi = std::max(w.s_max, next->s_max);
    std::fill(right + (lo & ~3), right + hi + 8, 0.0);
    std::fill(right + kStride + (lo & ~3), right + kStride + hi + 8, 0.0);
    simd::AddPackedPairs(w.value + 4, w.tests + 16, w.stride, kRows, 2, w.own_intervals, lo, hi, right);
    for (int s = lo; s <= hi; ++s) right[s] += right[kStride + s];
    right_ = 1 - right_;
    right_value_ = w.value + 4;
    right_tests_ = w.tests + 16;
    right_lo_ = lo;
    right_hi_ = hi;
  } else {
    right_value_ = nullptr;
  }
  const double* parts[4] = {window_, window_ + kStride};
  int n_parts = 2;
  if (have_left) parts[n_parts++] = left;
  if (next != nullptr) parts[n_parts++] = right;
  return simd::PackedContrasts(parts, n_parts, w.s_min, w.s_max, 2.0 * kMargin, contrast_);
}

void ThresholdSearch::ApproximateContrasts(const Window& w, const Window* next) {
  PackedSearch(w, next);
}

Choice ThresholdSearch::FastSearch(const Window& w, const Window* next) {
  const simd::PackedMaximum m = PackedSearch(w, next);
  // Every ordered C(s) is within kApproximateError < kMargin of its unordered value.
  if (m.best <= half_threshold_ - kMargin) return {false, w.s_min, false};
  // Visible, with s0 the best threshold, when every other one is clearly below it.
  if (m.best > half_threshold_ + kMargin && m.near == 1) return {true, m.first, false};
  return ExactSearch(w);
}

}  // namespace turbid::visible_edges
