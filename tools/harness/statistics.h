// The summary tables' statistics (issue 32 item 3, docs/experiments.md "Uncertainty and best"):
// a percentile bootstrap confidence interval of a mean over items, and the Wilcoxon signed-rank
// test that decides whether the best method of a row beats the runner-up on the same items.
// Everything is deterministic: the bootstrap draws come from a counter-based generator keyed by a
// seed (no state shared between threads), so tables are identical for any thread count.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace turbid {

// Bootstrap resamples per interval and the interval's level (documented in docs/experiments.md).
constexpr int kBootstrapResamples = 2000;
constexpr double kConfidenceLevel = 0.95;
// The seed every table interval is drawn from (combined with the cell's level, method, metric).
constexpr uint64_t kBootstrapSeed = 20261129;

struct Interval {
  double lo = 0.0, hi = 0.0;
};

// Percentile bootstrap of the mean of `values` (NaN values are left out first): `resamples` means
// of n values drawn with replacement, index k of draw r = floor(u(seed, r, k) * n) with u the
// SplitMix64 counter generator, then the (1 - level)/2 and (1 + level)/2 quantiles of those means
// (linear interpolation between order statistics, "type 7", numpy's default). n = 1 (or all
// equal): [v, v]; n = 0: NaN; a non-finite value: both ends the mean.
Interval BootstrapMeanCi(const std::vector<double>& values, uint64_t seed,
                         int resamples = kBootstrapResamples, double level = kConfidenceLevel);

// The "type 7" quantile of sorted values (q in [0, 1]).
double SortedQuantile(const std::vector<double>& sorted, double q);

// Two-sided Wilcoxon signed-rank test of paired values a[i], b[i] (pairs with a NaN are dropped,
// as are zero differences, Wilcoxon's original rule; tied |differences| share their mean rank).
// The p-value is exact (the permutation distribution of the signed-rank sum given the ranks,
// counted by dynamic programming) for up to 50 non-zero differences, and the normal approximation
// with the tie correction beyond. n = 0 non-zero differences: p = 1.
struct SignedRankResult {
  int n = 0;             // non-zero differences used
  double w_plus = 0.0;   // sum of the ranks of the positive differences (a > b)
  double p_value = 1.0;  // two-sided
  bool exact = true;
};
SignedRankResult WilcoxonSignedRank(const std::vector<double>& a, const std::vector<double>& b);

// A stable 64-bit key of a string (FNV-1a), to give each table cell its own bootstrap stream.
uint64_t StableHash(const std::string& text);

}  // namespace turbid
