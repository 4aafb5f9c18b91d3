// Property tests (issue 17): metric identities and symmetries on seeded random image pairs.
//   SSIM(x, x) = 1, MSE(x, x) = 0, PSNR(x, x) = +inf;
//   SSIM, MSE and PSNR are symmetric in their two images (Wang 2004 Eq. 13 is symmetric);
//   Hautiere e = 0 and r = 1 when the restored image is the original (n_r = n_o, every gradient
//   ratio 1), e NaN when the original has no visible edge (0 / 0);
//   every metric is finite (PSNR: +inf only for identical pairs) and a pure function of its input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "metrics/full_reference.h"
#include "metrics/registry.h"
#include "metrics/ssim.h"
#include "metrics/visible_edges.h"
#include "core/error.h"
#include "tests/support/random_images.h"

namespace turbid {
namespace {

class MetricProperty : public ::testing::TestWithParam<int> {};

// A second image of the same shape: the first plus bounded noise, clipped to [0, 1].
cv::Mat Perturbed(const cv::Mat& image, uint64_t seed) {
  cv::Mat noise(image.size(), image.type());
  cv::theRNG().state = seed + 1;
  cv::randn(noise, 0.0, 0.05);
  cv::Mat out = image + noise;
  return cv::min(cv::max(out, 0.0), 1.0);
}

TEST_P(MetricProperty, IdentitiesAndSymmetries) {
  const uint64_t seed = static_cast<uint64_t>(GetParam()) + 5000;
  const testing::RandomImage input = testing::MakeRandomImage(seed);
  const cv::Mat& x = input.image;
  const cv::Mat y = Perturbed(x, seed);
  SCOPED_TRACE(input.what);

  // MSE / PSNR: any size.
  EXPECT_EQ(Mse(x, x), 0.0);
  EXPECT_EQ(Psnr(PsnrOptions{}, x, x), std::numeric_limits<double>::infinity());
  EXPECT_EQ(Mse(x, y), Mse(y, x));
  EXPECT_EQ(Psnr(PsnrOptions{}, x, y), Psnr(PsnrOptions{}, y, x));

  // SSIM needs 11x11 with the default window: smaller inputs get one clear error.
  const int window = 2 * SsimRadius(SsimOptions{}) + 1;
  if (x.rows < window || x.cols < window) {
    try {
      Ssim(SsimOptions{}, x, x);
      ADD_FAILURE() << "SSIM accepted an image smaller than its window";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
  } else {
    for (const bool exact : {false, true}) {
      SsimOptions options;
      options.exact_double = exact;
      EXPECT_NEAR(Ssim(options, x, x).mean, 1.0, 1e-12) << "exact_double " << exact;
      // Symmetric up to rounding (the fused path sums in a fixed order per image).
      EXPECT_NEAR(Ssim(options, x, y).mean, Ssim(options, y, x).mean, 1e-9);
      EXPECT_LE(Ssim(options, x, y).mean, 1.0 + 1e-12);
    }
  }

  // Visible edges of an image against itself.
  if (x.rows >= 7 && x.cols >= 7) {
    for (const VisibleEdgeVariant variant : {VisibleEdgeVariant::kPaper, VisibleEdgeVariant::kIfsttar}) {
      const VisibleEdgeResult same = VisibleEdges({.variant = variant}, x, x);
      EXPECT_EQ(same.visible_original, same.visible_restored);
      if (same.visible_original > 0) {
        EXPECT_EQ(same.e, 0.0);
        if (same.finite_log_ratios > 0) {
          EXPECT_NEAR(same.r_mean, 1.0, 1e-12);
        }
      } else {
        EXPECT_TRUE(std::isnan(same.e)) << same.e;
      }
    }
  }

  // The whole registry: finite values, the same twice.
  if (x.rows >= window && x.cols >= window) {
    MetricInputs in{x, y, x, 0.0};
    const std::vector<std::string> names = ParseMetricList("all", true, true);
    const auto first = ComputeMetrics(names, in);
    const auto second = ComputeMetrics(names, in);
    for (const auto& [name, value] : first) {
      const bool edge_rate = name.rfind("hautiere_e", 0) == 0 || name.rfind("hautiere_r", 0) == 0;
      if (!edge_rate) {
        EXPECT_TRUE(std::isfinite(value)) << name << " = " << value;
      }
      const double again = second.at(name);
      EXPECT_TRUE(value == again || (std::isnan(value) && std::isnan(again))) << name;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, MetricProperty, ::testing::Range(0, 32));

}  // namespace
}  // namespace turbid
