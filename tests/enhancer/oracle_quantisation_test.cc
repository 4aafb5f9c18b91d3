// The oracle's quantisation variance is taken in the camera's coded domain (issue 30 item 5):
// (Delta s)^2 / 12 with s the decoding slope at the pixel's code, checked against finite
// differences of the IEC 61966-2-1 sRGB decoding curve written out here.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "enhancer/oracle/oracle_internal.h"

namespace turbid {
namespace {

double DecodeSrgb(double code) {
  return code <= 0.04045 ? code / 12.92 : std::pow((code + 0.055) / 1.055, 2.4);
}
double EncodeSrgb(double v) {
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

TEST(OracleQuantisation, IsTheCodeStepTimesTheDecodingSlope) {
  const double delta = 1.0 / 255.0;
  oracle_internal::CodedQuantisation q;
  q.step_var = static_cast<float>(delta * delta / 12.0);
  q.srgb = true;
  for (double v : {0.0, 0.001, 0.003, 0.004, 0.01, 0.05, 0.1, 0.3, 0.6, 0.9, 1.0}) {
    const double code = EncodeSrgb(v), h = 1e-6;
    // The linear width of one code step at this code: Delta * d decode / d code.
    const double lo = std::max(code - h, v <= 0.0031308 ? 0.0 : 0.04046);
    const double slope = (DecodeSrgb(code + h) - DecodeSrgb(lo)) / (code + h - lo);
    const double expected = delta * delta * slope * slope / 12.0;
    EXPECT_NEAR(q.Variance(static_cast<float>(v)), expected, 2e-3 * expected) << "v " << v;
  }
  // Linear coding: Delta^2 / 12 everywhere.
  q.srgb = false;
  for (float v : {0.0f, 0.01f, 0.5f, 1.0f})
    EXPECT_FLOAT_EQ(q.Variance(v), static_cast<float>(delta * delta / 12.0));
}

TEST(OracleQuantisation, TheLinearStepOverstatesTheNoiseInTheDarksOfAnSrgbCamera) {
  // The default sensor (photons_at_white 4000, read noise 0.002, simulator/noise.h): the old
  // linear-light Delta = 1/255 overstated the noise standard deviation in the darks of an sRGB
  // camera; the coded-domain step does not.
  const double delta = 1.0 / 255.0, read = 0.002, photons = 4000.0;
  oracle_internal::CodedQuantisation q;
  q.step_var = static_cast<float>(delta * delta / 12.0);
  q.srgb = true;
  for (double v : {0.001, 0.005, 0.02}) {
    const double signal = v / photons + read * read;
    const double old_sd = std::sqrt(signal + delta * delta / 12.0);
    const double new_sd = std::sqrt(signal + q.Variance(static_cast<float>(v)));
    std::cout << "v " << v << ": old / coded-domain noise sd " << old_sd / new_sd << "\n";
    EXPECT_GT(old_sd / new_sd, 1.04) << v;
  }
  // Above the point where the slope is 1 the sRGB step is wider than the linear one.
  const double v1 = std::pow(1.055 / 2.4, 2.4 / 1.4);  // s(v1) = 1
  EXPECT_NEAR(q.Variance(static_cast<float>(v1)), delta * delta / 12.0, 1e-4 * delta * delta);
  EXPECT_GT(q.Variance(0.9f), delta * delta / 12.0);
}

}  // namespace
}  // namespace turbid
