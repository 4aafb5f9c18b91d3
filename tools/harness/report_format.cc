#include "tools/harness/report_format.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace turbid {

NumberFormat ChooseNumberFormat(const std::vector<double>& values, int significant) {
  double largest = 0.0;
  for (double v : values) {
    if (std::isfinite(v)) largest = std::max(largest, std::fabs(v));
  }
  NumberFormat format;
  if (largest == 0.0) {
    format.decimals = 0;
    return format;
  }
  int magnitude = static_cast<int>(std::floor(std::log10(largest)));
  // 9.9996 with 3 digits prints as 10.0: one digit more before the point.
  const double rounded = std::round(largest / std::pow(10.0, magnitude - significant + 1)) *
                         std::pow(10.0, magnitude - significant + 1);
  if (rounded >= std::pow(10.0, magnitude + 1)) ++magnitude;
  if (magnitude < -3 || magnitude >= 5) {
    format.exponent = magnitude;
    magnitude = 0;
  }
  format.decimals = std::clamp(significant - 1 - magnitude, 0, 6);
  return format;
}

std::string FormatNumber(double value, const NumberFormat& format) {
  if (std::isnan(value)) return "–";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  if (value == 0.0) return "0";
  const double scaled = value / std::pow(10.0, format.exponent);
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", format.decimals, scaled);
  const std::string text = buffer;
  if (text.find_first_of("123456789") == std::string::npos) return "≈ 0";
  return text;
}

std::string FormatSignificant(double value, int significant) {
  if (!std::isfinite(value) || value == 0.0) return FormatNumber(value, NumberFormat{});
  if (std::fabs(value) < 1e-6) return "≈ 0";
  NumberFormat format = ChooseNumberFormat({value}, significant);
  if (format.exponent != 0) {  // a run time of 10^5 ms and more: no scaling, no decimals
    format.decimals = std::max(0, significant - 1 - format.exponent);
    format.exponent = 0;
  }
  return FormatNumber(value, format);
}

std::string ScaleSuffix(const NumberFormat& format) {
  return format.exponent == 0 ? "" : " ×10^" + std::to_string(format.exponent);
}

}  // namespace turbid
