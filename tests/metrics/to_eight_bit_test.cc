// ToEightBit (the 8-bit quantiser of the visible-edge, UIQM and UCIQE metrics): its AVX2 row
// kernel against the scalar formula it replaced, bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>

#include "metrics/simd_dispatch.h"
#include "metrics/visible_edges.h"
#include "core/error.h"

namespace turbid {
namespace {

// Pre-optimisation implementation (commit 3ef7f8e), less the input checks.
cv::Mat ReferenceToEightBit(const cv::Mat& image) {
  cv::Mat out(image.size(), CV_MAKETYPE(CV_8U, image.channels()));
  const int width = image.cols * image.channels();
  for (int i = 0; i < image.rows; ++i) {
    const float* src = image.ptr<float>(i);
    uint8_t* dst = out.ptr<uint8_t>(i);
    for (int j = 0; j < width; ++j) {
      const double scaled = std::floor(255.0 * static_cast<double>(src[j]) + 0.5);
      dst[j] = static_cast<uint8_t>(std::clamp(scaled, 0.0, 255.0));
    }
  }
  return out;
}

struct Cap {
  explicit Cap(simd::SimdLevel level) { simd::SetSimdLevelCap(level); }
  ~Cap() { simd::SetSimdLevelCap(simd::SimdLevel::kAvx512); }
};

// Values at and around every rounding boundary (k + 0.5) / 255, out of range, tiny and huge.
std::vector<float> Values() {
  std::vector<float> values;
  for (int k = -2; k <= 257; ++k) {
    const float edge = static_cast<float>((k + 0.5) / 255.0);
    values.push_back(edge);
    values.push_back(std::nextafter(edge, -1.0f));
    values.push_back(std::nextafter(edge, 2.0f));
    values.push_back(static_cast<float>(k / 255.0));
  }
  for (float v : {0.0f, -0.0f, 1e-40f, -1e-40f, 1.0f, -1.0f, 3e38f, -3e38f, 0.5f, 0.999999f}) values.push_back(v);
  cv::RNG rng(7);
  for (int k = 0; k < 20000; ++k) values.push_back(rng.uniform(-0.2f, 1.2f));
  return values;
}

TEST(ToEightBit, SameBytesAsTheScalarFormulaAtEveryLevel) {
  const std::vector<float> values = Values();
  for (int cols : {1, 7, 8, 9, 31, 333}) {
    for (int channels : {1, 3}) {
      const int rows = static_cast<int>(values.size()) / (cols * channels);
      cv::Mat image(rows, cols, CV_MAKETYPE(CV_32F, channels));
      std::copy(values.begin(), values.begin() + static_cast<long>(image.total() * channels),
                image.ptr<float>());
      const cv::Mat expected = ReferenceToEightBit(image);
      for (simd::SimdLevel level :
           {simd::SimdLevel::kBaseline, simd::SimdLevel::kAvx2, simd::SimdLevel::kAvx512}) {
        SCOPED_TRACE(::testing::Message() << cols << " x " << channels << ", level "
                                          << static_cast<int>(level));
        const Cap cap(level);
        const cv::Mat got = ToEightBit(image, "test");
        EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0.0);
      }
    }
  }
}

TEST(ToEightBit, NonFiniteValueThrowsAtEveryLevel) {
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                    -std::numeric_limits<float>::infinity()}) {
    for (int at : {0, 5, 8, 17}) {  // in a vector block and in the tail
      cv::Mat image(3, 19, CV_32F, cv::Scalar(0.5));
      image.at<float>(2, at) = bad;
      for (simd::SimdLevel level : {simd::SimdLevel::kBaseline, simd::SimdLevel::kAvx2}) {
        const Cap cap(level);
        EXPECT_THROW(ToEightBit(image, "test"), Error);
      }
    }
  }
}

}  // namespace
}  // namespace turbid
