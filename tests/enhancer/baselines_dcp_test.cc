#include <gtest/gtest.h>

#include <limits>
#include <opencv2/imgproc.hpp>

#include "enhancer/baselines/dcp.h"
#include "enhancer/blocks/guided_filter.h"
#include "core/error.h"
#include "tests/enhancer/baselines_reference.h"
#include "tests/enhancer/baselines_test_images.h"

namespace turbid {
namespace {

using baselines_test::AddHaze;
using baselines_test::ColumnTransmission;
using baselines_test::DarkPriorTexture;

TEST(BaselinesDcp, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(DcpOptions{}.Check(&why)) << why;
  EXPECT_TRUE(UdcpOptions{}.Check(&why)) << why;
  DcpOptions bad;
  bad.patch_size = 14;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("patch_size"), std::string::npos);
  bad = DcpOptions{};
  bad.omega = 0.0;
  EXPECT_FALSE(bad.Check(&why));
  bad = DcpOptions{};
  bad.t0 = 1.5;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(DarkChannelPrior(bad, cv::Mat(4, 4, CV_32FC3, cv::Scalar::all(0.5))), Error);
}

TEST(BaselinesDcp, DarkChannelMatchesBruteForce) {
  const cv::Mat image = DarkPriorTexture(20, 24, false, 3) * 0.5 + cv::Scalar::all(0.25);
  const cv::Mat dark = DarkChannel(image, 5);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      float expected = 1.0f;
      for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
          const cv::Vec3f p = image.at<cv::Vec3f>(std::clamp(y + dy, 0, image.rows - 1),
                                                  std::clamp(x + dx, 0, image.cols - 1));
          expected = std::min({expected, p[0], p[1], p[2]});
        }
      }
      ASSERT_FLOAT_EQ(dark.at<float>(y, x), expected) << y << "," << x;
    }
  }
  // Skipping red only ever raises the dark channel.
  const cv::Mat dark_gb = DarkChannel(image, 5, true);
  EXPECT_EQ(cv::countNonZero(dark_gb < dark), 0);
}

// Known answer (He 2011 eqs. 1, 12): on haze I = J t + A (1 - t) over a texture whose dark channel
// is exactly 0, with a pure-airlight strip (t = 0) on the left, DCP reads A exactly and the raw
// transmission is 1 - ω (1 - t_patch), where t_patch is the largest t in the 15 x 15 patch (t
// rises by 0.012 per column here, so |t_patch - t| <= 7 * 0.012 ≈ 0.08 (1 - ω tightens it).
TEST(BaselinesDcp, RecoversAirlightAndTransmissionOnSyntheticHaze) {
  const int rows = 48, cols = 96, sky = 16;
  const cv::Vec3f airlight(0.85f, 0.8f, 0.7f);
  const cv::Mat clean = DarkPriorTexture(rows, cols, false);
  const cv::Mat t = ColumnTransmission(rows, cols, sky, 0.1f, 1.0f);
  const cv::Mat hazy = AddHaze(clean, t, airlight);
  DcpOptions options;
  options.refine = false;
  const DcpResult result = DarkChannelPriorDetailed(options, hazy);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(result.airlight[c], airlight[c], 1e-6);
  EXPECT_LT(result.airlight_pixel.x, sky);
  const int half = options.patch_size / 2;
  double worst = 0.0;
  double worst_exact = 0.0;
  for (int y = 0; y < rows; ++y) {
    for (int x = sky + half; x < cols - half; ++x) {
      const double t_true = t.at<float>(y, x);
      const double t_patch = t.at<float>(y, x + half);
      const double estimate = result.raw_transmission.at<float>(y, x);
      worst = std::max(worst, std::abs(estimate - t_true));
      worst_exact =
          std::max(worst_exact, std::abs(estimate - (1.0 - options.omega * (1.0 - t_patch))));
    }
  }
  EXPECT_LT(worst_exact, 1e-5);  // the closed form, to float rounding
  EXPECT_LT(worst, 0.12);  // vs the true t: patch offset (<= 0.08) + (1 - ω)(1 - t) (<= 0.045)

  // With ω = 1 and a guided refinement, the recovered radiance is close to J where t >= 0.3.
  options.omega = 1.0;
  options.refine = true;
  options.guided_radius = 8;
  const DcpResult refined = DarkChannelPriorDetailed(options, hazy);
  double error = 0.0;
  int count = 0;
  for (int y = 0; y < rows; ++y) {
    for (int x = sky + half; x < cols - half; ++x) {
      if (t.at<float>(y, x) < 0.3f) continue;
      const cv::Vec3f d = refined.image.at<cv::Vec3f>(y, x) - clean.at<cv::Vec3f>(y, x);
      error += d.dot(d) / 3.0;
      ++count;
    }
  }
  const double psnr = 10.0 * std::log10(1.0 / (error / count));
  EXPECT_GT(psnr, 20.0);
}

// UDCP's prior holds when G or B is dark; red may stay bright (red is the channel water absorbs,
// so the classic prior becomes unreliable). Same known-answer set-up as DCP.
TEST(BaselinesUdcp, RecoversAirlightAndTransmissionWithRedIgnored) {
  const int rows = 48, cols = 96, sky = 16;
  const cv::Vec3f airlight(0.8f, 0.7f, 0.15f);  // blue-green water, little red
  const cv::Mat clean = DarkPriorTexture(rows, cols, true);
  const cv::Mat t = ColumnTransmission(rows, cols, sky, 0.1f, 1.0f);
  const cv::Mat hazy = AddHaze(clean, t, airlight);
  UdcpOptions options;
  options.refine = false;
  const DcpResult result = UnderwaterDarkChannelPriorDetailed(options, hazy);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(result.airlight[c], airlight[c], 1e-6);
  const int half = options.patch_size / 2;
  double worst = 0.0;
  for (int y = 0; y < rows; ++y) {
    for (int x = sky + half; x < cols - half; ++x) {
      const double t_patch = t.at<float>(y, x + half);
      worst = std::max(worst, std::abs(result.raw_transmission.at<float>(y, x) -
                                       (1.0 - options.omega * (1.0 - t_patch))));
    }
  }
  EXPECT_LT(worst, 1e-5);
  // The classic dark channel counts the bright red channel of the airlight-normalised image and
  // is not fooled here either, but its dark channel of the input differs: red is the minimum.
  const cv::Mat dark_all = DarkChannel(hazy, 15, false);
  const cv::Mat dark_gb = DarkChannel(hazy, 15, true);
  EXPECT_LT(cv::mean(dark_all)[0], cv::mean(dark_gb)[0]);
}

TEST(BaselinesDcp, GrayInputUsesTheSingleChannel) {
  const int rows = 32, cols = 64, sky = 8;
  cv::Mat clean_color = DarkPriorTexture(rows, cols, false);
  cv::Mat clean;
  cv::extractChannel(clean_color, clean, 0);  // one channel, zero in about a third of blocks
  // Make sure every 15x15 patch contains a 0: zero every 8th row and column.
  for (int i = 0; i < rows; i += 8) clean.row(i).setTo(0.0f);
  for (int i = 0; i < cols; i += 8) clean.col(i).setTo(0.0f);
  const cv::Mat t = ColumnTransmission(rows, cols, sky, 0.2f, 1.0f);
  const cv::Mat hazy = AddHaze(clean, t, cv::Vec3f(0.9f, 0.9f, 0.9f));
  DcpOptions options;
  options.refine = false;
  const DcpResult result = DarkChannelPriorDetailed(options, hazy);
  EXPECT_NEAR(result.airlight[0], 0.9f, 1e-6);
  EXPECT_EQ(result.image.channels(), 1);
  const int half = options.patch_size / 2;
  for (int x = sky + half; x < cols - half; ++x) {
    const double t_patch = t.at<float>(0, x + half);
    EXPECT_NEAR(result.raw_transmission.at<float>(rows / 2, x),
                1.0 - options.omega * (1.0 - t_patch), 1e-5);
  }
}

// The pre-optimisation dcp / udcp of commit 6722196 (enhancer/baselines_dcp.cc then): cv::erode
// minimum filters, a full nth_element for the airlight, the normalised dark channel filtered
// again, OpenCV arithmetic for the clamps. The guided filter is the library's (its own
// equivalence to the pre-optimisation filter is tested in guided_filter_test.cc).
DcpResult ReferenceDarkChannelPrior(const DcpOptions& options, const cv::Mat& image,
                                    bool underwater) {
  namespace ref = baselines_reference;
  DcpResult result;
  result.dark_channel = ref::DarkChannel(image, options.patch_size, underwater);
  result.airlight_pixel = ref::EstimateAirlight(image, result.dark_channel,
                                                options.airlight_fraction, &result.airlight);
  const int channels = image.channels();
  cv::Mat normalised(image.size(), CV_32FC1);
  const int last = (channels == 3 && underwater) ? 2 : channels;
  for (int y = 0; y < image.rows; ++y) {
    const float* in = image.ptr<float>(y);
    float* o = normalised.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      float m = std::numeric_limits<float>::max();
      for (int c = 0; c < last; ++c) {
        m = std::min(m, in[x * channels + c] / std::max(result.airlight[c], 1e-6f));
      }
      o[x] = m;
    }
  }
  result.raw_transmission = 1.0 - options.omega * ref::MinFilter(normalised, options.patch_size);
  ref::ClampUnit(result.raw_transmission);
  if (options.refine) {
    GuidedFilterOptions g;
    g.radius = std::max(1, std::min(options.guided_radius, std::max(image.rows, image.cols)));
    g.eps = options.guided_eps;
    result.transmission = GuidedFilter(g, image, result.raw_transmission);
    ref::ClampUnit(result.transmission);
  } else {
    result.transmission = result.raw_transmission.clone();
  }
  result.image = ref::RecoverRadiance(image, result.transmission, result.airlight, options.t0);
  return result;
}

void ExpectSameDcp(const DcpResult& a, const DcpResult& b, const cv::Mat& image,
                   const DcpOptions& o, const std::string& what) {
  namespace ref = baselines_reference;
  using ref::MaxDiff;
  EXPECT_EQ(MaxDiff(a.dark_channel, b.dark_channel), 0.0) << what;
  EXPECT_EQ(a.airlight_pixel, b.airlight_pixel) << what;
  EXPECT_EQ(a.airlight, b.airlight) << what;
  EXPECT_EQ(MaxDiff(a.raw_transmission, b.raw_transmission), 0.0) << what;
  if (o.refine && ref::UsesRunningGuidedFilter(image, o.guided_radius)) {
    // Float rounding of the guided filter only (kRunningGuidedTolerance); the clamp and the
    // recovery from it are the reference's arithmetic exactly.
    EXPECT_LE(MaxDiff(a.transmission, b.transmission), ref::kRunningGuidedTolerance) << what;
    EXPECT_EQ(MaxDiff(a.image, ref::RecoverRadiance(image, a.transmission, a.airlight, o.t0)), 0.0)
        << what;
  } else {
    EXPECT_EQ(MaxDiff(a.transmission, b.transmission), 0.0) << what;
    EXPECT_EQ(MaxDiff(a.image, b.image), 0.0) << what;
  }
}

// Today's dcp and udcp give the pre-optimisation values: bit for bit, except that the guided
// filter of gray images at radii > 12 rounds differently (GuidedFilterGrayRunning, see
// ExpectSameDcp). Every other step is the same arithmetic (minima are exact; the gray normalised
// dark channel is the dark channel over A, as float division by a positive constant is monotone).
TEST(BaselinesDcp, SameResultsAsThePreOptimisationImplementation) {
  std::vector<baselines_reference::NamedImage> inputs = baselines_reference::EquivalenceInputs();
  for (auto& real : baselines_reference::RealInputs()) inputs.push_back(real);
  for (const auto& [name, image] : inputs) {
    for (int variant = 0; variant < 4; ++variant) {
      DcpOptions o;
      if (variant == 1) o.refine = false;
      if (variant == 2) o.patch_size = 3, o.guided_radius = 8, o.omega = 0.7;
      if (variant == 3) o.patch_size = 1, o.airlight_fraction = 0.2;
      const std::string what = name + " variant " + std::to_string(variant);
      ExpectSameDcp(DarkChannelPriorDetailed(o, image), ReferenceDarkChannelPrior(o, image, false),
                    image, o, "dcp " + what);
      UdcpOptions u;
      static_cast<DcpOptions&>(u) = o;
      ExpectSameDcp(UnderwaterDarkChannelPriorDetailed(u, image),
                    ReferenceDarkChannelPrior(o, image, true), image, o, "udcp " + what);
    }
  }
}

// The minimum filter equals cv::erode (replicated border) for every size on odd shapes, including
// windows larger than the image.
TEST(BaselinesDcp, DarkChannelEqualsErodeForEverySize) {
  for (const auto& [name, image] : baselines_reference::EquivalenceInputs()) {
    for (int size : {1, 3, 5, 7, 9, 15, 17, 31, 33, 65}) {
      for (bool skip_red : {false, true}) {
        EXPECT_EQ(
            baselines_reference::MaxDiff(DarkChannel(image, size, skip_red),
                                         baselines_reference::DarkChannel(image, size, skip_red)),
            0.0)
            << name << " size " << size;
      }
    }
  }
}

// The airlight search narrows the sort to a sampled threshold; ties and plateaus (many equal
// brightest values) pick the same pixel as the full sort.
TEST(BaselinesDcp, AirlightEqualsFullSortWithTiesAndPlateaus) {
  cv::Mat image(300, 410, CV_32FC3);
  cv::RNG(5).fill(image, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat prior(image.size(), CV_32FC1);
  cv::RNG(6).fill(prior, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat quantised;
  prior.convertTo(quantised, CV_8U, 255.0);
  quantised.convertTo(quantised, CV_32F, 1.0 / 255.0);  // many ties
  cv::Mat plateau = prior.clone();
  plateau(cv::Rect(0, 0, 410, 120)).setTo(2.0);  // far more than `count` equal maxima
  for (const cv::Mat* p : {&prior, &quantised, &plateau}) {
    for (double fraction : {0.0001, 0.001, 0.01, 0.05, 0.5, 1.0}) {
      cv::Vec3f a, b;
      const cv::Point pa = EstimateAirlight(image, *p, fraction, &a);
      const cv::Point pb = baselines_reference::EstimateAirlight(image, *p, fraction, &b);
      EXPECT_EQ(pa, pb) << fraction;
      EXPECT_EQ(a, b) << fraction;
    }
  }
}

}  // namespace
}  // namespace turbid
