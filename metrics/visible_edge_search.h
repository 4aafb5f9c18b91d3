// The per-window threshold search of the visible-edge mask (metrics/visible_edges.cc) on 8-bit
// gray values: for one 7×7 window, the threshold s0 that maximises the mean Weber contrast C(s)
// of the pairs it separates (first argmax, as the published code), and whether C(s0) exceeds the
// visibility threshold. Internal to the metrics module; its own header so that the tests can
// compare the two ways of searching window by window.
//
// C(s) = (Σ_vertical + Σ_horizontal) / count, each Σ added in the code's pair order; rounding makes
// the result depend on that order, so the exact search adds in that order (ExactSearch). Those
// ordered sums take ~15 vector instructions per pair and chunk of 4 thresholds. FastSearch instead
// sums the same Weber contrasts, computed as 1 − min(v/s, s/v) (the AVX2 copy reads them from
// a table of those values), in any order (simd::AddPackedPairs()), which is within
// kApproximateError of
// the ordered C(s): the order freedom lets neighbouring windows share the sums of the pixels they
// have in common (windows overlap by two pixel columns and two pixel rows), so that each pair is
// summed about once instead of 2.25 times. It decides from that alone when
// the decision is clear
// by more than kMargin: the best threshold above every other one and the visibility threshold, or
// every C(s) below it. Otherwise (near-ties, a C(s) within kMargin of the threshold) it runs
// ExactSearch. Both give the same decision and s0 (tests/metrics/visible_edge_search_test.cc).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "metrics/simd_dispatch.h"

namespace turbid::visible_edges {

// Thresholds are in [1, 256]; Weber table rows hold columns [0, kTableStride) (s = 0 and s > 256
// hold 0, never summed) so that 4-wide chunks may run past s_max.
constexpr int kMaxThreshold = 256;
constexpr int kTableStride = kMaxThreshold + 8;

// Weber(s, v) = |s − v| / max(s, v) for v in [0, 255] (rows) and s in [1, 256] (columns).
const double* WeberTable();

// One window: `value` points at its pixel (1, 1) in an 8-bit gray image of row stride `stride`
// (the pixel's left and upper neighbours are read), `tests` at the same pixel in an image of the
// same stride holding 4 bytes per pixel: the vertical pair (pixel, left neighbour) is separated by
// the thresholds [tests[0], tests[1]) and the horizontal pair (pixel, upper neighbour) by
// [tests[2], tests[3]). The 6 × 6 pixels from (1, 1) carry the window's 72 pairs. Thresholds
// searched: [s_min, s_max], 1 <= s_min <= s_max <= 256.
// Integer tests of pairs that cannot reach the visibility threshold τ (= the code's percentage / 2),
// so that windows all of whose pairs are weak are skipped: a window's C(s) is a mean of its pairs'
// terms at s, at most their largest (up to a relative rounding of ~1e-14; the limits keep a 1e-9
// margin). Weber contrast W(s, v) = |s − v| / max(s, v) = 1 − min(s, v)/max(s, v).
//  - k: 1 − √(lo/hi) may exceed τ only when lo · 256 < hi · k (lo <= hi <= 255), the largest
//    term of a paper-variant pair of values lo, hi (see visible_edges.cc, WeakPairTest).
//  - k_ratio: 1 − lo/hi may exceed τ only when lo · 256 < hi · k_ratio (lo <= hi <= 256).
// The ifsttar variant sums the pair of values p <= q over thresholds [a, b] set by other pixels;
// its term at s is f(s) = min(W(s, p), W(s, q)). For s <= p, f(s) = 1 − s/p, falling in s; for
// s >= q, f(s) = 1 − q/s, rising; for p <= s <= q, f(s) = min(1 − p/s, 1 − s/q) <= 1 − √(p/q)
// (the two meet at s = √(pq)). So on [a, b], and on any part of it a window clips, f is at most
// f(a) = 1 − a/p when a < p, f(b) = 1 − q/b when b > q, and 1 − √(p/q) when [a, b] meets [p, q]:
// the pair is weak unless one of those is strong by the tests above (simd::IfsttarStrongRow();
// tests/metrics/simd_base_kernels_test.cc checks the claim on every (p, q) against the largest
// term over sampled intervals).
struct StrongLimits {
  int k = 256;
  int k_ratio = 256;
};
// The smallest limits that keep every pair whose bound exceeds τ / (1 + 1e-9) strong.
StrongLimits StrongPairLimits(double tau);

struct Window {
  const uint8_t* value = nullptr;
  const uint8_t* tests = nullptr;
  int stride = 0;
  int s_min = 1;
  int s_max = 1;
  // Every pair's interval is [min, max) of its own two values (the paper variant away from the
  // right and bottom image borders, where the pair maps are mirrored apart from the values).
  bool own_intervals = false;
};

struct Choice {
  bool visible = false;  // C(s0) > the visibility threshold / 2 (the code's test)
  int s0 = 0;            // the first argmax of C(s) (only meaningful when visible)
  bool exact = false;    // decided by the ordered sums (ExactSearch), not the unordered ones
};

class ThresholdSearch {
 public:
  // Largest difference between the unordered and the ordered C(s): the packed sums' ≤ 90
  // additions of values below 2^14 (one rounding ≤ 2^-40 each) and ≤ 4 relative roundings per
  // term (≤ 9e-11 in all), plus the ordered sums' ≤ 40 relative roundings of C ≤ 1 (≤ 5e-15).
  static constexpr double kApproximateError = 1e-10;
  // Decisions closer than this are re-checked with the ordered sums (10 × the error bound).
  static constexpr double kMargin = 1e-9;

  // half_threshold: the code's percentage / 2, i.e. VisibleEdgeOptions::visibility_threshold / 2.
  explicit ThresholdSearch(double half_threshold) : half_threshold_(half_threshold) {}
  // Not copyable: strip_base_ points into strips_.
  ThresholdSearch(const ThresholdSearch&) = delete;
  ThresholdSearch& operator=(const ThresholdSearch&) = delete;

  // The published code's search: C(s) from the ordered sums, first argmax over s with a non-zero
  // count, visible when C(s0) > half_threshold.
  Choice ExactSearch(const Window& w);

  // The same decisions for a band of windows, from the unordered sums where they decide (see the
  // file comment). band[k] is the window 4 pixels right of band[k − 1] (value == nullptr: not
  // searched; its choice is "not visible"); below[k] the window 4 pixels below band[k] (empty when
  // there is no band below). Bands must come in order, top to bottom, the `below` of one call
  // being the `band` of the next: the pairs that neighbouring windows share (two pixel columns to
  // the right, two pixel rows below) are summed once. Writes choices[k] for every k.
  void SearchBand(const std::vector<Window>& band, const std::vector<Window>& below,
                  std::vector<Choice>* choices);
  // One window alone (no sharing): SearchBand of a band of one.
  Choice FastSearch(const Window& w);

  // C(s) for s in [s_min, s_max] (−1 where no pair is separated), left in contrast(s): from the
  // ordered sums, or from the unordered ones of the window alone (this forgets the shared sums of
  // a SearchBand sequence).
  void ExactContrasts(const Window& w);
  void ApproximateContrasts(const Window& w);
  double contrast(int s) const { return contrast_[s]; }

 private:
  static constexpr int kStride = simd::kPackedStride;
  struct Range {
    int lo, hi;
  };
  // A window's unordered contrasts into contrast_ and where their maximum is; updates the
  // shared sums (see the .cc).
  simd::PackedMaximum PackedWindow(const std::vector<Window>& band,
                                   const std::vector<Window>& below, int k);
  Choice Decide(const Window& w, const simd::PackedMaximum& m);
  void Reserve(size_t n);            // the strips for bands of n windows
  // Window k's strip in strips_[buffer], 32-byte aligned (strip_base_, set by Reserve()).
  double* Strip(int buffer, int k) const {
    return strip_base_[buffer] + static_cast<size_t>(k) * kStride;
  }

  double half_threshold_;
  alignas(32) double sum_vertical_[kTableStride] = {};
  alignas(32) double sum_horizontal_[kTableStride] = {};
  alignas(32) double count_vertical_[kTableStride] = {};
  alignas(32) double count_horizontal_[kTableStride] = {};
  alignas(32) double contrast_[kTableStride] = {};
  // Unordered sums of the window's own pairs in pixel rows 0-3 when no strip came from the window
  // above (otherwise rows 2-3 are added to that strip); of the pixels it shares with the next
  // window (columns 4-5) in rows 2-3 and 4-5, two buffers each (this window's, the previous
  // window's); and, per window of the band, of its pixel rows 4-5, which the window below has as
  // rows 0-1 (two buffers: written, read).
  alignas(32) double own_top_[kStride] = {};
  alignas(32) double right_middle_[2][kStride] = {};
  alignas(32) double right_bottom_[2][kStride] = {};
  // The sums of rows 4-5 when there is no window below.
  alignas(32) double strip_scratch_[kStride] = {};
  int right_ = 0;                     // which right_* buffers the last window wrote
  bool have_left_ = false;            // the last window wrote them for the current one
  std::vector<double> strips_[2];     // per window, kStride doubles (see Strip())
  double* strip_base_[2] = {};        // the first 32-byte aligned element of strips_[b]
  std::vector<char> strip_valid_[2];  // per window: the strip holds the sums of its window below,
  std::vector<const uint8_t*> strip_value_[2], strip_tests_[2];  // which is this one
  std::vector<int> strip_lo_[2], strip_hi_[2];  // thresholds where the strip's sums are exact
  int strip_read_ = 0;
  std::vector<simd::PackedMaximum> maxima_;  // per window of the band being searched
};

}  // namespace turbid::visible_edges
