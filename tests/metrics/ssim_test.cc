// SSIM against scikit-image reference values and against a direct double-precision evaluation of
// Wang 2004 Eq. 13 (independent of our fused separable kernel).
#include "metrics/ssim.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "metrics/simd_dispatch.h"
#include "core/error.h"
#include "tests/metrics/reference_files.h"

namespace turbid {
namespace {

// Direct evaluation: 2-D Gaussian window, reflect borders, double everywhere.
cv::Mat NaiveSsimMap(const cv::Mat& a, const cv::Mat& b, double sigma, int radius, double range) {
  std::vector<double> w(2 * radius + 1);
  double s = 0;
  for (int k = -radius; k <= radius; ++k)
    s += (w[k + radius] = std::exp(-k * k / (2 * sigma * sigma)));
  for (double& v : w) v /= s;
  auto reflect = [](int i, int n) { return i < 0 ? -i - 1 : (i >= n ? 2 * n - i - 1 : i); };
  const double c1 = (0.01 * range) * (0.01 * range), c2 = (0.03 * range) * (0.03 * range);
  cv::Mat out(a.size(), CV_64F);
  for (int i = 0; i < a.rows; ++i)
    for (int j = 0; j < a.cols; ++j) {
      double mx = 0, my = 0, mxx = 0, myy = 0, mxy = 0;
      for (int di = -radius; di <= radius; ++di)
        for (int dj = -radius; dj <= radius; ++dj) {
          const double wt = w[di + radius] * w[dj + radius];
          const int r = reflect(i + di, a.rows), c = reflect(j + dj, a.cols);
          const double x = a.at<double>(r, c), y = b.at<double>(r, c);
          mx += wt * x, my += wt * y, mxx += wt * x * x, myy += wt * y * y, mxy += wt * x * y;
        }
      const double vx = mxx - mx * mx, vy = myy - my * my, vxy = mxy - mx * my;
      out.at<double>(i, j) =
          (2 * mx * my + c1) * (2 * vxy + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2));
    }
  return out;
}

double CroppedMean(const cv::Mat& map, int radius) {
  return cv::mean(map(cv::Rect(radius, radius, map.cols - 2 * radius, map.rows - 2 * radius)))[0];
}

cv::Mat RandomImage(int rows, int cols, int type, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat m(rows, cols, type);
  if (CV_MAT_DEPTH(type) == CV_8U)
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  else
    rng.fill(m, cv::RNG::UNIFORM, 0.0, 1.0);
  return m;
}

TEST(SsimOptions, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(SsimOptions{}.Check(&why)) << why;
  EXPECT_EQ(SsimRadius(SsimOptions{}), 5);  // 11 taps, as scikit-image with truncate 3.5
  SsimOptions bad;
  bad.sigma = -1;
  EXPECT_FALSE(bad.Check(&why));
  bad = {};
  bad.k2 = 0;
  EXPECT_FALSE(bad.Check(&why));
}

TEST(Ssim, MatchesScikitImageReferenceValues) {
  TURBID_REQUIRE_METRICS_REFERENCE(dir);
  std::ifstream in(dir + "/expected.json");
  const nlohmann::json expected = nlohmann::json::parse(in);
  ASSERT_GE(expected.at("cases").size(), 10u);
  for (const auto& c : expected.at("cases")) {
    const std::string name = c.at("image").get<std::string>();
    const cv::Mat ref =
        cv::imread(dir + "/" + c.at("reference").get<std::string>(), cv::IMREAD_UNCHANGED);
    const cv::Mat img = cv::imread(dir + "/" + name, cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(ref.empty() || img.empty()) << name;
    ASSERT_EQ(img.channels(), c.at("channels").get<int>()) << name;
    // 8-bit inputs, data range 255 (from the depth).
    EXPECT_NEAR(Ssim({}, ref, img).mean, c.at("ssim_uint8_range255").get<double>(), 1e-6) << name;
    // Inputs / 255 as float64 and as float32, data range 1.
    cv::Mat ref64, img64, ref32, img32;
    ref.convertTo(ref64, CV_64F, 1.0 / 255);
    img.convertTo(img64, CV_64F, 1.0 / 255);
    ref.convertTo(ref32, CV_32F, 1.0 / 255);
    img.convertTo(img32, CV_32F, 1.0 / 255);
    const double want_float = c.at("ssim_float_range1").get<double>();
    EXPECT_NEAR(Ssim({}, ref64, img64).mean, want_float, 1e-6) << name;
    EXPECT_NEAR(Ssim({}, ref32, img32).mean, want_float, 1e-6) << name;
  }
}

TEST(Ssim, MatchesDirectEvaluationGrayAndColour) {
  for (int channels : {1, 3}) {
    const cv::Mat a = RandomImage(29, 41, CV_64FC(channels), 1);
    cv::Mat b = a * 0.7 + RandomImage(29, 41, CV_64FC(channels), 2) * 0.3;
    SsimOptions options;
    options.compute_map = true;
    const SsimResult got = Ssim(options, a, b);
    std::vector<cv::Mat> pa, pb, pm;
    cv::split(a, pa);
    cv::split(b, pb);
    cv::split(got.map, pm);
    double mean = 0;
    for (int c = 0; c < channels; ++c) {
      const cv::Mat want = NaiveSsimMap(pa[c], pb[c], 1.5, 5, 1.0);
      cv::Mat got_map;
      pm[c].convertTo(got_map, CV_64F);
      EXPECT_LT(cv::norm(want, got_map, cv::NORM_INF), 2e-6) << "channel " << c;
      EXPECT_NEAR(got.per_channel[c], CroppedMean(want, 5), 1e-6);
      mean += CroppedMean(want, 5) / channels;
    }
    EXPECT_NEAR(got.mean, mean, 1e-6);
  }
}

// The 8-bit fused kernel (row groups of four, fused horizontal pass + float formula): map within
// 2e-6 of the direct evaluation and map-or-not means equal, for every channel stride it
// deinterleaves (1, 2, 3, 4) and sizes whose rows leave 0-3 rows after the last group of four and
// whose columns leave ragged 8-column blocks (including a crop narrower than 8 columns).
TEST(Ssim, EightBitKernelMatchesDirectEvaluationAtEveryStrideAndTail) {
  struct Case {
    int rows, cols, channels;
  };
  for (const Case& c : {Case{29, 41, 1}, Case{30, 13, 1}, Case{31, 37, 3}, Case{32, 19, 4},
                        Case{11, 11, 2}, Case{45, 70, 3}}) {
    const cv::Mat a = RandomImage(c.rows, c.cols, CV_8UC(c.channels), 21);
    cv::Mat noise = RandomImage(c.rows, c.cols, CV_8UC(c.channels), 22);
    cv::Mat b;
    cv::addWeighted(a, 0.7, noise, 0.3, 0.0, b);
    SsimOptions options;
    options.compute_map = true;
    const SsimResult got = Ssim(options, a, b);
    EXPECT_DOUBLE_EQ(got.mean, Ssim({}, a, b).mean) << c.rows << "x" << c.cols;
    std::vector<cv::Mat> pa, pb, pm;
    cv::split(a, pa);
    cv::split(b, pb);
    cv::split(got.map, pm);
    for (int ch = 0; ch < c.channels; ++ch) {
      cv::Mat a64, b64, got_map;
      pa[ch].convertTo(a64, CV_64F);
      pb[ch].convertTo(b64, CV_64F);
      pm[ch].convertTo(got_map, CV_64F);
      const cv::Mat want = NaiveSsimMap(a64, b64, 1.5, 5, 255.0);
      EXPECT_LT(cv::norm(want, got_map, cv::NORM_INF), 2e-6)
          << c.rows << "x" << c.cols << " channel " << ch;
      EXPECT_NEAR(got.per_channel[ch], CroppedMean(want, 5), 1e-6);
    }
  }
}

// SSIM with the kernels capped at one instruction set (simd::SetSimdLevelCap).
SsimResult SsimAt(simd::SimdLevel level, const SsimOptions& options, const cv::Mat& a,
                  const cv::Mat& b) {
  simd::SetSimdLevelCap(level);
  SsimResult r = Ssim(options, a, b);
  simd::SetSimdLevelCap(simd::SimdLevel::kAvx512);
  return r;
}

// The AVX-512 copies of the SSIM kernels (16 float / 8 double lanes) take each lane through the
// AVX2 copies' arithmetic in the same order: means and maps equal bit for bit, on sizes whose
// columns leave every kind of ragged block (narrower than 8, 8-15, 16-31 columns, several double
// strips) and whose rows leave 0-3 rows after the last group of four. The portable copies (no FMA,
// double formula) agree within float rounding. On a CPU without AVX-512 the first comparison is
// AVX2 against itself.
TEST(Ssim, KernelCopiesAgree) {
  struct Case {
    int rows, cols, type;
  };
  for (const Case& c : {Case{29, 13, CV_8UC1}, Case{30, 24, CV_8UC3}, Case{45, 41, CV_8UC1},
                        Case{70, 307, CV_8UC3}, Case{31, 19, CV_32FC1}, Case{66, 701, CV_32FC1},
                        Case{35, 350, CV_16UC3}, Case{22, 47, CV_64FC1}}) {
    const cv::Mat a = RandomImage(c.rows, c.cols, c.type, 31);
    cv::Mat b;
    cv::addWeighted(a, 0.8, RandomImage(c.rows, c.cols, c.type, 32), 0.2, 0.0, b);
    const bool eight_bit = CV_MAT_DEPTH(c.type) == CV_8U;
    const std::string what =
        std::to_string(c.rows) + "x" + std::to_string(c.cols) + " type " + std::to_string(c.type);
    for (bool map : {false, true}) {
      SsimOptions options;
      options.compute_map = map;
      const SsimResult wide = SsimAt(simd::SimdLevel::kAvx512, options, a, b);
      const SsimResult avx2 = SsimAt(simd::SimdLevel::kAvx2, options, a, b);
      const SsimResult plain = SsimAt(simd::SimdLevel::kBaseline, options, a, b);
      EXPECT_EQ(wide.mean, avx2.mean) << what;
      EXPECT_NEAR(plain.mean, avx2.mean, eight_bit ? 1e-7 : 1e-12) << what;
      if (map) {
        EXPECT_EQ(cv::norm(wide.map, avx2.map, cv::NORM_INF), 0.0) << what;
        EXPECT_LT(cv::norm(plain.map, avx2.map, cv::NORM_INF), eight_bit ? 2e-6 : 1e-6) << what;
      }
    }
  }
}

TEST(Ssim, OtherSigmaAndRangeMatchDirectEvaluation) {
  const cv::Mat a = RandomImage(33, 30, CV_8UC1, 3);
  const cv::Mat b = RandomImage(33, 30, CV_8UC1, 4);
  SsimOptions options;
  options.sigma = 2.0;  // radius int(7.5) = 7
  options.data_range = 200.0;
  cv::Mat a64, b64;
  a.convertTo(a64, CV_64F);
  b.convertTo(b64, CV_64F);
  const cv::Mat want = NaiveSsimMap(a64, b64, 2.0, 7, 200.0);
  EXPECT_NEAR(Ssim(options, a, b).mean, CroppedMean(want, 7), 1e-6);
}

TEST(Ssim, MapCropMeanEqualsMean) {
  const cv::Mat a = RandomImage(64, 80, CV_32FC3, 5);
  const cv::Mat b = RandomImage(64, 80, CV_32FC3, 6);
  SsimOptions options;
  options.compute_map = true;
  const SsimResult with_map = Ssim(options, a, b);
  ASSERT_EQ(with_map.map.type(), CV_32FC3);
  ASSERT_EQ(with_map.map.size(), a.size());
  EXPECT_DOUBLE_EQ(with_map.mean, Ssim({}, a, b).mean);  // map or not: same numbers
}

// SSIM of a and b with 1 and with 4 OpenCV threads: bitwise equal (deterministic reduction).
void ExpectSameWithOneAndFourThreads(const cv::Mat& a, const cv::Mat& b) {
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const double one = Ssim({}, a, b).mean;
  cv::setNumThreads(4);
  const double four = Ssim({}, a, b).mean;
  cv::setNumThreads(threads);
  EXPECT_EQ(one, four);
}

TEST(Ssim, IndependentOfThreadCount) {
  ExpectSameWithOneAndFourThreads(RandomImage(300, 257, CV_8UC3, 7),
                                  RandomImage(300, 257, CV_8UC3, 8));
}

// Float and 16-bit inputs go through the fused float64 kernel (tiles of row bands x column
// strips); the plain OpenCV double path (exact_double) is its cross-check. The image spans several
// strips and bands so that tile seams and reflected borders are both exercised.
TEST(Ssim, FusedDoubleKernelMatchesPlainDoublePath) {
  for (int depth : {CV_32F, CV_16U})
    for (int channels : {1, 3}) {
      cv::Mat a = RandomImage(203, 713, CV_32FC(channels), 11);
      cv::Mat b = a * 0.6 + RandomImage(203, 713, CV_32FC(channels), 12) * 0.4;
      if (depth == CV_16U) {
        a.convertTo(a, CV_16U, 65535.0);
        b.convertTo(b, CV_16U, 65535.0);
      }
      SsimOptions fused, plain;
      fused.compute_map = plain.compute_map = true;
      plain.exact_double = true;
      const SsimResult got = Ssim(fused, a, b), want = Ssim(plain, a, b);
      const std::string what =
          "depth " + std::to_string(depth) + " channels " + std::to_string(channels);
      EXPECT_NEAR(got.mean, want.mean, 1e-12) << what;
      for (int c = 0; c < channels; ++c)
        EXPECT_NEAR(got.per_channel[c], want.per_channel[c], 1e-12) << what;
      // Maps are stored as float32 by both paths.
      EXPECT_LT(cv::norm(got.map, want.map, cv::NORM_INF), 1e-6) << what;
      EXPECT_NEAR(Ssim({}, a, b).mean, got.mean, 1e-15) << what << ": map or not";
    }
}

TEST(Ssim, FusedDoubleKernelIndependentOfThreadCount) {
  ExpectSameWithOneAndFourThreads(RandomImage(300, 700, CV_32FC3, 13),
                                  RandomImage(300, 700, CV_32FC3, 14));
}

TEST(Ssim, IdenticalAndConstantImages) {
  const cv::Mat a = RandomImage(40, 40, CV_8UC1, 9);
  EXPECT_NEAR(Ssim({}, a, a).mean, 1.0, 1e-12);
  // Equal constants: both factors are C/C = 1.
  const cv::Mat flat(20, 20, CV_32F, cv::Scalar(0.25));
  EXPECT_NEAR(Ssim({}, flat, flat).mean, 1.0, 1e-12);
  // Different constants: zero variances, so SSIM = (2 mx my + C1) / (mx^2 + my^2 + C1).
  const cv::Mat other(20, 20, CV_32F, cv::Scalar(0.75));
  const double c1 = 0.01 * 0.01;
  EXPECT_NEAR(Ssim({}, flat, other).mean, (2 * 0.25 * 0.75 + c1) / (0.25 * 0.25 + 0.75 * 0.75 + c1),
              1e-6);
  // Constant against textured: finite, in [-1, 1].
  const double v = Ssim({}, cv::Mat(40, 40, CV_8UC1, cv::Scalar(128)), a).mean;
  EXPECT_TRUE(std::isfinite(v));
  EXPECT_LE(std::abs(v), 1.0);
}

TEST(Ssim, BadInputThrowsClearErrors) {
  const cv::Mat a(20, 20, CV_32FC1, cv::Scalar(0.5));
  auto message = [](auto&& fn) {
    try {
      fn();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([&] { Ssim({}, a, cv::Mat(20, 21, CV_32FC1, 0.5)); }).find("must match"),
            std::string::npos);
  EXPECT_NE(message([&] { Ssim({}, a, cv::Mat(20, 20, CV_32FC3, 0.5)); }).find("must match"),
            std::string::npos);
  EXPECT_NE(message([&] { Ssim({}, cv::Mat(), a); }).find("empty"), std::string::npos);
  cv::Mat nan = a.clone();
  nan.at<float>(3, 4) = std::nanf("");
  EXPECT_NE(message([&] { Ssim({}, a, nan); }).find("non-finite"), std::string::npos);
  EXPECT_NE(message([&] {
              Ssim({}, cv::Mat(10, 30, CV_32F, 0.5), cv::Mat(10, 30, CV_32F, 0.5));
            }).find("at least 11x11"),
            std::string::npos);
  EXPECT_NE(message([&] { Ssim({}, cv::Mat(20, 20, CV_8U, 1), a); }).find("depth"),
            std::string::npos);
  SsimOptions bad;
  bad.sigma = 0;
  EXPECT_NE(message([&] { Ssim(bad, a, a); }).find("sigma"), std::string::npos);
}

}  // namespace
}  // namespace turbid
