#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "enhancer/baselines/cap.h"
#include "enhancer/baselines/dcp.h"
#include "enhancer/blocks/guided_filter.h"
#include "core/error.h"
#include "tests/enhancer/baselines_reference.h"
#include "tests/enhancer/baselines_test_images.h"

namespace turbid {
namespace {

using baselines_test::AddHaze;
using baselines_test::SmoothColourTexture;

TEST(BaselinesCap, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(CapOptions{}.Check(&why)) << why;
  CapOptions bad;
  bad.t_min = 0.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("t_min"), std::string::npos);
  bad = CapOptions{};
  bad.beta = -1.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(ColorAttenuationPrior(bad, cv::Mat(3, 3, CV_32FC3, cv::Scalar::all(0.5))), Error);
}

// The raw depth is Zhu 2015 eq. 8 without ε; checked against OpenCV's own HSV conversion.
TEST(BaselinesCap, RawDepthMatchesOpenCvHsv) {
  const cv::Mat image = SmoothColourTexture(16, 20);
  const CapOptions options;
  const CapResult result = ColorAttenuationPriorDetailed(options, image);
  cv::Mat hsv;
  cv::cvtColor(image, hsv, cv::COLOR_BGR2HSV);  // float: S and V in [0,1]
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const cv::Vec3f p = hsv.at<cv::Vec3f>(y, x);
      const double expected = 0.121779 + 0.959710 * p[2] - 0.780245 * p[1];
      ASSERT_NEAR(result.raw_depth.at<float>(y, x), expected, 1e-5);
    }
  }
}

// Known ordering: haze whose transmission falls from left to right (true depth -ln t rises) gives
// a CAP depth whose band means rise in the same order, and t stays in [t_min, t_max].
TEST(BaselinesCap, DepthOrderingFollowsTrueDepth) {
  const int rows = 40, cols = 160, bands = 8;
  const cv::Mat clean = SmoothColourTexture(rows, cols);
  cv::Mat t(rows, cols, CV_32FC1);
  for (int x = 0; x < cols; ++x) t.col(x).setTo(std::exp(-2.0 * x / (cols - 1)));  // 1 .. 0.14
  const cv::Mat hazy = AddHaze(clean, t, cv::Vec3f(0.8f, 0.8f, 0.8f));
  CapOptions options;
  options.guided_radius = 8;
  const CapResult result = ColorAttenuationPriorDetailed(options, hazy);
  double previous = -1e9;
  for (int b = 0; b < bands; ++b) {
    const cv::Rect band(b * cols / bands, 0, cols / bands, rows);
    const double mean_depth = cv::mean(result.depth(band))[0];
    EXPECT_GT(mean_depth, previous) << "band " << b;
    previous = mean_depth;
  }
  double lo, hi;
  cv::minMaxLoc(result.transmission, &lo, &hi);
  EXPECT_GE(lo, options.t_min - 1e-7);
  EXPECT_LE(hi, options.t_max + 1e-7);
  // A comes from the farthest pixels: the right edge, where the haze is densest.
  EXPECT_GT(result.airlight_pixel.x, cols * 3 / 4);
}

// Gray input: saturation is 0, so depth = θ0 + θ1 v; brighter means farther.
TEST(BaselinesCap, GrayDepthIsLinearInBrightness) {
  cv::Mat gray(8, 8, CV_32FC1);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) gray.at<float>(y, x) = 0.1f * (x % 4) + 0.05f * (y % 3);
  }
  const CapResult result = ColorAttenuationPriorDetailed(CapOptions{}, gray);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      ASSERT_NEAR(result.raw_depth.at<float>(y, x), 0.121779 + 0.959710 * gray.at<float>(y, x),
                  1e-6);
    }
  }
  EXPECT_EQ(result.image.channels(), 1);
}

// With the refinement and minimum filter off (patch 1), the method is exact on haze that follows
// its own model: t = exp(-β d(I)) and A at the farthest pixel give back J where t > t_min.
TEST(BaselinesCap, InvertsItsOwnModelExactly) {
  const cv::Mat hazy_in = SmoothColourTexture(12, 12) * 0.5 + cv::Scalar::all(0.25);
  CapOptions options;
  options.refine = false;
  options.patch_size = 1;
  const CapResult result = ColorAttenuationPriorDetailed(options, hazy_in);
  const cv::Mat rehazed = AddHaze(result.image, result.transmission, result.airlight);
  // Recovered radiances that did not clip re-haze to the input.
  int checked = 0;
  for (int y = 0; y < hazy_in.rows; ++y) {
    for (int x = 0; x < hazy_in.cols; ++x) {
      const cv::Vec3f j = result.image.at<cv::Vec3f>(y, x);
      if (std::min({j[0], j[1], j[2]}) <= 0.0f || std::max({j[0], j[1], j[2]}) >= 1.0f) continue;
      if (result.transmission.at<float>(y, x) <= options.t_min) continue;
      const cv::Vec3f d = rehazed.at<cv::Vec3f>(y, x) - hazy_in.at<cv::Vec3f>(y, x);
      ASSERT_LT(std::sqrt(d.dot(d)), 1e-5);
      ++checked;
    }
  }
  EXPECT_GT(checked, 10);
}

// The pre-optimisation cap of commit 6722196 (enhancer/baselines_cap.cc then): the raw depth
// per pixel with a channel loop, cv::erode, a full nth_element for the airlight, OpenCV's min and
// max for the clamp. The guided filter is the library's (tested against its pre-optimisation
// version in guided_filter_test.cc).
CapResult ReferenceColorAttenuationPrior(const CapOptions& options, const cv::Mat& image) {
  namespace ref = baselines_reference;
  CapResult result;
  const int channels = image.channels();
  result.raw_depth.create(image.size(), CV_32FC1);
  for (int y = 0; y < image.rows; ++y) {
    const float* in = image.ptr<float>(y);
    float* d = result.raw_depth.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      const float* px = in + x * channels;
      float hi = px[0];
      float lo = px[0];
      for (int c = 1; c < channels; ++c) {
        hi = std::max(hi, px[c]);
        lo = std::min(lo, px[c]);
      }
      const double v = hi;
      const double sat = hi > 0.0f ? (hi - lo) / hi : 0.0;
      d[x] = static_cast<float>(options.theta0 + options.theta1 * v + options.theta2 * sat);
    }
  }
  const cv::Mat min_depth = ref::MinFilter(result.raw_depth, options.patch_size);
  result.airlight_pixel =
      ref::EstimateAirlight(image, min_depth, options.airlight_fraction, &result.airlight);
  if (options.refine) {
    GuidedFilterOptions g;
    g.radius = std::max(1, std::min(options.guided_radius, std::max(image.rows, image.cols)));
    g.eps = options.guided_eps;
    result.depth = GuidedFilter(g, image, min_depth);
  } else {
    result.depth = min_depth;
  }
  cv::Mat t;
  cv::exp(-options.beta * result.depth, t);
  result.transmission = cv::max(cv::min(t, options.t_max), options.t_min);
  result.image = ref::RecoverRadiance(image, result.transmission, result.airlight, options.t_min);
  return result;
}

// Today's cap gives the pre-optimisation values bit for bit (the same arithmetic per step),
// except that the guided filter of gray images at radii > 12 rounds differently
// (GuidedFilterGrayRunning: within baselines_reference::kRunningGuidedTolerance); the
// transmission and the image computed from its depth are then the reference's arithmetic exactly.
TEST(BaselinesCap, SameResultsAsThePreOptimisationImplementation) {
  namespace ref = baselines_reference;
  using ref::MaxDiff;
  std::vector<baselines_reference::NamedImage> inputs = baselines_reference::EquivalenceInputs();
  for (auto& real : baselines_reference::RealInputs()) inputs.push_back(real);
  for (const auto& [name, image] : inputs) {
    for (int variant = 0; variant < 3; ++variant) {
      CapOptions o;
      if (variant == 1) o.refine = false, o.patch_size = 1;
      if (variant == 2) o.patch_size = 5, o.guided_radius = 7, o.beta = 2.5, o.t_max = 0.9;
      const std::string what = name + " variant " + std::to_string(variant);
      const CapResult a = ColorAttenuationPriorDetailed(o, image);
      const CapResult b = ReferenceColorAttenuationPrior(o, image);
      EXPECT_EQ(MaxDiff(a.raw_depth, b.raw_depth), 0.0) << what;
      EXPECT_EQ(a.airlight_pixel, b.airlight_pixel) << what;
      EXPECT_EQ(a.airlight, b.airlight) << what;
      if (o.refine && ref::UsesRunningGuidedFilter(image, o.guided_radius)) {
        EXPECT_LE(MaxDiff(a.depth, b.depth), ref::kRunningGuidedTolerance) << what;
        // exp(-beta d) moves by at most beta |dd| (t <= 1).
        EXPECT_LE(MaxDiff(a.transmission, b.transmission), o.beta * ref::kRunningGuidedTolerance)
            << what;
        cv::Mat t;
        cv::exp(-o.beta * a.depth, t);
        EXPECT_EQ(MaxDiff(a.transmission, cv::max(cv::min(t, o.t_max), o.t_min)), 0.0) << what;
        EXPECT_EQ(
            MaxDiff(a.image, ref::RecoverRadiance(image, a.transmission, a.airlight, o.t_min)), 0.0)
            << what;
      } else {
        EXPECT_EQ(MaxDiff(a.depth, b.depth), 0.0) << what;
        EXPECT_EQ(MaxDiff(a.transmission, b.transmission), 0.0) << what;
        EXPECT_EQ(MaxDiff(a.image, b.image), 0.0) << what;
      }
    }
  }
}

}  // namespace
}  // namespace turbid
