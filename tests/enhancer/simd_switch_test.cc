// The hand-written AVX2 row kernels (guided filter windows of 9+ pixels, CLAHE binning and
// interpolation) against the portable loops they replace: identical results, bit for bit, on
// row widths with and without a remainder of 8.
#include "enhancer/simd_switch.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/paper/simplified.h"

namespace turbid {
namespace {

struct PortableKernels {
  PortableKernels() { enhancer_internal::SetHandWrittenAvx2(false); }
  ~PortableKernels() { enhancer_internal::SetHandWrittenAvx2(true); }
};

cv::Mat Textured(int rows, int cols, uint64_t seed) {
  cv::Mat m(rows, cols, CV_32F);
  cv::RNG(seed).fill(m, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat smooth;
  cv::GaussianBlur(m, smooth, cv::Size(0, 0), 2.0);
  return 0.3 * m + 0.7 * smooth;
}

TEST(HandWrittenAvx2, GuidedFilterEqualsPortableKernels) {
  for (int cols : {64, 83}) {
    const cv::Mat guide = Textured(51, cols, 1), src = Textured(51, cols, 2);
    for (int r = 1; r <= 13; ++r) {
      GuidedFilterOptions o;
      o.radius = r;
      o.eps = 0.03;
      const cv::Mat self = GuidedFilter(o, guide, guide), guided = GuidedFilter(o, guide, src);
      PortableKernels portable;
      EXPECT_EQ(cv::norm(self, GuidedFilter(o, guide, guide), cv::NORM_INF), 0.0)
          << r << " " << cols;
      EXPECT_EQ(cv::norm(guided, GuidedFilter(o, guide, src), cv::NORM_INF), 0.0)
          << r << " " << cols;
    }
  }
}

// Radii beyond the fused kernels (dcp r 60, cap r 30): the AVX2 doubling passes against the
// portable binary doubling, on widths with every remainder of 8 and rows shorter than the window.
TEST(HandWrittenAvx2, LargeRadiusGuidedFilterEqualsPortableKernels) {
  for (int cols : {40, 97, 203}) {
    const cv::Mat guide = Textured(70, cols, 4), src = Textured(70, cols, 5);
    for (int r : {13, 14, 16, 21, 30, 45, 60, 64, 127}) {
      GuidedFilterOptions o;
      o.radius = r;
      o.eps = 1e-3;
      const cv::Mat self = GuidedFilter(o, guide, guide), guided = GuidedFilter(o, guide, src);
      PortableKernels portable;
      EXPECT_EQ(cv::norm(self, GuidedFilter(o, guide, guide), cv::NORM_INF), 0.0)
          << r << " " << cols;
      EXPECT_EQ(cv::norm(guided, GuidedFilter(o, guide, src), cv::NORM_INF), 0.0)
          << r << " " << cols;
    }
  }
}

TEST(HandWrittenAvx2, ClaheAndSimplifiedEqualPortableKernels) {
  for (int cols : {96, 101}) {
    const cv::Mat img = Textured(77, cols, 3);
    for (ClaheDistribution d : {ClaheDistribution::kUniform, ClaheDistribution::kRayleigh}) {
      ClaheOptions o;
      o.distribution = d;
      const cv::Mat fast = Clahe(o, img);
      PortableKernels portable;
      EXPECT_EQ(cv::norm(fast, Clahe(o, img), cv::NORM_INF), 0.0) << cols;
    }
    const cv::Mat fast = SimplifiedEnhance(SimplifiedOptions{}, img);
    PortableKernels portable;
    EXPECT_EQ(cv::norm(fast, SimplifiedEnhance(SimplifiedOptions{}, img), cv::NORM_INF), 0.0);
  }
}

}  // namespace
}  // namespace turbid
