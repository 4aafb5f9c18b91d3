// The colour (interleaved, self-guided) guided filter with O(1) running box sums
// (enhancer/blocks/guided_segments.h, issue 29 item 6) against a double-precision transcription
// of He 2013 Alg. 1 with the clipped window, written here. Tolerance: 1e-5 of max(1, |q|) (the
// issue's 1e-5 relative; the data lie in [0, 1]). Every kernel set (AVX-512 with 16 lanes, AVX2 +
// FMA, portable; each where the CPU has it), chosen through the CPU level's cap.
#include "enhancer/blocks/guided_segments.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <vector>

#include "core/cpu.h"
#include "enhancer/blocks/guided_filter.h"

namespace turbid {
namespace {

constexpr double kTolerance = 1e-5;

// The caps that choose each kernel set (lower ones where the CPU lacks a level: then the same set
// runs twice).
constexpr CpuLevel kLevels[] = {CpuLevel::kAvx512, CpuLevel::kAvx2Fma, CpuLevel::kScalar};

// The kernel sets this build and CPU have.
std::vector<guided_segments::Kernels> KernelSets() {
  std::vector<guided_segments::Kernels> sets = {guided_segments::PortableKernels()};
  if (CpuHas(CpuLevel::kAvx2Fma) && guided_segments::Avx2FmaKernels().stage_a != nullptr) {
    sets.push_back(guided_segments::Avx2FmaKernels());
  }
  if (CpuHas(CpuLevel::kAvx512) && guided_segments::Avx512Kernels().stage_a != nullptr) {
    sets.push_back(guided_segments::Avx512Kernels());
  }
  return sets;
}

// Box means of a double plane over the window clipped to the image (sum / pixels inside).
cv::Mat ClippedMean(const cv::Mat& p, int r) {
  cv::Mat sum;
  cv::integral(p, sum, CV_64F);
  cv::Mat out(p.size(), CV_64F);
  for (int y = 0; y < p.rows; ++y) {
    const int y0 = std::max(y - r, 0), y1 = std::min(y + r, p.rows - 1) + 1;
    for (int x = 0; x < p.cols; ++x) {
      const int x0 = std::max(x - r, 0), x1 = std::min(x + r, p.cols - 1) + 1;
      const double s = sum.at<double>(y1, x1) - sum.at<double>(y0, x1) - sum.at<double>(y1, x0) +
                       sum.at<double>(y0, x0);
      out.at<double>(y, x) = s / ((y1 - y0) * (x1 - x0));
    }
  }
  return out;
}

// He 2013 Alg. 1, each channel its own guide, in double.
cv::Mat DoubleReference(const cv::Mat& image, int r, double eps) {
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (cv::Mat& p : planes) {
    cv::Mat i;
    p.convertTo(i, CV_64F);
    const cv::Mat m = ClippedMean(i, r), mm = ClippedMean(i.mul(i), r);
    const cv::Mat var = mm - m.mul(m);
    cv::Mat a = var / (var + eps);
    cv::Mat b = m - a.mul(m);
    p = ClippedMean(a, r).mul(i) + ClippedMean(b, r);
  }
  cv::Mat out;
  cv::merge(planes, out);
  return out;
}

// Largest |got - want| / max(1, |want|).
double WorstError(const cv::Mat& got, const cv::Mat& want) {
  cv::Mat g;
  got.convertTo(g, CV_64F);
  double worst = 0;
  const int n = static_cast<int>(g.total()) * g.channels();
  const double* pg = g.ptr<double>();
  const double* pw = want.ptr<double>();
  for (int i = 0; i < n; ++i) {
    const double e = std::abs(pg[i] - pw[i]) / std::max(1.0, std::abs(pw[i]));
    worst = std::isnan(e) ? 1e30 : std::max(worst, e);
  }
  return worst;
}

cv::Mat Noise(int rows, int cols, int seed, double blur = 1.3) {
  cv::Mat img(rows, cols, CV_32FC3);
  cv::RNG(seed).fill(img, cv::RNG::UNIFORM, 0.02, 0.95);
  if (rows > 2 && cols > 2 && blur > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), blur);
  return img;
}

cv::Mat Filter(const cv::Mat& img, int r, double eps) {
  GuidedFilterOptions o;
  o.radius = r;
  o.eps = eps;
  return GuidedFilterSelf(o, img);
}

TEST(GuidedSegments, EqualsDoublePrecisionReference) {
  // Widths around the segment multiples (8 segments of multiples of 8 pixels), tiny and odd
  // sizes, heights past the 64-row re-anchoring, radii up to beyond the image.
  const cv::Size sizes[] = {{1, 1},  {2, 3},   {7, 5},   {5, 33},    {31, 2},   {63, 70},
                            {64, 9}, {65, 66}, {83, 61}, {130, 140}, {257, 40}, {640, 20}};
  for (CpuLevel level : kLevels) {
    SetCpuLevelCap(level);
    const int lanes = guided_segments::ChosenKernels().lanes;
    for (const cv::Size& size : sizes) {
      const cv::Mat img = Noise(size.height, size.width, size.area());
      for (int r : {1, 2, 3, 4, 8, 12, 13, 30}) {
        for (double eps : {0.003, 0.01, 0.16}) {
          const double err = WorstError(Filter(img, r, eps), DoubleReference(img, r, eps));
          EXPECT_LE(err, kTolerance) << size << " r " << r << " eps " << eps << " level "
                                     << static_cast<int>(level) << " lanes " << lanes;
        }
      }
    }
  }
  SetCpuLevelCap(CpuLevel::kAvx512);
}

TEST(GuidedSegments, EqualsReferenceOnSharpEdgesAndFlatAreas) {
  // Flat areas (variance 0: the cancellation of mean(I^2) - mean(I)^2), hard edges, values at
  // 0 and 1, a long image (running column sums over 300 rows) and a wide one (running window
  // sums over 1360 pixels).
  cv::Mat img(300, 1360, CV_32FC3, cv::Scalar(0.5, 0.25, 0.9));
  img(cv::Rect(100, 50, 400, 120)).setTo(cv::Scalar(1.0, 0.0, 0.3));
  img(cv::Rect(900, 0, 3, 300)).setTo(cv::Scalar(0.0, 1.0, 0.7));
  Noise(100, 700, 5, 0).copyTo(img(cv::Rect(600, 190, 700, 100)));
  for (CpuLevel level : kLevels) {
    SetCpuLevelCap(level);
    for (int r : {2, 4, 8}) {
      const double eps = r == 8 ? 0.16 : 0.01;
      const double err = WorstError(Filter(img, r, eps), DoubleReference(img, r, eps));
      EXPECT_LE(err, kTolerance) << "r " << r << " level " << static_cast<int>(level);
    }
  }
  SetCpuLevelCap(CpuLevel::kAvx512);
}

TEST(GuidedSegments, RowsEqualWholeImageAndThreadsDoNotMatter) {
  const cv::Mat img = Noise(150, 211, 9);
  GuidedFilterOptions fine, coarse;
  fine.radius = 2;
  coarse.radius = 8;
  coarse.eps = 0.16;
  const cv::Mat f = GuidedFilterSelf(fine, img), g = GuidedFilterSelf(coarse, img);
  cv::Mat rf(img.size(), CV_32FC3), rg(img.size(), CV_32FC3);
  GuidedFilterSelfRows({fine, coarse}, img, [&](int y, const std::vector<const float*>& q) {
    std::memcpy(rf.ptr<float>(y), q[0], sizeof(float) * 3 * img.cols);
    std::memcpy(rg.ptr<float>(y), q[1], sizeof(float) * 3 * img.cols);
  });
  EXPECT_EQ(cv::norm(f, rf, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(g, rg, cv::NORM_INF), 0.0);
  // Four threads at once give the single call's bits.
  std::vector<cv::Mat> out(4);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i)
    threads.emplace_back([&, i] { out[i] = GuidedFilterSelf(coarse, img); });
  for (std::thread& t : threads) t.join();
  for (const cv::Mat& m : out) EXPECT_EQ(cv::norm(m, g, cv::NORM_INF), 0.0);
}

// The direct column sums (the every-64-rows re-summing) of every kernel set against a double sum
// (bound: 1e-6 relative; 17 rows of values in [0, 1)), with squares and with a second plane.
TEST(GuidedSegments, DirectColumnSumsEqualDoubleSums) {
  for (const guided_segments::Kernels& k : KernelSets()) {
    ASSERT_NE(k.direct, nullptr);
    const guided_segments::Geometry g = guided_segments::MakeGeometry(200, 8, k.lanes);
    const size_t n = static_cast<size_t>(g.L) * 3 * g.K;
    ASSERT_EQ(n % (4 * g.K), 0u);
    for (int count : {1, 5, 17}) {
      std::vector<guided_segments::Buffer> planes(2 * count);
      std::vector<const float*> rows0(count), rows1(count);
      cv::RNG rng(count);
      for (int y = 0; y < 2 * count; ++y) {
        planes[y].Assign(n);
        for (size_t i = 0; i < n; ++i) planes[y].data[i] = rng.uniform(0.0f, 1.0f);
        (y < count ? rows0[y] : rows1[y - count]) = planes[y].data;
      }
      for (const bool square : {true, false}) {
        guided_segments::Buffer c0, c1;
        c0.Assign(n);
        c1.Assign(n);
        std::fill(c0.data, c0.data + n, -7.0f);  // overwritten, not added to
        std::fill(c1.data, c1.data + n, -7.0f);
        k.direct(n, rows0.data(), square ? nullptr : rows1.data(), count, c0.data, c1.data);
        for (size_t i = 0; i < n; ++i) {
          double s0 = 0, s1 = 0;
          for (int y = 0; y < count; ++y) {
            s0 += rows0[y][i];
            s1 += square ? double{rows0[y][i]} * rows0[y][i] : double{rows1[y][i]};
          }
          ASSERT_NEAR(c0.data[i], s0, 1e-6 * std::max(1.0, s0))
              << k.lanes << " " << count << " " << i;
          ASSERT_NEAR(c1.data[i], s1, 1e-6 * std::max(1.0, s1))
              << k.lanes << " " << count << " " << i;
        }
      }
    }
  }
}

TEST(GuidedSegments, TransposesRoundTrip) {
  for (const guided_segments::Kernels& k : KernelSets()) {
    for (int cols : {1, 63, 64, 65, 127, 128, 129, 200}) {
      const guided_segments::Geometry g = guided_segments::MakeGeometry(cols, 3, k.lanes);
      ASSERT_EQ(g.L % 8, 0);
      ASSERT_GE(g.K * g.L, cols);
      ASSERT_LT(g.K * (g.L - 8), cols);
      guided_segments::Buffer in, seg, out;
      in.Assign(static_cast<size_t>(g.K * g.L) * 3);
      seg.Assign(static_cast<size_t>(g.L) * 3 * g.K);
      out.Assign(static_cast<size_t>(g.L) * 3 * g.K);
      for (int p = 0; p < cols * 3; ++p) in.data[p] = static_cast<float>(p + 1);
      const float* src[16];
      for (int i = 0; i < g.K; ++i) src[i] = in.data + static_cast<size_t>(i) * g.L * 3;
      k.transpose_in(g, src, seg.data);
      // Segment k, column s, channel c holds pixel k L + s (zero past the image).
      for (int seg_k = 0; seg_k < g.K; ++seg_k) {
        for (int s = 0; s < g.L; ++s) {
          const int p = seg_k * g.L + s;
          for (int c = 0; c < 3; ++c) {
            const float want = p < cols ? static_cast<float>(p * 3 + c + 1) : 0.0f;
            ASSERT_EQ(seg.data[(s * 3 + c) * g.K + seg_k], want)
                << cols << " lanes " << g.K << " " << seg_k << " " << s;
          }
        }
      }
      k.transpose_out(g, seg.data, out.data, cols * 3);
      for (int p = 0; p < cols * 3; ++p) ASSERT_EQ(out.data[p], static_cast<float>(p + 1));
      for (int p = cols * 3; p < g.K * g.L * 3; ++p) {
        ASSERT_EQ(out.data[p], 0.0f) << "past the limit";
      }
    }
  }
}

}  // namespace
}  // namespace turbid
