// metrics/opencv_lab.h against cv::cvtColor(COLOR_BGR2Lab) on every one of the 2^24 8-bit colours,
// through both kernels (vectorised where the CPU has it, and the portable one, chosen with
// simd::SetSimdLevelCap), and through both of
// OpenCV's loops: rows of 4096 pixels go through its vectorised loop, rows of 31 pixels (fewer than
// one vector) through its scalar one, so a difference between those would show here too.
#include "metrics/opencv_lab.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "metrics/simd_dispatch.h"

namespace turbid {
namespace {

// Every colour once: pixel k is (B, G, R) = (k & 255, (k >> 8) & 255, k >> 16); `cols` pixels a
// row, the last row padded with black.
cv::Mat AllColours(int cols) {
  constexpr int kColours = 1 << 24;
  const int rows = (kColours + cols - 1) / cols;
  cv::Mat image(rows, cols, CV_8UC3, cv::Scalar::all(0));
  uint8_t* p = image.ptr<uint8_t>(0);
  for (int k = 0; k < kColours; ++k, p += 3) {
    p[0] = static_cast<uint8_t>(k);
    p[1] = static_cast<uint8_t>(k >> 8);
    p[2] = static_cast<uint8_t>(k >> 16);
  }
  return image;
}

// Index of the first differing pixel, or -1.
long FirstDifference(const cv::Mat& expected, const std::vector<uint8_t>& ours) {
  const uint8_t* e = expected.ptr<uint8_t>(0);
  for (size_t i = 0; i < ours.size(); ++i)
    if (e[i] != ours[i]) return static_cast<long>(i / 3);
  return -1;
}

void ExpectAllColoursEqual(int cols) {
  const cv::Mat bgr = AllColours(cols);
  ASSERT_TRUE(bgr.isContinuous());
  cv::Mat expected;
  cv::cvtColor(bgr, expected, cv::COLOR_BGR2Lab);
  ASSERT_TRUE(expected.isContinuous());
  std::vector<uint8_t> fast(3 * bgr.total()), portable(3 * bgr.total());
  BgrToLab8(bgr.ptr<uint8_t>(0), 3, bgr.total(), fast.data());
  simd::SetSimdLevelCap(simd::SimdLevel::kBaseline);
  BgrToLab8(bgr.ptr<uint8_t>(0), 3, bgr.total(), portable.data());
  simd::SetSimdLevelCap(simd::SimdLevel::kAvx512);
  long at = FirstDifference(expected, fast);
  EXPECT_EQ(at, -1) << "vectorised kernel, rows of " << cols << ": first difference at BGR "
                    << (at & 255) << ", " << ((at >> 8) & 255) << ", " << (at >> 16);
  at = FirstDifference(expected, portable);
  EXPECT_EQ(at, -1) << "portable kernel, rows of " << cols << ": first difference at BGR "
                    << (at & 255) << ", " << ((at >> 8) & 255) << ", " << (at >> 16);
}

TEST(OpenCvLab, EveryColourEqualsCvtColorVectorisedLoop) { ExpectAllColoursEqual(4096); }

TEST(OpenCvLab, EveryColourEqualsCvtColorScalarLoop) { ExpectAllColoursEqual(31); }

TEST(OpenCvLab, GrayEqualsCvtColorOfReplicatedGray) {
  cv::Mat gray(1, 256, CV_8UC1);
  for (int v = 0; v < 256; ++v) gray.at<uint8_t>(0, v) = static_cast<uint8_t>(v);
  cv::Mat bgr, expected;
  cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(bgr, expected, cv::COLOR_BGR2Lab);
  std::vector<uint8_t> ours(3 * 256);
  BgrToLab8(gray.ptr<uint8_t>(0), 1, 256, ours.data());
  EXPECT_EQ(FirstDifference(expected, ours), -1);
}

// Every length up to a few vectors: the vectorised kernel's ragged end, and no byte written past
// 3·n (its 16-byte stores).
TEST(OpenCvLab, ShortRowsAndNoWritePastTheEnd) {
  const cv::Mat colours = AllColours(4096);
  for (int n = 0; n <= 40; ++n) {
    const cv::Mat row = colours.reshape(3, 1).colRange(1000 * n, 1000 * n + n + 1).colRange(0, n);
    cv::Mat expected;
    if (n > 0) cv::cvtColor(row.clone(), expected, cv::COLOR_BGR2Lab);
    std::vector<uint8_t> ours(3 * n + 32, 0xA5);
    BgrToLab8(n > 0 ? row.ptr<uint8_t>(0) : colours.ptr<uint8_t>(0), 3, n, ours.data());
    for (int i = 0; i < 3 * n; ++i) ASSERT_EQ(ours[i], expected.ptr<uint8_t>(0)[i]) << "n " << n;
    for (int i = 3 * n; i < 3 * n + 32; ++i) ASSERT_EQ(ours[i], 0xA5) << "n " << n << " byte " << i;
  }
}

}  // namespace
}  // namespace turbid
