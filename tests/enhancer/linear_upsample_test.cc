// LinearUpsampler (enhancer/linear_upsample.h) against cv::resize INTER_LINEAR: the same float
// map, bit for bit, row by row, on the sizes `full` upsamples (1/light_subsample of odd and even
// images) and on random sizes and factors, with -0, infinities and NaN among the values.
#include "enhancer/blocks/linear_upsample.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace turbid {
namespace {

using enhancer_internal::LinearUpsampler;

// The same float bits, or both NaN: which NaN a sum of two NaNs (or inf * 0) gives depends on
// the order the compiler puts a commutative operation's operands in (x86 returns the first
// operand's), so the sign of a NaN is not part of cv::resize's contract, and nothing in `full`
// can see it (every consumer of t and E_L tests finiteness, and the output clamp maps NaN to 0).
bool SameValue(float a, float b) {
  return std::memcmp(&a, &b, sizeof(float)) == 0 || (std::isnan(a) && std::isnan(b));
}

// Whether every row of the upsampler is cv::resize's, bit for bit (NaN: see SameValue).
::testing::AssertionResult SameAsResize(const cv::Mat& src, cv::Size size) {
  cv::Mat ref;
  cv::resize(src, ref, size, 0, 0, cv::INTER_LINEAR);
  const LinearUpsampler up(src, size);
  if (up.size() != size) return ::testing::AssertionFailure() << "size";
  std::vector<float> buf(size.width);
  for (int y = 0; y < size.height; ++y) {
    const float* row = up.Row(y, buf.data());
    const float* r = ref.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      if (!SameValue(row[x], r[x])) {
        return ::testing::AssertionFailure()
               << src.cols << "x" << src.rows << " -> " << size.width << "x" << size.height
               << " at (" << x << ", " << y << "): " << row[x] << " vs " << r[x];
      }
    }
  }
  const int every = 1 + size.height / 5;
  const cv::Mat grid = up.EveryNthRow(every);
  for (int i = 0; i < grid.rows; ++i) {
    for (int x = 0; x < size.width; ++x) {
      if (!SameValue(grid.at<float>(i, x), ref.at<float>(i * every, x))) {
        return ::testing::AssertionFailure() << "EveryNthRow(" << every << ") row " << i;
      }
    }
  }
  return ::testing::AssertionSuccess();
}

cv::Mat RandomMap(cv::RNG& rng, int rows, int cols, bool smooth) {
  cv::Mat m(rows, cols, CV_32F);
  rng.fill(m, cv::RNG::UNIFORM, -2.0, 3.0);
  if (smooth) {  // t-like: exp of a negative range, in (0, 1]
    cv::Mat e;
    cv::exp(-cv::abs(m), e);
    m = e;
  }
  return m;
}

TEST(LinearUpsample, FullsMapSizesMatchResize) {
  // `full` computes t and E_L at max(1, ceil(n / subsample)) per dimension and upsamples to n.
  cv::RNG rng(11);
  const cv::Size images[] = {{1360, 1024}, {640, 480}, {641, 479}, {97, 61}, {5, 3},
                             {1, 1},       {2, 7},     {33, 1},    {1, 40}};
  for (const cv::Size& image : images) {
    for (int sub : {1, 2, 3, 4, 5, 7, 8, 9, 16, 17, 31, 64}) {
      const int w = std::max(1, (image.width + sub - 1) / sub);
      const int h = std::max(1, (image.height + sub - 1) / sub);
      EXPECT_TRUE(SameAsResize(RandomMap(rng, h, w, sub % 2 == 0), image)) << "subsample " << sub;
    }
  }
}

TEST(LinearUpsample, RandomSizesAndFactorsMatchResize) {
  cv::RNG rng(5);
  for (int trial = 0; trial < 300; ++trial) {
    const int sw = 1 + rng.uniform(0, 120), sh = 1 + rng.uniform(0, 90);
    const double fx = rng.uniform(1.0, 9.0), fy = rng.uniform(1.0, 9.0);
    cv::Size size(static_cast<int>(sw * fx), static_cast<int>(sh * fy));
    if (trial % 3 == 0) size = cv::Size(sw * (1 + trial % 8), sh * (1 + trial % 5));
    EXPECT_TRUE(SameAsResize(RandomMap(rng, sh, sw, trial % 2 == 0), size));
  }
}

TEST(LinearUpsample, SpecialValuesMatchResize) {
  // -0 and non-finite values: an edge value is v (1 - f) + v f, and a zero weight still
  // multiplies its neighbour (inf * 0 is NaN), as in cv::resize.
  cv::RNG rng(2);
  const float specials[] = {-0.0f,
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::quiet_NaN(),
                            1e-42f,
                            3e38f};
  for (int trial = 0; trial < 40; ++trial) {
    cv::Mat m = RandomMap(rng, 3 + trial % 9, 2 + trial % 13, false);
    for (int k = 0; k < 4; ++k) {
      m.at<float>(rng.uniform(0, m.rows), rng.uniform(0, m.cols)) = specials[(trial + k) % 6];
    }
    m.at<float>(0, 0) = -0.0f;
    EXPECT_TRUE(SameAsResize(m, cv::Size(m.cols * 8 - trial % 8, m.rows * 8 - trial % 5)));
    EXPECT_TRUE(SameAsResize(m, cv::Size(m.cols * 4, m.rows * 4)));
  }
}

TEST(LinearUpsample, EqualSizeIsTheMapItself) {
  cv::RNG rng(1);
  const cv::Mat m = RandomMap(rng, 6, 9, false);
  const LinearUpsampler up(m, m.size());
  std::vector<float> buf(m.cols);
  EXPECT_EQ(up.Row(4, buf.data()), m.ptr<float>(4));
  EXPECT_TRUE(SameAsResize(m, m.size()));
}

}  // namespace
}  // namespace turbid
