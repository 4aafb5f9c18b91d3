// The tables' statistics (tools/harness/statistics.h) against closed forms and hand-computed
// cases: Wilcoxon signed-rank p-values counted by hand, the bootstrap interval of a mean against
// the exact bootstrap distribution of small samples, determinism, and the row verdict.
#include "tools/harness/statistics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "tests/support/test_support.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

TEST(Statistics, SignedRankAllPositiveIsTwoOverTwoToTheN) {
  // Every sign assignment of n ranks is equally likely under H0; all positive is the single most
  // extreme one on each side: p = 2 / 2^n.
  for (int n = 1; n <= 12; ++n) {
    std::vector<double> a, b;
    for (int i = 0; i < n; ++i) {
      a.push_back(1.0 + 0.1 * i);
      b.push_back(0.0);
    }
    const SignedRankResult r = WilcoxonSignedRank(a, b);
    EXPECT_EQ(r.n, n);
    EXPECT_DOUBLE_EQ(r.w_plus, n * (n + 1) / 2.0);
    EXPECT_DOUBLE_EQ(r.p_value, std::min(1.0, 2.0 / std::pow(2.0, n))) << n;
    EXPECT_TRUE(r.exact);
  }
  // Five items can never be significant at 5 % two-sided: 2/32 = 0.0625.
  EXPECT_GT(WilcoxonSignedRank({1, 2, 3, 4, 5}, {0, 0, 0, 0, 0}).p_value, 0.05);
}

TEST(Statistics, SignedRankHandCountedCases) {
  // d = 1, 2, -3, 4, 5: ranks 1..5, W+ = 12. Subsets of {1..5} with sum <= 3: {}, {1}, {2}, {3},
  // {1,2} = 5 of 32, so P(W+ >= 12) = 5/32 and p = 10/32.
  SignedRankResult r = WilcoxonSignedRank({1, 2, -3, 4, 5}, {0, 0, 0, 0, 0});
  EXPECT_DOUBLE_EQ(r.w_plus, 12.0);
  EXPECT_DOUBLE_EQ(r.p_value, 10.0 / 32.0);
  // Zero differences and NaN pairs are dropped: the same test.
  r = WilcoxonSignedRank({1, 2, -3, 4, 5, 7, std::nan("")}, {0, 0, 0, 0, 0, 7, 1});
  EXPECT_EQ(r.n, 5);
  EXPECT_DOUBLE_EQ(r.p_value, 10.0 / 32.0);
  // Ties: |d| = 1, 1, 2 -> mid-ranks 1.5, 1.5, 3; d = +1, -1, +2: W+ = 4.5. The 8 sign
  // assignments give W+ in {0, 1.5, 1.5, 3, 3, 4.5, 4.5, 6}; P(W+ >= 4.5) = 3/8, P(<= 4.5) = 7/8,
  // p = 2 * 3/8 = 0.75.
  r = WilcoxonSignedRank({1, -1, 2}, {0, 0, 0});
  EXPECT_DOUBLE_EQ(r.w_plus, 4.5);
  EXPECT_DOUBLE_EQ(r.p_value, 0.75);
  // Symmetric: swapping a and b gives the same p.
  EXPECT_DOUBLE_EQ(WilcoxonSignedRank({0, 0, 0}, {1, -1, 2}).p_value, 0.75);
  // No non-zero difference: p = 1.
  EXPECT_EQ(WilcoxonSignedRank({1, 2}, {1, 2}).p_value, 1.0);
}

TEST(Statistics, SignedRankNormalApproximationBeyondFifty) {
  // 60 differences, all positive, distinct: z = (W - mu) / sigma with mu = n(n+1)/4,
  // sigma^2 = n(n+1)(2n+1)/24; p = erfc(z / sqrt 2).
  std::vector<double> a, b(60, 0.0);
  for (int i = 0; i < 60; ++i) a.push_back(i % 2 == 0 ? 1.0 + i : -1.0 - i);
  const SignedRankResult r = WilcoxonSignedRank(a, b);
  EXPECT_FALSE(r.exact);
  const double n = 60, mu = n * (n + 1) / 4, sigma = std::sqrt(n * (n + 1) * (2 * n + 1) / 24);
  double w = 0;
  for (int i = 0; i < 60; i += 2) w += i + 1;  // ranks of the positive ones
  EXPECT_DOUBLE_EQ(r.w_plus, w);
  EXPECT_NEAR(r.p_value, std::erfc(std::fabs(w - mu) / sigma / std::sqrt(2.0)), 1e-12);
}

// The exact bootstrap distribution of the mean of {x1, x2, x3}: 27 equally likely resamples.
TEST(Statistics, BootstrapIntervalMatchesTheExactBootstrapDistribution) {
  const std::vector<double> x = {0.0, 1.0, 5.0};
  std::vector<double> exact;
  for (double a : x)
    for (double b : x)
      for (double c : x) exact.push_back((a + b + c) / 3.0);
  std::sort(exact.begin(), exact.end());
  // With many resamples the interval's ends are the exact distribution's 2.5 % and 97.5 %
  // quantiles; the distribution is discrete (steps of 1/27 in probability), and those quantiles
  // lie inside steps, so the ends are exact values of it.
  const Interval ci = BootstrapMeanCi(x, 99, 200000);
  EXPECT_DOUBLE_EQ(ci.lo, 0.0);  // P(mean = 0) = 1/27 > 2.5 %
  EXPECT_DOUBLE_EQ(ci.hi, 5.0);  // P(mean = 5) = 1/27 > 2.5 %
  const Interval ci90 = BootstrapMeanCi(x, 99, 200000, 0.80);
  // 10 % quantile: P(mean <= 1/3) = 4/27 = 0.148 > 0.10 > P(mean = 0) = 0.037 -> 1/3.
  EXPECT_DOUBLE_EQ(ci90.lo, 1.0 / 3.0);
  // 90 %: P(mean >= 11/3) = P(two 5s and a 1, or three 5s) = (3 + 1)/27 = 0.148 > 0.10, and
  // P(mean >= 11/3 + ...) : the next value above is 5 (1/27 = 0.037) -> 11/3.
  EXPECT_DOUBLE_EQ(ci90.hi, 11.0 / 3.0);
  // Degenerate cases.
  EXPECT_EQ(BootstrapMeanCi({2.5}, 1).lo, 2.5);
  EXPECT_EQ(BootstrapMeanCi({2.5, 2.5, 2.5}, 1).hi, 2.5);
  EXPECT_TRUE(std::isnan(BootstrapMeanCi({}, 1).lo));
  EXPECT_EQ(BootstrapMeanCi({1.0, std::nan(""), 1.0}, 1).lo, 1.0);
}

TEST(Statistics, BootstrapIntervalOfManyItemsIsTheNormalOne) {
  // 400 values 0/1 (p = 0.3): the bootstrap means are Binomial(400, 0.3)/400, whose central 95 %
  // is p +- 1.96 sqrt(p (1 - p) / n) = 0.3 +- 0.0449 to within a step (1/400) and the resampling
  // error of 2000 draws (~0.003).
  std::vector<double> x(400, 0.0);
  for (int i = 0; i < 120; ++i) x[static_cast<size_t>(i) * 3 % 400] = 1.0;
  const Interval ci = BootstrapMeanCi(x, 7);
  const double half = 1.96 * std::sqrt(0.3 * 0.7 / 400);
  EXPECT_NEAR(ci.lo, 0.3 - half, 0.006);
  EXPECT_NEAR(ci.hi, 0.3 + half, 0.006);
  // Deterministic for a seed, different for another.
  EXPECT_EQ(BootstrapMeanCi(x, 7).lo, ci.lo);
  EXPECT_EQ(BootstrapMeanCi(x, 7).hi, ci.hi);
  EXPECT_NE(BootstrapMeanCi(x, 8).lo + BootstrapMeanCi(x, 8).hi, ci.lo + ci.hi);
  EXPECT_DOUBLE_EQ(SortedQuantile({1, 2, 3, 4}, 0.5), 2.5);  // type 7
  EXPECT_DOUBLE_EQ(SortedQuantile({1, 2, 3, 4}, 0.25), 1.75);
}

TEST(Statistics, RowVerdictNeedsThePairedTest) {
  const auto cell = [](std::vector<double> values) {
    SummaryCell c;
    c.values = std::move(values);
    c.stats = ComputeStats(c.values);
    return c;
  };
  // Six items, a above b on every one: p = 2/64 < 5 %, a is best.
  const SummaryCell a = cell({0.6, 0.7, 0.5, 0.8, 0.65, 0.7});
  const SummaryCell b = cell({0.5, 0.6, 0.45, 0.7, 0.6, 0.65});
  const SummaryCell floor = cell({0.9, 0.9, 0.9, 0.9, 0.9, 0.9});  // excluded (oracle)
  RowVerdict v = JudgeRow({&floor, &b, &a}, {true, false, false}, true);
  EXPECT_EQ(v.best, 2);
  EXPECT_EQ(v.runner_up, 1);
  EXPECT_TRUE(v.significant);
  EXPECT_DOUBLE_EQ(v.p_value, 2.0 / 64.0);
  // Lower is better: b wins, and also significantly.
  v = JudgeRow({&floor, &b, &a}, {true, false, false}, false);
  EXPECT_EQ(v.best, 1);
  EXPECT_TRUE(v.significant);
  // Five items (the example): never significant, "tied".
  const SummaryCell c5 = cell({0.6, 0.7, 0.5, 0.8, 0.65});
  const SummaryCell d5 = cell({0.5, 0.6, 0.45, 0.7, 0.6});
  v = JudgeRow({&c5, &d5}, {false, false}, true);
  EXPECT_EQ(v.best, 0);
  EXPECT_FALSE(v.significant);
  EXPECT_DOUBLE_EQ(v.p_value, 0.0625);
  // Higher mean, but most items favour the other (one outlier): not significant for the mean's
  // winner.
  const SummaryCell spike = cell({0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0});
  const SummaryCell steady = cell({0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1});
  v = JudgeRow({&spike, &steady}, {false, false}, true);
  EXPECT_EQ(v.best, 0);
  EXPECT_FALSE(v.significant);
}

TEST(Statistics, RegressWithinIntervalPassesItemNoiseOnly) {
  testing::TempDir dir;
  const std::string head = "level,method,metric,domain,n,mean,sd,ci_lo,ci_hi,min,max,failed\n";
  const std::string base =
      dir.Write("base.csv", head + "all,a,ssim,encoded,9,0.5,0.1,0.45,0.55,0.3,0.7,0\n");
  const std::string near =
      dir.Write("near.csv", head + "all,a,ssim,encoded,9,0.53,0.1,0.48,0.58,0.3,0.7,0\n");
  const std::string far =
      dir.Write("far.csv", head + "all,a,ssim,encoded,9,0.6,0.1,0.55,0.65,0.3,0.7,0\n");
  RegressOptions options;
  options.higher_is_better["ssim"] = false;  // so that both moves are regressions
  EXPECT_TRUE(Regress(base, near, options).failed());
  options.within_interval = true;
  const RegressReport near_report = Regress(base, near, options);
  EXPECT_FALSE(near_report.failed());
  EXPECT_EQ(near_report.within_noise, 1);
  EXPECT_NE(near_report.Format().find("within noise"), std::string::npos);
  const RegressReport far_report = Regress(base, far, options);
  EXPECT_TRUE(far_report.failed());  // 0.6 is outside [0.45, 0.55]
  EXPECT_EQ(far_report.within_noise, 0);
}

}  // namespace
}  // namespace turbid
