// The visible-edge window search (metrics/visible_edge_search.h): the fast search, which decides
// from contrast sums added in any order and shared between neighbouring windows, against the
// published code's ordered search, window by window, on random bands of windows with few grey
// levels (exact ties), random levels, saturated values, both kinds of pair intervals, skipped
// windows (so that the shared sums are sometimes missing) and several thresholds; and the bound
// on the difference of the two contrasts that the decisions rely on.
#include "metrics/visible_edge_search.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace turbid::visible_edges {
namespace {

// A grid of gray values and pair tests (4 bytes per pixel, same stride) cut into windows of 7 × 7
// with a step of 4, as VisibleEdgeMask8 lays them out.
struct Grid {
  int bands = 0;
  int per_band = 0;
  int stride = 0;
  std::vector<uint8_t> value;
  std::vector<uint8_t> tests;
  bool own_intervals = false;

  Window At(int band, int k) const {
    const int r0 = 4 * band, c0 = 4 * k;
    int lo = 255, hi = 0;
    for (int i = 0; i < 7; ++i) {
      for (int j = 0; j < 7; ++j) {
        lo = std::min<int>(lo, value[(r0 + i) * stride + c0 + j]);
        hi = std::max<int>(hi, value[(r0 + i) * stride + c0 + j]);
      }
    }
    const size_t at = static_cast<size_t>(r0 + 1) * stride + c0 + 1;
    return {&value[at], &tests[4 * at], stride, std::max(lo, 1), std::max(hi, 1), own_intervals};
  }
};

// Values from `levels` (all 256 when empty); own = the paper's intervals [min, max) of each pair,
// otherwise random intervals as the ifsttar variant's come from other pixels.
Grid MakeGrid(int bands, int per_band, const std::vector<int>& levels, bool own, uint32_t seed) {
  std::mt19937 rng(seed);
  Grid g;
  g.bands = bands;
  g.per_band = per_band;
  g.stride = 4 * per_band + 3 + 8;
  const int rows = 4 * bands + 3;
  g.value.resize(static_cast<size_t>(rows) * g.stride);
  g.tests.resize(4 * g.value.size());
  g.own_intervals = own;
  for (uint8_t& v : g.value) {
    v = static_cast<uint8_t>(levels.empty() ? rng() % 256 : levels[rng() % levels.size()]);
  }
  for (int i = 1; i < rows; ++i) {
    for (int j = 1; j < g.stride; ++j) {
      const size_t k = static_cast<size_t>(i) * g.stride + j;
      uint8_t* t = &g.tests[4 * k];
      const uint8_t p = g.value[k], left = g.value[k - 1], up = g.value[k - g.stride];
      if (own) {
        t[0] = std::min(p, left);
        t[1] = std::max(p, left);
        t[2] = std::min(p, up);
        t[3] = std::max(p, up);
      } else {
        for (int d = 0; d < 2; ++d) {
          const int a = static_cast<int>(rng() % 256), b = static_cast<int>(rng() % 256);
          t[2 * d] = static_cast<uint8_t>(std::min(a, b));
          t[2 * d + 1] = static_cast<uint8_t>(rng() % 4 == 0 ? std::min(a, b) : std::max(a, b));
        }
      }
    }
  }
  return g;
}

struct Counts {
  int windows = 0;
  int rechecked = 0;
  int visible = 0;
};

// Every band of the grid through SearchBand (with some windows skipped), each choice against
// ExactSearch of the same window.
void ExpectSameChoices(const Grid& g, double half_threshold, double skip_fraction, uint32_t seed,
                       const std::string& what, Counts* counts) {
  std::mt19937 rng(seed);
  ThresholdSearch fast(half_threshold), exact(half_threshold);
  std::vector<std::vector<Window>> bands(g.bands);
  for (int b = 0; b < g.bands; ++b) {
    for (int k = 0; k < g.per_band; ++k) {
      const bool skip = (rng() % 1000) < skip_fraction * 1000;
      bands[b].push_back(skip ? Window{} : g.At(b, k));
    }
  }
  const std::vector<Window> none;
  std::vector<Choice> choices;
  for (int b = 0; b < g.bands; ++b) {
    fast.SearchBand(bands[b], b + 1 < g.bands ? bands[b + 1] : none, &choices);
    ASSERT_EQ(choices.size(), bands[b].size());
    for (int k = 0; k < g.per_band; ++k) {
      const Window& w = bands[b][k];
      if (w.value == nullptr) {
        EXPECT_FALSE(choices[k].visible);
        continue;
      }
      const Choice want = exact.ExactSearch(w);
      const std::string where = what + " band " + std::to_string(b) + " window " +
                                std::to_string(k) + " threshold " + std::to_string(half_threshold);
      ASSERT_EQ(choices[k].visible, want.visible) << where;
      if (want.visible) {
        ASSERT_EQ(choices[k].s0, want.s0) << where;
      }
      ++counts->windows;
      counts->rechecked += choices[k].exact;
      counts->visible += want.visible;
    }
  }
}

const std::vector<std::vector<int>>& Palettes() {
  static const std::vector<std::vector<int>> palettes = {
      {2, 6},           // binary: C(3) = C(4) = 1/3 exactly, a tie at the maximum
      {2, 18},          // ties away from the maximum (s·s' = 36)
      {0, 255},         // saturated
      {0, 1, 2},        // the lowest thresholds
      {100, 101, 103},  // flat: contrasts near the visibility threshold
      {30, 60, 90, 120},
      {12, 13, 40, 41, 200},
      {},  // all levels
  };
  return palettes;
}

TEST(VisibleEdgeSearch, FastSearchDecidesAsTheOrderedSums) {
  Counts counts;
  uint32_t seed = 7;
  for (bool own : {true, false}) {
    for (const std::vector<int>& levels : Palettes()) {
      for (double half_threshold : {0.025, 0.005, 0.1, 0.3, 0.5}) {
        for (double skip : {0.0, 0.3}) {
          const Grid g = MakeGrid(5, 9, levels, own, seed++);
          ExpectSameChoices(g, half_threshold, skip, seed++,
                            std::string(own ? "own" : "other") + " intervals, " +
                                std::to_string(levels.size()) + " levels",
                            &counts);
        }
      }
    }
  }
  // The test covers both ways of deciding: from the unordered sums and by the re-check.
  EXPECT_GT(counts.rechecked, 0);
  EXPECT_LT(counts.rechecked, counts.windows / 2);
  EXPECT_GT(counts.visible, 0);
  EXPECT_LT(counts.visible, counts.windows);
}

TEST(VisibleEdgeSearch, ThresholdExactlyAtAContrastIsRechecked) {
  // Binary {2, 6}: every C(s) over the separated pairs is the Weber term of (2, 6); the maximum
  // is 1/3 (s = 3 and s = 4). With the visibility threshold at 1/3 the decision "C > 1/3" rests
  // on rounding: the fast search must hand it to the ordered sums.
  const Grid g = MakeGrid(2, 3, {2, 6}, true, 3);
  const double third = 1.0 / 3.0;
  ThresholdSearch fast(third), exact(third);
  std::vector<Choice> choices;
  std::vector<Window> band = {g.At(0, 0), g.At(0, 1), g.At(0, 2)};
  fast.SearchBand(band, {}, &choices);
  for (size_t k = 0; k < band.size(); ++k) {
    EXPECT_TRUE(choices[k].exact);
    EXPECT_EQ(choices[k].visible, exact.ExactSearch(band[k]).visible);
  }
}

TEST(VisibleEdgeSearch, UnorderedContrastsWithinTheirErrorBound) {
  double largest = 0.0;
  uint32_t seed = 100;
  for (bool own : {true, false}) {
    for (const std::vector<int>& levels : Palettes()) {
      const Grid g = MakeGrid(3, 6, levels, own, seed++);
      ThresholdSearch a(0.025), b(0.025);
      for (int band = 0; band < g.bands; ++band) {
        for (int k = 0; k < g.per_band; ++k) {
          const Window w = g.At(band, k);
          a.ApproximateContrasts(w);
          b.ExactContrasts(w);
          for (int s = w.s_min; s <= w.s_max; ++s) {
            ASSERT_EQ(a.contrast(s) < 0, b.contrast(s) < 0) << "s " << s;  // same pair counts
            if (b.contrast(s) < 0) continue;
            largest = std::max(largest, std::abs(a.contrast(s) - b.contrast(s)));
          }
        }
      }
    }
  }
  EXPECT_LE(largest, ThresholdSearch::kApproximateError);
  EXPECT_GT(largest, 0.0);  // the two really are computed differently
}

TEST(VisibleEdgeSearch, FastSearchOfOneWindow) {
  const Grid g = MakeGrid(1, 1, {}, true, 11);
  ThresholdSearch fast(0.025), exact(0.025);
  const Choice a = fast.FastSearch(g.At(0, 0)), b = exact.ExactSearch(g.At(0, 0));
  EXPECT_EQ(a.visible, b.visible);
  if (b.visible) {
    EXPECT_EQ(a.s0, b.s0);
  }
}

}  // namespace
}  // namespace turbid::visible_edges
