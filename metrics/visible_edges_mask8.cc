// The visible-edge mask on 8-bit gray (see visible_edges.cc's design notes): windows in row bands
// whose pair tests, strong-pair flags and threshold ranges stay in cache; the threshold search of
// visible_edge_search.h; visible windows mark the pixels their threshold separates. Split from
// visible_edges.cc.
#include "metrics/visible_edges_mask8.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <vector>

#include "metrics/simd_dispatch.h"
#include "metrics/visible_edge_search.h"

namespace turbid::visible_edges {
namespace {

// Which pair tests of the paper variant can reach the visibility threshold τ at all. A pair's
// term at threshold s is min(W(s, lo), W(s, hi)) for its two values lo < hi, and the paper
// variant sums it for s in [lo, hi − 1] only, where it is min((s − lo)/s, (hi − s)/hi) <=
// 1 − √(lo/hi) (the two meet at s = √(lo·hi)). A window none of whose pairs can exceed τ has
// every C(s) <= τ (a mean of such terms, up to a relative rounding of ~1e-14; the table keeps a
// 1e-9 margin) and is not visible. The ifsttar variant sums each pair over an interval set by
// other pixels; its bound is simd::IfsttarStrongRow() (proof at StrongLimits),
// which prunes about a quarter of the windows searched on the bench pair.
class WeakPairTest {
 public:
  explicit WeakPairTest(double tau) : k_(StrongPairLimits(tau)) {}
  // False when a paper-variant pair test [lo, hi) cannot exceed τ (may be true for empty ones).
  bool Strong(int lo, int hi) const { return lo * 256 < hi * k_.k; }
  const StrongLimits& limits() const { return k_; }

 private:
  StrongLimits k_;
};

// The mask is read and written 8 bytes at a time as one uint64_t (here and in the r-bar scan):
// byte k of the word is mask column j0 + k only on a little-endian machine.
static_assert(std::endian::native == std::endian::little,
              "the mask's 8-byte words assume little-endian byte order");

// Byte k of kByteMasks[bits] is 255 when bit k of bits is set (bits < 128).
constexpr std::array<uint64_t, 128> MakeByteMasks() {
  std::array<uint64_t, 128> m{};
  for (unsigned bits = 0; bits < 128; ++bits)
    for (int k = 0; k < 7; ++k)
      if (bits >> k & 1) m[bits] |= uint64_t{0xFF} << (8 * k);
  return m;
}
constexpr std::array<uint64_t, 128> kByteMasks = MakeByteMasks();

// The pair tests of one image row (see BuildMaps()) as {vertical first, vertical end,
// horizontal first, horizontal end} per pixel j < n: `row` is the row, `up` and `up2` the two
// above it (all readable from index −2). Two branch-free loops, so that each vectorises.
void PairTestRow(const uint8_t* up2, const uint8_t* up, const uint8_t* row, int n, bool ifsttar,
                 uint8_t* __restrict out) {
  if (ifsttar) {
    for (int j = 0; j < n; ++j) {
      out[4 * j] = std::min(up[j - 2], up[j - 1]);
      out[4 * j + 1] = std::max(up[j - 1], up[j]);
      out[4 * j + 2] = std::min(up2[j - 1], up[j - 1]);
      out[4 * j + 3] = std::max(up[j - 1], row[j - 1]);
    }
  } else {
    for (int j = 0; j < n; ++j) {
      out[4 * j] = std::min(row[j], row[j - 1]);
      out[4 * j + 1] = std::max(row[j], row[j - 1]);
      out[4 * j + 2] = std::min(row[j], up[j]);
      out[4 * j + 3] = std::max(row[j], up[j]);
    }
  }
}

// strong[c] for c in [1, n): whether pixel c of a row of pair tests has a strong pair.
void StrongRow(const WeakPairTest& weak, const uint8_t* __restrict tests, int n,
               uint8_t* __restrict strong) {
  const WeakPairTest test = weak;
  for (int c = 1; c < n; ++c) {
    // Both tests always run (no branch): | on their 0/1 values, not ||.
    strong[c] =
        static_cast<uint8_t>(static_cast<uint8_t>(test.Strong(tests[4 * c], tests[4 * c + 1])) |
                             static_cast<uint8_t>(test.Strong(tests[4 * c + 2], tests[4 * c + 3])));
  }
}

// Per column c < n, the extremes of rows r0 .. r0 + rows − 1 of `at`.
void ColumnExtremes(const MirroredGray8& at, int r0, int rows, int n, uint8_t* __restrict lo,
                    uint8_t* __restrict hi) {
  std::copy(at.Row(r0), at.Row(r0) + n, lo);
  std::copy(at.Row(r0), at.Row(r0) + n, hi);
  for (int nn = 1; nn < rows; ++nn) {
    const uint8_t* row = at.Row(r0 + nn);
    for (int c = 0; c < n; ++c) {
      lo[c] = std::min(lo[c], row[c]);
      hi[c] = std::max(hi[c], row[c]);
    }
  }
}

// In place, for c < n − 6: lo[c] = min(lo[c .. c + 6]) and hi[c] = max(hi[c .. c + 6]) (the
// extremes of the 7 columns of the window from c), in three passes that vectorise: spans 2, 4, 7.
void SpanExtremes7(int n, uint8_t* __restrict lo, uint8_t* __restrict hi) {
  for (const int offset : {1, 2, 3}) {
    for (int c = 0; c + offset < n; ++c) {
      lo[c] = std::min(lo[c], lo[c + offset]);
      hi[c] = std::max(hi[c], hi[c + offset]);
    }
  }
}

// VisibleEdgeMask() on CV_8UC1 gray: the same windows, thresholds, sums and decisions. Windows
// go in bands of rows (step 4): each band computes the pair tests of its 6 pair rows (the maps of
// BuildMaps(): [ceil(a), ceil(b) − 1] = [a, b − 1] on integers, stored as {vertical first,
// vertical end, horizontal first, horizontal end} with exclusive ends, the layout
// simd::WeberWindowSums() reads) and which pixels have a strong pair, so that everything a band
// touches stays in cache.
class Mask8Builder {
 public:
  Mask8Builder(const VisibleEdgeOptions& options, const cv::Mat& gray8)
      : nl_(gray8.rows),
        nc_(gray8.cols),
        ifsttar_(options.variant == VisibleEdgeVariant::kIfsttar),
        half_threshold_(options.visibility_threshold / 2.0),
        weak_(half_threshold_),
        search_(half_threshold_),
        at_(gray8, kWindow),
        stride_(at_.cols()),
        n_windows_((nc_ + kStep - 1) / kStep),
        skip_up_to_(SkipTable(half_threshold_)) {
    for (Band& b : bands_) {
      b.tests.resize(4 * (static_cast<size_t>(kPairRows) * stride_ + 8));
      b.strong.resize(static_cast<size_t>(kPairRows) * stride_ + 8);
      b.windows.resize(n_windows_);
    }
    column_lo_.resize(stride_);
    column_hi_.resize(stride_);
    column_strong_.resize(stride_ + 8);
  }

  cv::Mat Build() {
    // The mask with 7 spare rows and 8 spare columns that windows at the borders may mark.
    cv::Mat padded = cv::Mat::zeros(nl_ + kWindow, nc_ + 8, CV_8UC1);
    std::vector<Choice> choices(n_windows_);
    const std::vector<Window> no_band;

    Prepare(0, bands_[0], nullptr);
    for (int r0 = 0, b = 0; r0 < nl_; r0 += kStep, b = 1 - b) {
      const bool has_below = r0 + kStep < nl_;
      if (has_below) Prepare(r0 + kStep, bands_[1 - b], &bands_[b]);
      search_.SearchBand(bands_[b].windows, has_below ? bands_[1 - b].windows : no_band, &choices);
      MarkVisible(r0, bands_[b], choices, &padded);
    }
    cv::Mat mask;
    padded(cv::Rect(0, 0, nc_, nl_)).copyTo(mask);
    return mask;
  }

 private:
  static constexpr int kPairRows = kWindow - 1;
  // One band of windows (rows r0 .. r0 + 6): its pair tests in the stride of `at` (column c at
  // index c; columns up to nc + 5 are used, 8 more are readable), which pixels have a strong
  // pair, and its windows (value nullptr: not searched). Two bands are kept, the one searched and
  // the one below it, which shares two pair rows with it.
  struct Band {
    std::vector<uint8_t> tests;  // 4 bytes per pixel
    std::vector<uint8_t> strong;
    std::vector<Window> windows;
  };

  // Every Weber term of a window is at most (hi − lo) / hi, and so is every C(s) up to a relative
  // rounding of ~1e-14: no threshold can be visible when that bound (with a 1e-9 margin) is below
  // the threshold. The bound grows with hi − lo, so per hi the test is hi − lo <= skip_up_to[hi]:
  // the largest difference it passes, found with the same double expression (no division per
  // window).
  static std::array<int, 256> SkipTable(double half_threshold) {
    auto below_threshold = [&](int difference, int hi) {
      const double bound = static_cast<double>(difference) / hi;
      return bound * (1.0 + 1e-9) <= half_threshold;
    };
    std::array<int, 256> skip_up_to{};
    for (int hi = 1; hi < 256; ++hi) {
      int d = std::clamp(static_cast<int>(half_threshold * hi), 0, hi);
      while (d >= 0 && !below_threshold(d, hi)) --d;
      while (d < hi && below_threshold(d + 1, hi)) ++d;
      skip_up_to[hi] = d;  // −1: no window with this hi is skipped
    }
    return skip_up_to;
  }

  // `above`: the band of r0 − 4 when it was prepared last, else nullptr.
  void Prepare(int r0, Band& band, const Band* above) {
    PreparePairRows(r0, band, above);
    PrepareWindows(r0, band);
  }

  void PreparePairRows(int r0, Band& band, const Band* above) {
    uint8_t* tests = band.tests.data();
    std::vector<uint8_t>& strong = band.strong;
    // Pair tests of padded rows r0 + 1 .. r0 + 6 (image row Reflect(r)), mirrored columns. They
    // depend on the padded row alone, so the two rows the band shares with the band above (its
    // rows 5 and 6) are copied from there.
    int first_row = 1;
    if (above != nullptr) {
      constexpr int kShared = kPairRows - kStep;
      std::memcpy(tests, above->tests.data() + 4 * static_cast<size_t>(kStep) * stride_,
                  4 * static_cast<size_t>(kShared) * stride_);
      std::memcpy(strong.data(), above->strong.data() + static_cast<size_t>(kStep) * stride_,
                  static_cast<size_t>(kShared) * stride_);
      first_row += kShared;
    }
    for (int nn = first_row; nn < kWindow; ++nn) {
      const int i = Reflect(r0 + nn, nl_);
      const uint8_t* up2 = at_.Row(i - 2);
      const uint8_t* up = at_.Row(i - 1);
      const uint8_t* row = at_.Row(i);
      uint8_t* tb = tests + 4 * static_cast<size_t>(nn - 1) * stride_;
      PairTestRow(up2, up, row, nc_, ifsttar_, tb);
      for (int c = nc_; c < nc_ + kWindow - 1; ++c)
        std::memcpy(tb + 4 * c, tb + 4 * Reflect(c, nc_), 4);
      // Which pixels of the row have a pair that can reach the threshold (the ifsttar variant's
      // with the values the window sums use: rows r0 + nn and r0 + nn − 1 of `at`).
      uint8_t* strong_row = &strong[static_cast<size_t>(nn - 1) * stride_];
      if (ifsttar_)
        simd::IfsttarStrongRow(tb, at_.Row(r0 + nn), at_.Row(r0 + nn - 1), nc_ + kWindow - 1,
                               weak_.limits().k, weak_.limits().k_ratio, strong_row);
      else
        StrongRow(weak_, tb, nc_ + kWindow - 1, strong_row);
    }
  }

  void PrepareWindows(int r0, Band& band) {
    const uint8_t* tests = band.tests.data();
    const std::vector<uint8_t>& strong = band.strong;
    // Extremes of the band's 7 rows per column, then of each window's 7 columns, for the
    // windows' ranges.
    const int n = nc_ + kWindow - 1;
    ColumnExtremes(at_, r0, kWindow, n, column_lo_.data(), column_hi_.data());
    SpanExtremes7(n, column_lo_.data(), column_hi_.data());
    // Per column, whether any of the band's 6 pair rows has a strong pair there; a window's six
    // columns from c0 + 1 are then read as one 8-byte word.
    std::copy(strong.begin(), strong.begin() + n, column_strong_.begin());
    for (int nn = 1; nn < kPairRows; ++nn) {
      const uint8_t* row = &strong[static_cast<size_t>(nn) * stride_];
      uint8_t* __restrict any = column_strong_.data();
      for (int c = 1; c < n; ++c) any[c] |= row[c];
    }
    // Which windows of the band are searched, and their threshold ranges.
    for (int c0 = 0, w = 0; c0 < nc_; c0 += kStep, ++w) {
      band.windows[w] = {};
      uint64_t any_strong;
      std::memcpy(&any_strong, &column_strong_[c0 + 1], 8);
      if ((any_strong & 0xFFFF'FFFF'FFFFu) == 0) continue;  // bytes 0-5: columns c0 + 1 .. c0 + 6
      const int lo_value = column_lo_[c0], hi_value = column_hi_[c0];
      // An all-black window has no separated pair at all; see skip_up_to for the bound.
      if (hi_value == 0 || hi_value - lo_value <= skip_up_to_[hi_value]) continue;
      band.windows[w] = {at_.Row(r0 + 1) + c0 + 1,
                         tests + 4 * (c0 + 1),
                         stride_,
                         std::max(lo_value, 1),
                         hi_value,
                         !ifsttar_ && r0 + kWindow - 1 < nl_ && c0 + kWindow - 1 < nc_};
    }
  }

  // The visible windows of the band at r0 mark the pixels of the pairs their s0 separates.
  void MarkVisible(int r0, const Band& band, const std::vector<Choice>& choices, cv::Mat* padded) {
    const uint8_t* tests = band.tests.data();
    for (int c0 = 0, w = 0; c0 < nc_; c0 += kStep, ++w) {
      if (!choices[w].visible) continue;
      const int s0 = choices[w].s0;
      // Pairs separated by s0 mark both pixels: bit k of rows[nn] is column c0 + k of row r0 + nn,
      // each row written as 8 bytes into the padded mask (no bounds tests).
      // s0 >= 255 separates no pair (every interval ends at 255 or before).
      if (s0 >= 255) continue;
      unsigned rows[kWindow] = {};  // bits of rows r0 .. r0 + 6
      simd::SeparatedPairRows(tests + 4 * static_cast<size_t>(c0 + 1), stride_, s0, rows);
      uint8_t* corner = padded->ptr<uint8_t>(r0) + c0;
      const size_t step = padded->step;
      for (int nn = 0; nn < kWindow; ++nn) {
        uint64_t word;
        std::memcpy(&word, corner + nn * step, 8);
        word |= kByteMasks[rows[nn]];
        std::memcpy(corner + nn * step, &word, 8);
      }
    }
  }

  const int nl_, nc_;
  const bool ifsttar_;
  const double half_threshold_;
  const WeakPairTest weak_;
  ThresholdSearch search_;
  const MirroredGray8 at_;  // padded values: row r, column c of the maps is at(r, c)
  const int stride_;
  const int n_windows_;
  const std::array<int, 256> skip_up_to_;
  Band bands_[2];
  std::vector<uint8_t> column_lo_, column_hi_, column_strong_;
};

}  // namespace

cv::Mat VisibleEdgeMask8(const VisibleEdgeOptions& options, const cv::Mat& gray8) {
  return Mask8Builder(options, gray8).Build();
}

}  // namespace turbid::visible_edges
