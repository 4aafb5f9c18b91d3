// The report's number formats (tools/harness/report_format.h): expected strings written out by
// hand from the rule (three significant digits of the largest magnitude, fixed decimals per
// metric, "≈ 0" for values that round to zero, scaling below 10^-3 and from 10^5 on).
#include "tools/harness/report_format.h"

#include <gtest/gtest.h>

#include <cmath>

namespace turbid {
namespace {

TEST(ReportFormat, DecimalsFollowTheLargestMagnitude) {
  const NumberFormat ssim = ChooseNumberFormat({0.3163, 0.85, -0.02});
  EXPECT_EQ(ssim.decimals, 3);
  EXPECT_EQ(ssim.exponent, 0);
  EXPECT_EQ(FormatNumber(0.3163, ssim), "0.316");
  EXPECT_EQ(FormatNumber(0.85, ssim), "0.850");
  EXPECT_EQ(FormatNumber(-0.02, ssim), "-0.020");
  const NumberFormat psnr = ChooseNumberFormat({9.2, 27.46});
  EXPECT_EQ(psnr.decimals, 1);
  EXPECT_EQ(FormatNumber(9.24, psnr), "9.2");
  EXPECT_EQ(FormatNumber(27.46, psnr), "27.5");
  const NumberFormat big = ChooseNumberFormat({1234.6});
  EXPECT_EQ(big.decimals, 0);
  EXPECT_EQ(FormatNumber(1234.6, big), "1235");
}

TEST(ReportFormat, RoundingUpToTheNextDecadeTakesOneDigitLess) {
  // 9.996 with three digits is 10.0, so the column has one decimal, not two.
  const NumberFormat f = ChooseNumberFormat({9.996, 1.0});
  EXPECT_EQ(f.decimals, 1);
  EXPECT_EQ(FormatNumber(9.996, f), "10.0");
}

TEST(ReportFormat, NearZeroIsShownAsSuchNotAsNoise) {
  // The column: 0.3163 next to 1.06e-06 and 8.681e-07.
  const NumberFormat f = ChooseNumberFormat({0.3163, 1.06e-06, 8.681e-07, 0.0});
  EXPECT_EQ(FormatNumber(1.06e-06, f), "≈ 0");
  EXPECT_EQ(FormatNumber(-8.681e-07, f), "≈ 0");
  EXPECT_EQ(FormatNumber(0.0, f), "0");
  EXPECT_EQ(FormatNumber(0.0004, f), "≈ 0");
  EXPECT_EQ(FormatNumber(0.0006, f), "0.001");
}

TEST(ReportFormat, TinyAndHugeMetricsAreScaled) {
  const NumberFormat tiny = ChooseNumberFormat({2.5e-6, 1.2e-6});
  EXPECT_EQ(tiny.exponent, -6);
  EXPECT_EQ(tiny.decimals, 2);
  EXPECT_EQ(FormatNumber(2.5e-6, tiny), "2.50");
  EXPECT_EQ(FormatNumber(1.2e-6, tiny), "1.20");
  EXPECT_EQ(ScaleSuffix(tiny), " ×10^-6");
  const NumberFormat huge = ChooseNumberFormat({3.0e7});
  EXPECT_EQ(huge.exponent, 7);
  EXPECT_EQ(FormatNumber(3.0e7, huge), "3.00");
  EXPECT_EQ(ScaleSuffix(ChooseNumberFormat({0.5})), "");
}

TEST(ReportFormat, NonFiniteAndEmpty) {
  const NumberFormat f = ChooseNumberFormat({HUGE_VAL, std::nan(""), 0.5});
  EXPECT_EQ(f.decimals, 3);  // inf and NaN do not set the scale
  EXPECT_EQ(FormatNumber(HUGE_VAL, f), "inf");
  EXPECT_EQ(FormatNumber(-HUGE_VAL, f), "-inf");
  EXPECT_EQ(FormatNumber(std::nan(""), f), "–");
  const NumberFormat none = ChooseNumberFormat({});
  EXPECT_EQ(none.decimals, 0);
  EXPECT_EQ(FormatNumber(0.0, none), "0");
}

TEST(ReportFormat, RunTimesKeepThreeSignificantDigitsEach) {
  EXPECT_EQ(FormatSignificant(0.012345), "0.0123");
  EXPECT_EQ(FormatSignificant(1.5), "1.50");
  EXPECT_EQ(FormatSignificant(1234.0), "1234");
  EXPECT_EQ(FormatSignificant(123456.0), "123456");
  EXPECT_EQ(FormatSignificant(0.00012345), "0.000123");
  EXPECT_EQ(FormatSignificant(2e-7), "≈ 0");
  EXPECT_EQ(FormatSignificant(0.0), "0");
}

}  // namespace
}  // namespace turbid
