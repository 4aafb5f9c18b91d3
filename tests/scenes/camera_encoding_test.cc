// The camera quantiser (scenes/camera_encoding.h) against an independent formula: the IEC 61966-2-1
// encoding evaluated in double and rounded, and the PNG round trip through image_io.
#include "scenes/camera_encoding.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/cpu.h"
#include "core/error.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

double EncodeReference(double v) {
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}
double DecodeReference(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

TEST(CameraEncoding, SrgbCodesMatchTheRoundedCurve) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int bits : {8, 16}) {
    const double levels = (1 << bits) - 1;
    int checked = 0;
    for (int i = 0; i < 200000; ++i) {
      // Uniform in the code domain, so dark values get their share.
      const float v = static_cast<float>(DecodeReference(uniform(rng)));
      const double code = EncodeReference(v) * levels;
      // Skip values within double rounding of a decision threshold (half a code).
      if (std::abs(code - std::floor(code) - 0.5) < 1e-6) continue;
      float q = v;
      QuantiseEncodedRow(&q, 1, CameraEncoding::kSrgb, bits);
      const double expected = DecodeReference(std::round(code) / levels);
      ASSERT_NEAR(q, expected, 1e-6 * expected + 1e-12) << "bits " << bits << " v " << v;
      ++checked;
    }
    EXPECT_GT(checked, 190000);
  }
}

TEST(CameraEncoding, ClipsNanAndLinearMatchesRounding) {
  float values[5] = {-0.5f, std::nanf(""), 2.0f, 0.5f, 0.25f};
  QuantiseEncodedRow(values, 5, CameraEncoding::kSrgb, 8);
  EXPECT_EQ(values[0], 0.0f);
  EXPECT_EQ(values[1], 0.0f);
  EXPECT_FLOAT_EQ(values[2], 1.0f);
  EXPECT_NEAR(values[3], DecodeReference(std::round(EncodeReference(0.5) * 255) / 255), 1e-7);
  float lin[2] = {0.5f, 0.2f};
  QuantiseEncodedRow(lin, 2, CameraEncoding::kLinear, 8);
  EXPECT_FLOAT_EQ(lin[0], 128.0f / 255.0f);
  EXPECT_FLOAT_EQ(lin[1], 51.0f / 255.0f);
  EXPECT_THROW(CameraEncodingFromName("gamma", "x"), Error);
}

TEST(CameraEncoding, PngRoundTripStoresTheCodesExactly) {
  testing::TempDir dir;
  for (int bits : {8, 16}) {
    for (CameraEncoding encoding : {CameraEncoding::kSrgb, CameraEncoding::kLinear}) {
      cv::Mat ramp(1, 70000, CV_32FC1);
      for (int x = 0; x < ramp.cols; ++x) ramp.at<float>(0, x) = x / 69999.0f;
      const cv::Mat q = QuantiseEncoded(ramp, encoding, bits);
      WriteImageOptions write;
      write.bit_depth = bits;
      write.transfer = TransferFor(encoding);
      const std::string path = dir.File("ramp.png");
      write.overwrite = true;
      WriteImage(path, q, write);
      ReadImageOptions read;
      read.transfer = TransferFor(encoding);
      const cv::Mat back = ReadImage(path, read);
      // Reading gives the decoded codes back (float decode in image_io vs double here).
      EXPECT_LT(cv::norm(back, q, cv::NORM_INF), 2e-6) << bits;
      // Quantising is idempotent: the decoded codes are fixed points.
      EXPECT_EQ(cv::norm(QuantiseEncoded(q, encoding, bits), q, cv::NORM_INF), 0.0) << bits;
    }
  }
}

// Every decision threshold, approached from both sides by adjacent floats: the code is the one a
// linear scan of the exact (double) thresholds gives, in the plain and the R <-> B quantiser.
TEST(CameraEncoding, SrgbCodesAreExactAtEveryThreshold) {
  for (int bits : {8, 16}) {
    const int levels = (1 << bits) - 1;
    std::vector<double> threshold(levels);
    for (int k = 0; k < levels; ++k) threshold[k] = DecodeReference((k + 0.5) / levels);
    const auto code_of = [&](float v) {  // the reference: count the thresholds <= v
      const auto it = std::upper_bound(threshold.begin(), threshold.end(), static_cast<double>(v));
      return static_cast<int>(it - threshold.begin());
    };
    std::vector<float> values;
    for (int k = 0; k < levels; k += bits == 8 ? 1 : 7) {
      const float near = static_cast<float>(threshold[k]);
      for (float v : {std::nextafter(near, 0.0f), near, std::nextafter(near, 2.0f)})
        values.push_back(v);
    }
    while (values.size() % 3 != 0) values.push_back(1.0f);
    std::vector<float> plain = values, swapped = values;
    QuantiseEncodedRow(plain.data(), static_cast<int>(plain.size()), CameraEncoding::kSrgb, bits);
    QuantiseEncodedRowSwapRB(swapped.data(), static_cast<int>(swapped.size()),
                             CameraEncoding::kSrgb, bits);
    for (size_t i = 0; i < values.size(); ++i) {
      const float expected =
          static_cast<float>(DecodeReference(double(code_of(values[i])) / levels));
      ASSERT_EQ(plain[i], expected) << "bits " << bits << " v " << values[i];
      const size_t j = i - i % 3 + (2 - i % 3);  // R <-> B within each pixel
      ASSERT_EQ(swapped[j], expected) << "bits " << bits << " v " << values[i];
    }
  }
}

// The vector kernels (AVX-512 and AVX2 where the CPU has them: the 8-bit one-step table's and the
// search's) and the portable loop give the same bits: values
// next to every 8-bit threshold, random values, NaN, negatives, values above 1 and a row length
// that leaves a tail; plain and R <-> B.
TEST(CameraEncoding, SrgbQuantiserIsTheSameAtEveryCpuLevel) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> uniform(-0.1f, 1.1f);
  for (int bits : {8, 16}) {
    std::vector<float> values;
    const int levels = (1 << bits) - 1;
    for (int k = 0; k < levels; k += bits == 8 ? 1 : 13) {
      const float near = static_cast<float>(DecodeReference((k + 0.5) / levels));
      for (float v : {std::nextafter(near, 0.0f), near, std::nextafter(near, 2.0f)})
        values.push_back(v);
    }
    for (int i = 0; i < 20000; ++i) values.push_back(uniform(rng));
    for (float v : {std::nanf(""), -1.0f, 0.0f, 1.0f, 2.0f, -0.0f, 1e-30f}) values.push_back(v);
    while (values.size() % 3 != 0 || values.size() % 8 == 0) values.push_back(0.5f);
    std::vector<float> results[3][2];
    const CpuLevel caps[3] = {CpuLevel::kScalar, CpuLevel::kAvx512, CpuLevel::kAvx2};
    for (int c = 0; c < 3; ++c) {
      SetCpuLevelCap(caps[c]);
      results[c][0] = results[c][1] = values;
      QuantiseEncodedRow(results[c][0].data(), static_cast<int>(values.size()),
                         CameraEncoding::kSrgb, bits);
      QuantiseEncodedRowSwapRB(results[c][1].data(), static_cast<int>(values.size()),
                               CameraEncoding::kSrgb, bits);
    }
    SetCpuLevelCap(CpuLevel::kAvx512);
    for (int c = 1; c < 3; ++c)
      for (int k = 0; k < 2; ++k)
        for (size_t i = 0; i < values.size(); ++i)
          ASSERT_EQ(results[0][k][i], results[c][k][i])
              << "bits " << bits << " v " << values[i] << (k ? " (R <-> B)" : "") << " level "
              << static_cast<int>(caps[c]);
  }
}

// The 8-bit code bytes (EncodeCodesRow8, AVX-512 where the CPU has it, and the portable loop) are
// EncodeCodes' codes and decode to QuantiseEncodedRow's values: next to every threshold, random,
// NaN, negative and above-1 values, a row length that leaves a tail; both encodings.
TEST(CameraEncoding, CodeBytesAreTheQuantisersCodesAtEveryCpuLevel) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> uniform(-0.1f, 1.1f);
  std::vector<float> values;
  for (int k = 0; k < 255; ++k) {
    for (double t : {DecodeReference((k + 0.5) / 255), (k + 0.5) / 255}) {
      const float near = static_cast<float>(t);
      for (float v : {std::nextafter(near, 0.0f), near, std::nextafter(near, 2.0f)})
        values.push_back(v);
    }
  }
  for (int i = 0; i < 20000; ++i) values.push_back(uniform(rng));
  for (float v : {std::nanf(""), -1.0f, 0.0f, 1.0f, 2.0f, -0.0f, 1e-30f}) values.push_back(v);
  values.push_back(0.5f);  // a tail of 16
  const int n = static_cast<int>(values.size());
  ASSERT_NE(n % 16, 0);
  for (CameraEncoding encoding : {CameraEncoding::kSrgb, CameraEncoding::kLinear}) {
    const cv::Mat row(1, n, CV_32FC1, values.data());
    const cv::Mat codes = EncodeCodes(row, encoding, 8);
    std::vector<float> decoded = values;
    QuantiseEncodedRow(decoded.data(), n, encoding, 8);
    for (CpuLevel cap : {CpuLevel::kScalar, CpuLevel::kAvx2, CpuLevel::kAvx512}) {
      SetCpuLevelCap(cap);
      std::vector<uint8_t> bytes(n, 77);
      EncodeCodesRow8(values.data(), n, encoding, bytes.data());
      SetCpuLevelCap(CpuLevel::kAvx512);
      for (int i = 0; i < n; ++i) {
        ASSERT_EQ(bytes[i], codes.at<float>(0, i))
            << "v " << values[i] << " level " << static_cast<int>(cap);
        float one = static_cast<float>(bytes[i]) / 255.0f;  // its decoded value, via the quantiser
        if (encoding == CameraEncoding::kSrgb) one = static_cast<float>(DecodeReference(one));
        ASSERT_NEAR(decoded[i], one, 1e-6) << "v " << values[i];
      }
    }
  }
}

}  // namespace
}  // namespace turbid
