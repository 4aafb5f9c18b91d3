// Numbers in the report's tables (docs/report.md, "Numbers"): one format per metric, chosen from
// the largest magnitude the metric takes anywhere in the report, so that every cell of a column
// has the same decimals and values are compared digit by digit. Values that round to zero in that
// format are written "≈ 0" (never 1e-07 noise); a metric whose values are all tiny or huge is
// written scaled, with the power of ten in its header ("×10^-6").
#pragma once

#include <string>
#include <vector>

namespace turbid {

struct NumberFormat {
  int decimals = 3;  // digits after the point of the scaled value
  int exponent = 0;  // values are shown divided by 10^exponent (0: as they are)
};

// The format that gives the largest finite |value| `significant` significant digits. Magnitudes
// below 10^-3 or from 10^5 on are scaled to [1, 10). Decimals are at most 6. NaN and infinite
// values are ignored; none finite and non-zero: 0 decimals, no scaling.
NumberFormat ChooseNumberFormat(const std::vector<double>& values, int significant = 3);

// `value` in `format`: "0.853", "-12.4", "0" (exactly zero), "≈ 0" (non-zero, rounds to zero),
// "inf", "-inf", "–" (NaN: missing).
std::string FormatNumber(double value, const NumberFormat& format);

// A value with `significant` significant digits on its own (run times): "0.0123", "1234", "≈ 0"
// below 10^-6.
std::string FormatSignificant(double value, int significant = 3);

// The header suffix of a scaled format: " ×10^-6"; "" without scaling.
std::string ScaleSuffix(const NumberFormat& format);

}  // namespace turbid
