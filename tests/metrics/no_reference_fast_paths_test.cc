// The optimised visible-edge, UIQM and UCIQE code (issue 18 item 2) against the pre-optimisation
// implementations of commit 6722196 (tests/metrics/reference_visible_edges.cc and
// reference_uiqm_uciqe.cc): visible-edge masks and values bit for bit, on random and structured
// images of several sizes (odd, tiny, gray and colour, float and 8-bit input), both variants,
// several thresholds, images with exact ties between thresholds, and the real images of
// $TURBID_DATA when present; the gray conversion for all 2^24 colours; UCIQE bit for bit, UIQM
// within the stated rounding tolerance.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "metrics/no_reference.h"
#include "tests/metrics/expect_visible_edges.h"
#include "tests/metrics/reference_pre_optimisation.h"

namespace turbid {
namespace {

// Random image with smooth shading, blocky edges of several contrasts and noise, so that many
// windows sit near the visibility decision; `levels` limits the noise amplitude.
cv::Mat Structured(int rows, int cols, int channels, uint32_t seed, int noise) {
  std::mt19937 rng(seed);
  cv::Mat img(rows, cols, CV_8UC(channels));
  const int step = 1 + static_cast<int>(rng() % 9);
  const int base = static_cast<int>(rng() % 200);
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      for (int c = 0; c < channels; ++c) {
        const int v = base / 2 + (i * step) / 3 + ((j / 5 + i / 7) % 2) * (20 + 7 * c) +
                      (noise > 0 ? static_cast<int>(rng() % noise) : 0);
        img.ptr<uint8_t>(i)[j * channels + c] = cv::saturate_cast<uint8_t>(v);
      }
    }
  }
  return img;
}

using testing::ExpectSameResult;

void ExpectSameMasks(const VisibleEdgeOptions& o, const cv::Mat& image, const std::string& what) {
  const cv::Mat gray = reference::ReferenceToGray255(image, "test");
  EXPECT_EQ(cv::norm(ToGray255(image, "test"), gray, cv::NORM_INF), 0.0) << what << ": gray";
  const cv::Mat fast = VisibleEdgeMask(o, gray);
  const cv::Mat slow = reference::ReferenceVisibleEdgeMask(o, gray);
  EXPECT_EQ(cv::countNonZero(fast != slow), 0) << what << ": mask";
}

std::vector<VisibleEdgeOptions> AllOptions() {
  std::vector<VisibleEdgeOptions> out;
  for (auto variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
    for (double threshold : {0.05, 0.01, 0.2, 1.0}) {
      VisibleEdgeOptions o;
      o.variant = variant;
      o.visibility_threshold = threshold;
      out.push_back(o);
    }
  }
  return out;
}

TEST(NoReferenceFastPaths, VisibleEdgesEqualPreOptimisationCode) {
  const std::vector<cv::Size> sizes = {{1, 1},   {2, 3},   {7, 7},    {8, 5},    {13, 9},
                                       {31, 17}, {64, 48}, {97, 101}, {160, 123}};
  uint32_t seed = 1;
  for (const cv::Size size : sizes) {
    for (int channels : {1, 3}) {
      for (int noise : {0, 4, 40, 256}) {
        const cv::Mat original = Structured(size.height, size.width, channels, seed++, noise);
        const cv::Mat restored = Structured(size.height, size.width, channels, seed++, noise);
        for (const VisibleEdgeOptions& o : AllOptions()) {
          const std::string what = std::to_string(size.width) + "x" + std::to_string(size.height) +
                                   "x" + std::to_string(channels) + " noise " +
                                   std::to_string(noise) + " " + VisibleEdgeVariantName(o.variant) +
                                   " threshold " + std::to_string(o.visibility_threshold);
          ExpectSameResult(VisibleEdges(o, original, restored),
                           reference::ReferenceVisibleEdges(o, original, restored), what);
          ExpectSameMasks(o, restored, what);
        }
      }
    }
  }
}

TEST(NoReferenceFastPaths, VisibleEdgesEdgeCases) {
  std::vector<cv::Mat> images;
  images.push_back(cv::Mat(20, 30, CV_8UC1, cv::Scalar(0)));    // all black
  images.push_back(cv::Mat(20, 30, CV_8UC1, cv::Scalar(255)));  // all white
  cv::Mat steps(40, 41, CV_8UC1);
  for (int i = 0; i < steps.rows; ++i)
    for (int j = 0; j < steps.cols; ++j) steps.at<uint8_t>(i, j) = ((i / 3 + j / 4) % 2) ? 255 : 0;
  images.push_back(steps);  // saturated two-level edges
  cv::Mat ramp(33, 47, CV_8UC1);
  for (int i = 0; i < ramp.rows; ++i)
    for (int j = 0; j < ramp.cols; ++j) ramp.at<uint8_t>(i, j) = static_cast<uint8_t>(5 * j + i);
  images.push_back(ramp);  // long threshold ranges in every window
  for (const cv::Mat& a : images) {
    for (const cv::Mat& b : images) {
      if (a.size() != b.size()) continue;
      for (const VisibleEdgeOptions& o : AllOptions()) {
        ExpectSameResult(VisibleEdges(o, a, b), reference::ReferenceVisibleEdges(o, a, b),
                         "edge case " + VisibleEdgeVariantName(o.variant));
        ExpectSameMasks(o, b, "edge case");
      }
    }
  }
}

TEST(NoReferenceFastPaths, VisibleEdgesFloatInputAndNonIntegerGray) {
  const cv::Mat a8 = Structured(50, 61, 3, 99, 30), b8 = Structured(50, 61, 3, 98, 30);
  cv::Mat a, b;
  a8.convertTo(a, CV_32F, 1.0 / 255.0);
  b8.convertTo(b, CV_32F, 1.0 / 255.0);
  for (const VisibleEdgeOptions& o : AllOptions()) {
    ExpectSameResult(VisibleEdges(o, a, b), reference::ReferenceVisibleEdges(o, a, b), "float");
  }
  // VisibleEdgeMask on gray values that are not 8-bit integers keeps the general path.
  cv::Mat gray(37, 45, CV_64F);
  std::mt19937 rng(5);
  for (int i = 0; i < gray.rows; ++i)
    for (int j = 0; j < gray.cols; ++j) gray.at<double>(i, j) = (rng() % 60000) / 200.0 - 10.0;
  for (const VisibleEdgeOptions& o : AllOptions()) {
    EXPECT_EQ(
        cv::countNonZero(VisibleEdgeMask(o, gray) != reference::ReferenceVisibleEdgeMask(o, gray)),
        0);
  }
}

TEST(NoReferenceFastPaths, VisibleEdgesOnRealData) {
  const char* data = std::getenv("TURBID_DATA");
  if (data == nullptr || *data == '\0') GTEST_SKIP() << "TURBID_DATA not set";
  std::vector<std::filesystem::path> files;
  for (const char* folder : {"uieb_waternet", "euvp_funiegan"}) {
    const std::filesystem::path dir = std::filesystem::path(data) / folder;
    if (!std::filesystem::is_directory(dir)) continue;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
      const std::string ext = entry.path().extension().string();
      if (ext == ".png" || ext == ".jpg") files.push_back(entry.path());
    }
  }
  if (files.empty()) GTEST_SKIP() << "no underwater images in $TURBID_DATA";
  std::sort(files.begin(), files.end());
  if (files.size() > 4) files.resize(4);
  for (const auto& file : files) {
    const cv::Mat image = cv::imread(file.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(image.empty()) << file;
    cv::Mat enhanced;
    image.convertTo(enhanced, -1, 1.4, -30);  // a contrast stretch as the "restored" image
    for (auto variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
      VisibleEdgeOptions o;
      o.variant = variant;
      ExpectSameResult(VisibleEdges(o, image, enhanced),
                       reference::ReferenceVisibleEdges(o, image, enhanced), file.string());
    }
  }
}

// Images whose windows have exact ties between thresholds, or a best contrast equal to the
// visibility threshold (binary {2, 6}: C = 1/3 at s = 3 and 4; a visibility threshold of 2/3 puts
// the code's test C > 1/3 on that value), where the fast path must fall back on the ordered sums.
TEST(NoReferenceFastPaths, VisibleEdgesOnImagesWithTies) {
  std::mt19937 rng(21);
  std::vector<cv::Mat> images;
  for (const std::vector<int>& levels :
       std::vector<std::vector<int>>{{2, 6}, {2, 18}, {0, 255}, {100, 101}, {3, 12, 48}}) {
    for (const cv::Size size : std::vector<cv::Size>{{37, 29}, {64, 9}, {13, 71}}) {
      cv::Mat random(size, CV_8UC1), blocks(size, CV_8UC1);
      for (int i = 0; i < size.height; ++i) {
        for (int j = 0; j < size.width; ++j) {
          random.at<uint8_t>(i, j) = static_cast<uint8_t>(levels[rng() % levels.size()]);
          blocks.at<uint8_t>(i, j) = static_cast<uint8_t>(levels[(i / 3 + j / 2) % levels.size()]);
        }
      }
      images.push_back(random);
      images.push_back(blocks);
    }
  }
  for (size_t a = 0; a + 1 < images.size(); a += 2) {
    for (auto variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
      for (double threshold : {0.05, 2.0 / 3.0, 0.01, 1.0}) {
        VisibleEdgeOptions o;
        o.variant = variant;
        o.visibility_threshold = threshold;
        const std::string what = "ties " + std::to_string(a) + " " +
                                 VisibleEdgeVariantName(variant) + " " + std::to_string(threshold);
        ExpectSameResult(VisibleEdges(o, images[a], images[a + 1]),
                         reference::ReferenceVisibleEdges(o, images[a], images[a + 1]), what);
        ExpectSameMasks(o, images[a + 1], what);
      }
    }
  }
}

// OctaveRgbToGray in integer arithmetic against the double formula, for every 8-bit colour.
TEST(NoReferenceFastPaths, OctaveRgbToGrayEqualsTheDoubleFormulaForEveryColour) {
  cv::Mat all(4096, 4096, CV_8UC3);
  for (int i = 0; i < all.rows; ++i) {
    uint8_t* row = all.ptr<uint8_t>(i);
    for (int j = 0; j < all.cols; ++j) {
      const int colour = i * all.cols + j;
      row[3 * j] = static_cast<uint8_t>(colour & 255);
      row[3 * j + 1] = static_cast<uint8_t>((colour >> 8) & 255);
      row[3 * j + 2] = static_cast<uint8_t>(colour >> 16);
    }
  }
  EXPECT_EQ(cv::countNonZero(OctaveRgbToGray(all) != reference::ReferenceOctaveRgbToGray(all)), 0);
  // Odd widths (the row kernel's tail) and a view into a larger image.
  const cv::Mat part = all(cv::Rect(5, 7, 101, 33));
  EXPECT_EQ(cv::countNonZero(OctaveRgbToGray(part) != reference::ReferenceOctaveRgbToGray(part)),
            0);
}

// UIQM: UICM and UIConM are computed from the same integers with the same operations (equal);
// UISM takes each tile's log(max/min) as ½·log of the exact integer ratio m²x² instead of the
// ratio of two rounded edge values, which moves it by rounding only: 1e-13 relative.
constexpr double kUismTolerance = 1e-13;
// UCIQE: the same doubles summed in the same order: equal.

std::vector<cv::Mat> UiqmInputs() {
  std::vector<cv::Mat> out;
  uint32_t seed = 11;
  for (const cv::Size size :
       std::vector<cv::Size>{{10, 10}, {17, 23}, {64, 48}, {123, 37}, {203, 151}}) {
    for (int channels : {1, 3}) {
      for (int noise : {0, 10, 256}) {
        out.push_back(Structured(size.height, size.width, channels, seed++, noise));
      }
    }
  }
  out.push_back(cv::Mat(30, 40, CV_8UC3, cv::Scalar(0, 0, 0)));       // flat black
  out.push_back(cv::Mat(30, 40, CV_8UC3, cv::Scalar(90, 120, 200)));  // flat colour
  out.push_back(cv::Mat(30, 40, CV_8UC1, cv::Scalar(255)));           // flat white gray
  cv::Mat f;
  out[7].convertTo(f, CV_32F, 1.0 / 255.0);
  out.push_back(f);  // float input
  return out;
}

void ExpectClose(double a, double b, double tolerance, const std::string& what) {
  if (b == 0.0) {
    EXPECT_EQ(a, 0.0) << what;
    return;
  }
  EXPECT_LE(std::abs(a - b) / std::abs(b), tolerance) << what << ": " << a << " vs " << b;
}

TEST(NoReferenceFastPaths, UiqmEqualsPreOptimisationCode) {
  int index = 0;
  for (const cv::Mat& image : UiqmInputs()) {
    for (auto variant : {UiqmVariant::kFunieGanCompat, UiqmVariant::kCorrected}) {
      for (int block : {10, 4}) {
        UiqmOptions o;
        o.variant = variant;
        o.block_size = block;
        if (image.rows < block || image.cols < block) continue;
        const std::string what = "image " + std::to_string(index) + " " + UiqmVariantName(variant) +
                                 " block " + std::to_string(block);
        const UiqmResult a = Uiqm(o, image);
        const UiqmResult b = reference::ReferenceUiqm(o, image);
        EXPECT_EQ(a.uicm, b.uicm) << what;
        EXPECT_EQ(a.uiconm, b.uiconm) << what;
        ExpectClose(a.uism, b.uism, kUismTolerance, what + " uism");
        ExpectClose(a.uiqm, b.uiqm, kUismTolerance, what + " uiqm");
      }
    }
    ++index;
  }
}

TEST(NoReferenceFastPaths, UciqeEqualsPreOptimisationCode) {
  int index = 0;
  for (const cv::Mat& image : UiqmInputs()) {
    const UciqeResult a = Uciqe({}, image);
    const UciqeResult b = reference::ReferenceUciqe({}, image);
    const std::string what = "image " + std::to_string(index++);
    EXPECT_EQ(a.uciqe, b.uciqe) << what;
    EXPECT_EQ(a.chroma_spread, b.chroma_spread) << what;
    EXPECT_EQ(a.luminance_contrast, b.luminance_contrast) << what;
    EXPECT_EQ(a.mean_saturation, b.mean_saturation) << what;
  }
  // More than one NumPy chunk (8192 values) and a partial last chunk.
  const cv::Mat big = Structured(211, 307, 3, 77, 60);
  EXPECT_EQ(Uciqe({}, big).uciqe, reference::ReferenceUciqe({}, big).uciqe);
}

}  // namespace
}  // namespace turbid
