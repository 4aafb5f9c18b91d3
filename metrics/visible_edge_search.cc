#include "metrics/visible_edge_search.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace turbid::visible_edges {

StrongLimits StrongPairLimits(double tau) {
  auto weak = [tau](double bound) { return bound * (1.0 + 1e-9) <= tau; };
  StrongLimits limits;
  // For each hi, the smallest lo whose bound is weak (the bounds fall as lo rises); every lo
  // below it must pass lo · 256 < hi · k. A few weak pairs may pass too, which only costs a search.
  limits.k = 1;
  for (int hi = 1; hi < 256; ++hi) {
    int lo = hi;
    while (lo > 0 && weak(1.0 - std::sqrt(static_cast<double>(lo - 1) / hi))) --lo;
    if (lo > 0) limits.k = std::max(limits.k, (lo - 1) * 256 / hi + 1);
  }
  limits.k_ratio = 1;
  for (int hi = 1; hi <= 256; ++hi) {
    int lo = hi;
    while (lo > 0 && weak(1.0 - static_cast<double>(lo - 1) / hi)) --lo;
    if (lo > 0) limits.k_ratio = std::max(limits.k_ratio, (lo - 1) * 256 / hi + 1);
  }
  return limits;
}
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

simd::PackedMaximum ThresholdSearch::PackedWindow(const std::vector<Window>& band,
                                                  const std::vector<Window>& below, int k) {
  // The window's pixels (rows and columns 0-5 from w.value) in blocks of 2 × 2: rows 0-1 are the
  // rows 4-5 of the window above (summed there, with columns 0-5: a strip), columns 0-1 the
  // columns 4-5 of the window to the left (summed there, rows 2-3 and 4-5 apart).
  const Window& w = band[k];
  const int n = static_cast<int>(band.size());
  const Window* right = k + 1 < n && band[k + 1].value != nullptr ? &band[k + 1] : nullptr;
  const int n_below = static_cast<int>(below.size());
  const Window* down = k < n_below && below[k].value != nullptr ? &below[k] : nullptr;
  const Window* down_right = right != nullptr && k + 1 < n_below && below[k + 1].value != nullptr
                                 ? &below[k + 1]
                                 : nullptr;
  auto join = [](Range r, const Window* o) {
    return o == nullptr ? r : Range{std::min(r.lo, o->s_min), std::max(r.hi, o->s_max)};
  };
  const Range own{w.s_min, w.s_max};
  const Range bottom = join(own, down);
  const Range middle_right = join(own, right);
  const Range bottom_right = join(join(middle_right, down), down_right);
  const int read = strip_read_, write = 1 - strip_read_;
  double* strip_in = Strip(read, k);
  const bool have_top = strip_valid_[read][k] != 0 && strip_value_[read][k] == w.value &&
                        strip_tests_[read][k] == w.tests && strip_lo_[read][k] <= own.lo &&
                        own.hi <= strip_hi_[read][k];
  const bool have_left = have_left_;
  const int col_begin = have_left ? 2 : 0;
  const int cols = (right != nullptr ? 4 : 6) - col_begin;
  const int next = 1 - right_;
  // Rows 2-3 of the window's own columns go straight into the strip it got from the window
  // above (read once, by this window only); rows 4-5 of them into the strip it writes for the
  // window below, which the contrast pass completes with the shared blocks of columns 0-1 and
  // 4-5 (rows 4-5). So only the strip and the two blocks shared with the right window are zeroed.
  double* top = have_top ? strip_in : own_top_;
  double* strip = down != nullptr ? Strip(write, k) : strip_scratch_;
  simd::PackedBlock blocks[5];
  int n_blocks = 0;
  if (!have_top) blocks[n_blocks++] = {0, 0, 2, 6, own.lo, own.hi, true, own_top_};
  blocks[n_blocks++] = {2, col_begin, 2, cols, own.lo, own.hi, false, top};
  blocks[n_blocks++] = {4, col_begin, 2, cols, bottom.lo, bottom.hi, true, strip};
  if (right != nullptr) {
    blocks[n_blocks++] = {2, 4, 2, 2, middle_right.lo, middle_right.hi, true, right_middle_[next]};
    blocks[n_blocks++] = {4, 4, 2, 2, bottom_right.lo, bottom_right.hi, true, right_bottom_[next]};
  }
  simd::AddPackedBlocks(w.value, w.tests, w.stride, w.own_intervals, blocks, n_blocks);
  const double* parts[3] = {top};
  const double* adds[2];
  int n_parts = 1, n_adds = 0;
  if (have_left) {
    parts[n_parts++] = right_middle_[right_];
    adds[n_adds++] = right_bottom_[right_];
  }
  if (right != nullptr) {
    parts[n_parts++] = right_middle_[next];
    adds[n_adds++] = right_bottom_[next];
  }
  const simd::PackedMaximum m =
      simd::PackedContrastsWithStrip(parts, n_parts, strip, adds, n_adds, bottom.lo, bottom.hi,
                                     w.s_min, w.s_max, 2.0 * kMargin, contrast_);
  if (down != nullptr) {
    strip_valid_[write][k] = 1;
    strip_value_[write][k] = down->value;
    strip_tests_[write][k] = down->tests;
    strip_lo_[write][k] = bottom.lo;
    strip_hi_[write][k] = bottom.hi;
  }
  have_left_ = right != nullptr;
  if (right != nullptr) right_ = next;
  return m;
}

// Inline (its one caller is SearchBand()): returned through memory, the choice's fields were
// written as bytes and read back as one word, which store forwarding does not serve.
inline Choice ThresholdSearch::Decide(const Window& w, const simd::PackedMaximum& m) {
  // Every ordered C(s) is within kApproximateError < kMargin of its unordered value.
  if (m.best <= half_threshold_ - kMargin) return {false, w.s_min, false};
  // Visible, with s0 the best threshold, when every other one is clearly below it.
  if (m.best > half_threshold_ + kMargin && m.near == 1) return {true, m.first, false};
  return ExactSearch(w);
}

void ThresholdSearch::Reserve(size_t n) {
  for (int b = 0; b < 2; ++b) {
    if (strip_valid_[b].size() != n) {
      strips_[b].assign(n * kStride + 4, 0.0);  // + 4: room to align to 32 bytes
      double* data = strips_[b].data();
      const size_t misalignment = reinterpret_cast<uintptr_t>(data) % 32 / sizeof(double);
      strip_base_[b] = data + (misalignment == 0 ? 0 : 4 - misalignment);
      strip_valid_[b].assign(n, 0);
      strip_value_[b].assign(n, nullptr);
      strip_tests_[b].assign(n, nullptr);
      strip_lo_[b].assign(n, 0);
      strip_hi_[b].assign(n, -1);
    }
  }
}

void ThresholdSearch::SearchBand(const std::vector<Window>& band, const std::vector<Window>& below,
                                 std::vector<Choice>* choices) {
  const size_t n = band.size();
  Reserve(n);
  std::fill(strip_valid_[1 - strip_read_].begin(), strip_valid_[1 - strip_read_].end(), 0);
  choices->assign(n, Choice{});
  have_left_ = false;
  // All the band's sums first, then the decisions: a decision's branch waits for the end of its
  // window's contrast pass (divisions), and when it is mispredicted the next windows' work done
  // meanwhile is lost; in a separate loop its inputs are ready.
  maxima_.resize(n);
  for (size_t k = 0; k < n; ++k) {
    if (band[k].value == nullptr) {
      have_left_ = false;
      continue;
    }
    maxima_[k] = PackedWindow(band, below, static_cast<int>(k));
  }
  for (size_t k = 0; k < n; ++k)
    if (band[k].value != nullptr) (*choices)[k] = Decide(band[k], maxima_[k]);
  strip_read_ = 1 - strip_read_;
}

Choice ThresholdSearch::FastSearch(const Window& w) {
  std::vector<Choice> choices;
  SearchBand({w}, {}, &choices);
  return choices[0];
}

void ThresholdSearch::ApproximateContrasts(const Window& w) {
  const std::vector<Window> band = {w};
  Reserve(1);
  std::fill(strip_valid_[strip_read_].begin(), strip_valid_[strip_read_].end(), 0);
  have_left_ = false;
  PackedWindow(band, {}, 0);
}

}  // namespace turbid::visible_edges
