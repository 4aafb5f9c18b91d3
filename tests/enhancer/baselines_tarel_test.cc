#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "enhancer/baselines/median.h"
#include "enhancer/baselines/tarel.h"
#include "enhancer/baselines/common.h"
#include "enhancer/simd_switch.h"
#include "scenes/builtin.h"
#include "core/error.h"
#include "scenes/image_io.h"
#include "simulator/render.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

// ---------------------------------------------------------------------------------------------
// The pre-optimisation implementation of tarel (enhancer/baselines_tarel.cc at commit 6722196:
// Huang's sliding histogram on 4096 coarse bins plus a selection in the median's bin, and one
// OpenCV call per step), kept as the reference that today's must match bit for bit.
namespace reference {

using baselines_internal::IsOddPositive;

cv::Mat ReferenceMedianFilter(const cv::Mat& image, int size) {
  CV_Assert(image.type() == CV_32FC1 && IsOddPositive(size));
  if (size == 1) return image.clone();
  const int half = size / 2;
  cv::Mat padded;
  cv::copyMakeBorder(image, padded, half, half, half, half, cv::BORDER_REFLECT);
  // Huang's sliding histogram on coarse bins finds the bin holding the median; the exact value is
  // then selected among the few window values in that bin. Exact, and ~10x faster than selecting
  // among all size^2 values per pixel.
  constexpr int kBins = 4096;
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(padded, &lo, &hi);
  const double scale = hi > lo ? (kBins - 1e-3) / (hi - lo) : 0.0;
  cv::Mat bins(padded.size(), CV_16UC1);
  for (int y = 0; y < padded.rows; ++y) {
    const float* v = padded.ptr<float>(y);
    uint16_t* b = bins.ptr<uint16_t>(y);
    for (int x = 0; x < padded.cols; ++x) {
      b[x] = static_cast<uint16_t>(std::min(kBins - 1, static_cast<int>((v[x] - lo) * scale)));
    }
  }
  cv::Mat out(image.size(), CV_32FC1);
  const int middle = (size * size) / 2;  // rank of the median, 0-based
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& rows) {
    std::vector<int> histogram(kBins);
    std::vector<float> candidates;
    candidates.reserve(static_cast<size_t>(size) * size);
    for (int y = rows.start; y < rows.end; ++y) {
      std::fill(histogram.begin(), histogram.end(), 0);
      for (int dy = 0; dy < size; ++dy) {
        const uint16_t* b = bins.ptr<uint16_t>(y + dy);
        for (int dx = 0; dx < size; ++dx) ++histogram[b[dx]];
      }
      int bin = 0;
      int below = 0;  // window values in bins < bin
      float* o = out.ptr<float>(y);
      for (int x = 0; x < image.cols; ++x) {
        if (x > 0) {
          for (int dy = 0; dy < size; ++dy) {
            const uint16_t* b = bins.ptr<uint16_t>(y + dy);
            const int gone = b[x - 1];
            const int added = b[x - 1 + size];
            --histogram[gone];
            if (gone < bin) --below;
            ++histogram[added];
            if (added < bin) ++below;
          }
        }
        while (below > middle) below -= histogram[--bin];
        while (below + histogram[bin] <= middle) below += histogram[bin++];
        candidates.clear();
        for (int dy = 0; dy < size; ++dy) {
          const uint16_t* b = bins.ptr<uint16_t>(y + dy) + x;
          const float* v = padded.ptr<float>(y + dy) + x;
          for (int dx = 0; dx < size; ++dx) {
            if (b[dx] == bin) candidates.push_back(v[dx]);
          }
        }
        const auto nth = candidates.begin() + (middle - below);
        std::nth_element(candidates.begin(), nth, candidates.end());
        o[x] = *nth;
      }
    }
  });
  return out;
}

// Smallest white / local-balance factor we divide by: keeps a channel that is nearly absent from
// blowing up (values are clamped to [0,1] after the division anyway).
constexpr float kMinBalance = 1e-3f;

cv::Mat ChannelMin(const cv::Mat& image) {
  if (image.channels() == 1) return image.clone();
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  return cv::min(cv::min(planes[0], planes[1]), planes[2]);
}

cv::Mat ChannelMean(const cv::Mat& image) {
  if (image.channels() == 1) return image.clone();
  cv::Mat mean;
  cv::transform(image, mean, cv::Matx13f(1.0f / 3, 1.0f / 3, 1.0f / 3));
  return mean;
}

// Global balance (reference code, balance == 0): the mean colour of the pixels whose whiteness
// reaches its 99th percentile (nearest rank), scaled so its largest channel is 1.
cv::Vec3f GlobalWhite(const cv::Mat& image) {
  const cv::Mat w = ChannelMin(image);
  std::vector<float> values(w.begin<float>(), w.end<float>());
  const size_t rank =
      static_cast<size_t>(std::floor(0.99 * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + rank, values.end());
  const float threshold = values[rank];
  cv::Vec3d sum(0, 0, 0);
  int count = 0;
  for (int y = 0; y < image.rows; ++y) {
    const cv::Vec3f* px = image.ptr<cv::Vec3f>(y);
    const float* wy = w.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      if (wy[x] >= threshold) {
        sum += cv::Vec3d(px[x][0], px[x][1], px[x][2]);
        ++count;
      }
    }
  }
  const double top = std::max({sum[0], sum[1], sum[2]});
  if (count == 0 || top <= 0.0) return cv::Vec3f(1, 1, 1);
  cv::Vec3f white;
  for (int c = 0; c < 3; ++c) white[c] = std::max(static_cast<float>(sum[c] / top), kMinBalance);
  return white;
}

// Local balance (reference code, balance > 0): per-pixel colour of the sv-median image, its
// deviation from gray raised to `strength`, renormalised to mean 1 over the channels.
cv::Mat LocalBalanceFactors(const cv::Mat& image, int sv, double strength) {
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (auto& plane : planes) plane = ReferenceMedianFilter(plane, sv);
  cv::Mat factors(image.size(), CV_32FC3);
  for (int y = 0; y < image.rows; ++y) {
    cv::Vec3f* f = factors.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.cols; ++x) {
      cv::Vec3d m(planes[0].at<float>(y, x), planes[1].at<float>(y, x), planes[2].at<float>(y, x));
      const double mean = (m[0] + m[1] + m[2]) / 3.0;
      if (mean <= 0.0) {
        f[x] = cv::Vec3f(1, 1, 1);
        continue;
      }
      for (int c = 0; c < 3; ++c) m[c] = std::pow(m[c] / mean, strength);
      const double renorm = (m[0] + m[1] + m[2]) / 3.0;
      for (int c = 0; c < 3; ++c) {
        f[x][c] = std::max(static_cast<float>(renorm > 0.0 ? m[c] / renorm : 1.0), kMinBalance);
      }
    }
  }
  return factors;
}

// Mean and sample standard deviation of log(v + 0.5/255) over the bottom third of the rows.
void BottomThirdLogStats(const cv::Mat& gray, double* mean, double* stddev) {
  const int first = std::min(gray.rows - 1, (2 * gray.rows) / 3);
  cv::Mat bottom = gray.rowRange(first, gray.rows).clone();
  cv::Mat logs;
  cv::log(bottom + 0.5 / 255.0, logs);
  cv::Scalar m, s;
  cv::meanStdDev(logs, m, s);
  const double n = static_cast<double>(logs.total());
  *mean = m[0];
  *stddev = n > 1 ? s[0] * std::sqrt(n / (n - 1)) : 0.0;
}

TarelResult ReferenceTarel(const TarelOptions& options, const cv::Mat& image) {
  baselines_internal::ValidateImage(image, "tarel");
  ThrowIfInvalid(options, "tarel");
  TarelResult result;
  result.white = cv::Vec3f(1, 1, 1);
  const bool color = image.channels() == 3;
  cv::Mat local_factors;
  if (color && options.balance == 0.0) {
    result.white = GlobalWhite(image);
    cv::divide(image, cv::Scalar(result.white[0], result.white[1], result.white[2]),
               result.balanced);
  } else if (color && options.balance > 0.0) {
    local_factors = LocalBalanceFactors(image, options.sv, options.balance);
    cv::divide(image, local_factors, result.balanced);
  } else {
    result.balanced = image.clone();
  }
  // Balanced values above 1 would let the veil exceed 1 and the restoration divide by <= 0.
  baselines_internal::ClampUnit(result.balanced);

  // Tarel 2009 §4.3: A = median_sv(W); B = A - median_sv(|W - A|); V = p max(min(W, B), 0).
  result.whiteness = ChannelMin(result.balanced);
  const cv::Mat local_median = ReferenceMedianFilter(result.whiteness, options.sv);
  const cv::Mat deviation = cv::abs(result.whiteness - local_median);
  const cv::Mat bound = local_median - ReferenceMedianFilter(deviation, options.sv);
  result.veil = cv::max(cv::min(result.whiteness, bound), 0.0) * options.p;

  // Tarel 2009 eq. 9 with the sky intensity I_s = 1 (after white balance): R = (I - V) / (1 - V).
  // V <= p W < 1, so the divisor is at least 1 - p and R >= 0.
  const int channels = image.channels();
  result.restored.create(image.size(), image.type());
  for (int y = 0; y < image.rows; ++y) {
    const float* in = result.balanced.ptr<float>(y);
    const float* v = result.veil.ptr<float>(y);
    float* r = result.restored.ptr<float>(y);
    const cv::Vec3f* f = local_factors.empty() ? nullptr : local_factors.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.cols; ++x) {
      for (int c = 0; c < channels; ++c) {
        float value = (in[x * channels + c] - v[x]) / (1.0f - v[x]);
        value *= f != nullptr ? f[x][c] : result.white[color ? c : 0];
        r[x * channels + c] = std::max(value, 0.0f);
      }
    }
  }

  if (!options.tone_map) {
    result.image = result.restored.clone();
    baselines_internal::ClampUnit(result.image);
    return result;
  }
  // Reference code: a gamma that matches the log-mean and log-spread of the bottom third of the
  // image to the input's, then u / (1 + (1 - 1/max u) u), which maps max u to 1.
  double mean_in, std_in, mean_out, std_out;
  BottomThirdLogStats(ChannelMean(result.balanced), &mean_in, &std_in);
  BottomThirdLogStats(ChannelMean(result.restored), &mean_out, &std_out);
  // A flat bottom third has no spread to match: keep the exponent at 1 instead of 0 or infinity.
  const double exponent =
      (std_in > 1e-6 && std_out > 1e-6) ? options.gamma_factor * std_in / std_out : 1.0;
  const double scale = std::exp(mean_in - mean_out * exponent);
  cv::Mat u;
  cv::pow(result.restored, exponent, u);
  u *= scale;
  double max_u = 0.0;
  cv::minMaxLoc(u.reshape(1), nullptr, &max_u);
  if (max_u > 1e-12 && std::isfinite(max_u)) {
    cv::Mat denominator = u * (1.0 - 1.0 / max_u) + cv::Scalar::all(1.0);
    cv::divide(u, denominator, result.image);
  } else {
    result.image = u;
  }
  baselines_internal::ClampUnit(result.image);
  return result;
}

}  // namespace reference

using reference::ReferenceMedianFilter;
using reference::ReferenceTarel;

TEST(BaselinesTarel, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(TarelOptions{}.Check(&why)) << why;
  TarelOptions bad;
  bad.p = 1.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("p must"), std::string::npos);
  bad = TarelOptions{};
  bad.sv = 10;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(Tarel(bad, cv::Mat(3, 3, CV_32FC1, cv::Scalar(0.5))), Error);
}

void ExpectBruteForceMedian(const cv::Mat& image, int size) {
  const cv::Mat median = MedianFilter(image, size);
  const int half = size / 2;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      std::vector<float> window;
      for (int dy = -half; dy <= half; ++dy) {
        for (int dx = -half; dx <= half; ++dx) {
          window.push_back(
              image.at<float>(cv::borderInterpolate(y + dy, image.rows, cv::BORDER_REFLECT),
                              cv::borderInterpolate(x + dx, image.cols, cv::BORDER_REFLECT)));
        }
      }
      std::sort(window.begin(), window.end());
      ASSERT_EQ(median.at<float>(y, x), window[window.size() / 2]) << size << " " << y << "," << x;
    }
  }
}

TEST(BaselinesTarel, MedianFilterMatchesBruteForceWithReflectBorder) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  cv::Mat image(29, 37, CV_32FC1);
  for (auto it = image.begin<float>(); it != image.end<float>(); ++it) *it = u(rng);
  ExpectBruteForceMedian(image, 5);
  ExpectBruteForceMedian(image, 11);
  ExpectBruteForceMedian(image(cv::Rect(0, 0, 3, 2)).clone(), 11);  // window larger than image
  // Values packed in a narrow range with many ties (8-bit levels) and one outlier far away,
  // so most of the window shares a coarse bin.
  for (auto it = image.begin<float>(); it != image.end<float>(); ++it) {
    *it = 0.5f + std::round(*it * 6.0f) / 255.0f;
  }
  image.at<float>(3, 4) = -7.0f;
  ExpectBruteForceMedian(image, 11);
  ExpectBruteForceMedian(cv::Mat(5, 5, CV_32FC1, cv::Scalar(0.25)), 3);
}

// Known answer: a constant veil V over a scene that is black on most pixels (Koschmieder with a
// white sky, I = J (1 - V) + V). Every 11x11 window is mostly V, so med(W) = V, the median
// deviation is 0 and the inferred veil is exactly p V; the restoration is (I - pV) / (1 - pV).
TEST(BaselinesTarel, RecoversConstantVeil) {
  const float veil = 0.4f;
  for (int channels : {1, 3}) {
    cv::Mat clean(30, 33, CV_32FC(channels), cv::Scalar::all(0.0));
    for (int y = 0; y < clean.rows; y += 3) {
      for (int x = 0; x < clean.cols; x += 3) {
        for (int c = 0; c < channels; ++c) {
          clean.ptr<float>(y)[x * channels + c] = 0.3f + 0.2f * c + 0.01f * ((x + y) % 7);
        }
      }
    }
    const cv::Mat hazy = clean * (1.0 - veil) + cv::Scalar::all(veil);
    TarelOptions options;
    options.balance = -1.0;  // the veil is white already
    options.p = 0.99;
    const TarelResult result = TarelDetailed(options, hazy);
    for (int y = 0; y < hazy.rows; ++y) {
      for (int x = 0; x < hazy.cols; ++x) {
        ASSERT_NEAR(result.veil.at<float>(y, x), options.p * veil, 1e-6);
        for (int c = 0; c < channels; ++c) {
          const double i = hazy.ptr<float>(y)[x * channels + c];
          const double expected = (i - options.p * veil) / (1.0 - options.p * veil);
          ASSERT_NEAR(result.restored.ptr<float>(y)[x * channels + c], expected, 1e-5);
          // and close to the clean scene, off by the 1 % of the veil p leaves
          ASSERT_NEAR(result.restored.ptr<float>(y)[x * channels + c],
                      clean.ptr<float>(y)[x * channels + c], 0.01);
        }
      }
    }
  }
}

// The veil never exceeds the whiteness (Tarel 2009 constraint 0 <= V <= W), on a real-looking
// colour scene with each white-balance mode.
TEST(BaselinesTarel, VeilBelowMinimumChannel) {
  BuiltinSceneOptions scene_options;
  scene_options.scale = 0.25;
  const Scene scene = MakeBuiltinScene("seafloor", scene_options);
  cv::Mat hazy = scene.image * 0.6 + cv::Scalar(0.3, 0.25, 0.05);
  for (double balance : {-1.0, 0.0, 0.5}) {
    TarelOptions options;
    options.balance = balance;
    const TarelResult result = TarelDetailed(options, hazy);
    EXPECT_EQ(cv::countNonZero(result.veil > result.whiteness), 0) << balance;
    EXPECT_EQ(cv::countNonZero(result.veil < 0.0f), 0) << balance;
    std::vector<cv::Mat> planes;
    cv::split(result.balanced, planes);
    const cv::Mat w = cv::min(cv::min(planes[0], planes[1]), planes[2]);
    EXPECT_EQ(cv::norm(w, result.whiteness, cv::NORM_INF), 0.0);
    double lo, hi;
    cv::minMaxLoc(result.image.reshape(1), &lo, &hi);
    EXPECT_GE(lo, 0.0);
    EXPECT_LE(hi, 1.0);
  }
}

// Global white balance maps the mean colour of the whitest 1 % to gray.
TEST(BaselinesTarel, GlobalWhiteBalanceNeutralisesTint) {
  cv::Mat image(20, 20, CV_32FC3, cv::Scalar(0.2, 0.2, 0.1));
  image(cv::Rect(0, 0, 4, 4)).setTo(cv::Scalar(0.9, 0.8, 0.6));  // the whitest patch, tinted
  TarelOptions options;
  const TarelResult result = TarelDetailed(options, image);
  EXPECT_NEAR(result.white[0], 1.0f, 1e-6);
  EXPECT_NEAR(result.white[1], 0.8f / 0.9f, 1e-6);
  EXPECT_NEAR(result.white[2], 0.6f / 0.9f, 1e-6);
  const cv::Vec3f balanced = result.balanced.at<cv::Vec3f>(1, 1);
  EXPECT_NEAR(balanced[0], balanced[1], 1e-6);
  EXPECT_NEAR(balanced[0], balanced[2], 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Today's implementation against the pre-optimisation one: the medians are exact either way, so
// every output must be bit-identical (compared with ==, so a median of +0 and -0 may be either).

cv::Mat Uniform(int rows, int cols, int channels, uint32_t seed, float lo = 0.0f, float hi = 1.0f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  cv::Mat image(rows, cols, CV_32FC(channels));
  float* p = image.ptr<float>();
  for (size_t i = 0; i < image.total() * channels; ++i) p[i] = u(rng);
  return image;
}

// Values on a few levels (8-bit codes near 0.5), so that windows hold many ties.
cv::Mat FewLevels(int rows, int cols, uint32_t seed) {
  cv::Mat image = Uniform(rows, cols, 1, seed);
  for (auto it = image.begin<float>(); it != image.end<float>(); ++it) {
    *it = 0.5f + std::round(*it * 6.0f) / 255.0f;
  }
  return image;
}

void ExpectSame(const cv::Mat& ours, const cv::Mat& reference, const std::string& what) {
  ASSERT_EQ(ours.size(), reference.size()) << what;
  ASSERT_EQ(ours.type(), reference.type()) << what;
  EXPECT_EQ(cv::norm(ours, reference, cv::NORM_INF), 0.0) << what;
}

// Every median path (the straight-line networks for k = 11 where the CPU has AVX2, the run-time
// networks, the run-time networks without the AVX2 switch) against the old filter.
void ExpectMediansMatchReference(const cv::Mat& image, int k, const std::string& what) {
  const cv::Mat reference = ReferenceMedianFilter(image, k);
  ExpectSame(MedianFilter(image, k), reference, what + " MedianFilter k=" + std::to_string(k));
  if (k >= 3) {
    ExpectSame(baselines_internal::NetworkMedian(image, k, false), reference,
               what + " run-time networks k=" + std::to_string(k));
  }
}

TEST(BaselinesTarel, MedianFilterMatchesPreOptimisationFilter) {
  struct Case {
    int rows, cols;
  };
  // Odd and even sizes, single rows and columns, windows larger than the image.
  const std::vector<Case> sizes = {{1, 1},  {1, 9},   {9, 1},   {2, 3},   {3, 2},
                                   {7, 13}, {12, 12}, {31, 17}, {40, 67}, {64, 33}};
  uint32_t seed = 100;
  for (const Case& size : sizes) {
    for (int k : {1, 3, 5, 7, 9, 11, 13, 15}) {
      const std::string what = std::to_string(size.rows) + "x" + std::to_string(size.cols);
      ExpectMediansMatchReference(Uniform(size.rows, size.cols, 1, ++seed), k, what + " uniform");
      ExpectMediansMatchReference(FewLevels(size.rows, size.cols, ++seed), k, what + " ties");
    }
  }
  // Larger windows (run-time networks with thousands of values).
  for (int k : {21, 31}) {
    ExpectMediansMatchReference(Uniform(40, 45, 1, ++seed), k, "40x45 uniform");
    ExpectMediansMatchReference(FewLevels(40, 45, ++seed), k, "40x45 ties");
  }
  // Constant images, values outside [0, 1], signed zeros and a far outlier.
  ExpectMediansMatchReference(cv::Mat(23, 29, CV_32FC1, cv::Scalar(0.25)), 11, "constant");
  ExpectMediansMatchReference(cv::Mat(23, 29, CV_32FC1, cv::Scalar(0.0)), 11, "zero");
  ExpectMediansMatchReference(Uniform(37, 41, 1, 7, -1e6f, 1e6f), 11, "wide range");
  cv::Mat zeros = Uniform(25, 26, 1, 8, -1.0f, 1.0f);
  for (auto it = zeros.begin<float>(); it != zeros.end<float>(); ++it) {
    if (std::fabs(*it) < 0.5f) *it = *it < 0.0f ? -0.0f : 0.0f;
  }
  ExpectMediansMatchReference(zeros, 11, "signed zeros");
  cv::Mat outlier = FewLevels(30, 30, 9);
  outlier.at<float>(3, 4) = -7.0f;
  outlier.at<float>(20, 21) = 1e30f;
  ExpectMediansMatchReference(outlier, 11, "outliers");
}

TEST(BaselinesTarel, MedianFilterWithoutAvx2MatchesPreOptimisationFilter) {
  enhancer_internal::SetHandWrittenAvx2(false);
  const cv::Mat image = Uniform(45, 52, 1, 21);
  const cv::Mat ours = MedianFilter(image, 11);
  enhancer_internal::SetHandWrittenAvx2(true);
  ExpectSame(ours, ReferenceMedianFilter(image, 11), "portable k=11");
}

// A 1360x1024 render (the hull scene, as `turbid bench` uses) and the real frames in $TURBID_DATA.
TEST(BaselinesTarel, MedianFilterMatchesPreOptimisationFilterOnRender) {
  BuiltinSceneOptions scene_options;
  const Scene hull = MakeBuiltinScene("hull", scene_options);
  RenderOptions render;
  render.water.type = "3C";
  render.seed = 1;
  render.camera.encoding = CameraEncoding::kLinear;
  const cv::Mat image = Render(render, hull).image;
  ASSERT_EQ(image.size(), cv::Size(1360, 1024));
  ExpectSame(MedianFilter(image, 11), ReferenceMedianFilter(image, 11), "hull render");
}

void ExpectTarelMatchesReference(const TarelOptions& options, const cv::Mat& image,
                                 const std::string& what) {
  const TarelResult ours = TarelDetailed(options, image);
  const TarelResult reference = ReferenceTarel(options, image);
  ExpectSame(ours.image, reference.image, what + " image");
  ExpectSame(ours.balanced, reference.balanced, what + " balanced");
  ExpectSame(ours.whiteness, reference.whiteness, what + " whiteness");
  ExpectSame(ours.veil, reference.veil, what + " veil");
  ExpectSame(ours.restored, reference.restored, what + " restored");
  EXPECT_EQ(ours.white, reference.white) << what;
}

TEST(BaselinesTarel, MatchesPreOptimisationImplementation) {
  BuiltinSceneOptions scene_options;
  scene_options.scale = 0.25;
  const cv::Mat seafloor = MakeBuiltinScene("seafloor", scene_options).image;
  const cv::Mat hazy_color = seafloor * 0.6 + cv::Scalar(0.3, 0.25, 0.05);
  cv::Mat hazy_gray;
  cv::cvtColor(hazy_color, hazy_gray, cv::COLOR_BGR2GRAY);
  std::vector<std::pair<std::string, cv::Mat>> images = {
      {"seafloor colour", hazy_color},
      {"seafloor gray", hazy_gray},
      {"odd colour", Uniform(17, 23, 3, 31)},
      {"odd gray", Uniform(23, 17, 1, 32)},
      {"tiny colour", Uniform(2, 3, 3, 33)},
      {"tiny gray", Uniform(1, 1, 1, 34)},
      {"constant colour", cv::Mat(20, 21, CV_32FC3, cv::Scalar(0.4, 0.5, 0.6))},
      {"constant gray", cv::Mat(20, 21, CV_32FC1, cv::Scalar(0.4))},
      {"above one", Uniform(19, 18, 3, 35, 0.0f, 1.5f)},
  };
  for (const auto& [name, image] : images) {
    for (double balance : {-1.0, 0.0, 0.5}) {
      for (bool tone_map : {true, false}) {
        for (int sv : {11, 5}) {
          TarelOptions options;
          options.balance = balance;
          options.tone_map = tone_map;
          options.sv = sv;
          ExpectTarelMatchesReference(options, image,
                                      name + " balance " + std::to_string(balance) +
                                          (tone_map ? " tone-mapped" : "") + " sv " +
                                          std::to_string(sv));
        }
      }
    }
  }
}

TEST(BaselinesTarel, MatchesPreOptimisationImplementationOnRealFrames) {
  TURBID_REQUIRE_DATA(data);
  for (const char* file : {"/uieb_waternet/616.png", "/euvp_funiegan/A/1.jpg",
                           "/subvo/images/frame_00_00_21.000.jpg"}) {
    const cv::Mat image = ReadImage(data + file);
    cv::Mat gray;
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
    ExpectTarelMatchesReference(TarelOptions{}, image, std::string(file) + " colour");
    if (image.cols <= 800) {  // the large frame once (the reference takes seconds)
      ExpectTarelMatchesReference(TarelOptions{}, gray, std::string(file) + " gray");
    }
  }
}

}  // namespace
}  // namespace turbid
