// `full`'s blind light scale (EstimateLightScale) on a three-channel image with one-channel t and
// L, the default colour path: its sample columns, ratio kernel (float division, branch-free
// compaction), largest veil weight and normal-equation sums with the samples in the vector lanes
// (enhancer/paper/full_light.cc, branch full4), against a transcription in double of the
// method: every channel in its own pass, samples in grid order, the normal equations summed
// sample by sample as cv::Matx, the percentile by std::nth_element. The ratio bound is the same
// value; the fit, summed in another order, within 1e-5 relative (issue 29 item 6's rule).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <vector>

#include "enhancer/paper/full.h"
#include "tests/enhancer/veil_fit_reference.h"

namespace turbid {
namespace {

constexpr double kFitTolerance = 1e-5;  // relative

// EstimateLightScale for CV_32FC3 `img` and CV_32F `t`, `l` on the grid of `stride`.
std::vector<LightScaleEstimate> Reference(const cv::Mat& img, const cv::Mat& l, const cv::Mat& t,
                                          double percentile, double support, int stride) {
  std::vector<LightScaleEstimate> out(3);
  float w_max = 0.0f;
  for (int y = 0; y < img.rows; y += stride) {
    for (int x = 0; x < img.cols; x += stride) {
      w_max = std::max(w_max, (1.0f - t.at<float>(y, x)) * l.at<float>(y, x));
    }
  }
  if (!(w_max > 0.0f) || !std::isfinite(w_max)) return out;
  const float w_min = static_cast<float>(support) * w_max;
  for (int c = 0; c < 3; ++c) {
    std::vector<float> ratios;
    std::vector<cv::Vec4d> samples;
    for (int y = 0; y < img.rows; y += stride) {
      for (int x = 0; x < img.cols; x += stride) {
        const double ti = t.at<float>(y, x), li = l.at<float>(y, x);
        const double v = img.at<cv::Vec3f>(y, x)[c];
        const float w = static_cast<float>((1.0 - ti) * li);
        if (!std::isfinite(v) || !std::isfinite(li)) continue;
        if (w >= w_min) ratios.push_back(static_cast<float>(std::max(v, 0.0) / w));
        samples.push_back(cv::Vec4d(ti, (1.0 - ti) * li, ti * li, v));
      }
    }
    if (ratios.empty()) continue;
    const size_t k = static_cast<size_t>(std::floor(percentile / 100.0 * (ratios.size() - 1)));
    std::nth_element(ratios.begin(), ratios.begin() + static_cast<std::ptrdiff_t>(k), ratios.end());
    ReferenceChooseLightScale(samples, std::max(0.0, static_cast<double>(ratios[k])), &out[c]);
  }
  return out;
}

// An image of the veil model I = a (1 - t) L + t L rho + t J plus noise (`physical`: the fit is
// usable), else uniform noise; t in [0.1, 1], L in [0, 2].
void Inputs(cv::Size size, int seed, bool physical, cv::Mat* img, cv::Mat* t, cv::Mat* l) {
  cv::RNG rng(seed);
  *img = cv::Mat(size, CV_32FC3), *t = cv::Mat(size, CV_32F), *l = cv::Mat(size, CV_32F);
  rng.fill(*t, cv::RNG::UNIFORM, 0.1, 1.0);
  rng.fill(*l, cv::RNG::UNIFORM, 0.0, 2.0);
  rng.fill(*img, cv::RNG::UNIFORM, -0.1, 1.0);
  if (!physical) return;
  const double a[3] = {0.8, 0.6, 0.45}, rho[3] = {0.3, 0.2, 0.1};
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const double ti = t->at<float>(y, x), li = l->at<float>(y, x);
      cv::Vec3f& v = img->at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        v[c] = static_cast<float>(a[c] * (1 - ti) * li + ti * li * rho[c] + ti * 0.2 * v[c] +
                                  rng.gaussian(0.01));
      }
    }
  }
}

TEST(FullLightScale, SharedColumnsEqualTheDoubleTranscription) {
  double worst = 0.0;  // the largest relative difference of a fit
  int fits = 0, compared = 0;
  const cv::Size sizes[] = {{1, 1}, {3, 2}, {9, 7}, {37, 23}, {130, 97}, {401, 203}};
  for (const cv::Size& size : sizes) {
    for (int stride : {1, 2, 3, 5}) {
      for (int physical = 0; physical < 2; ++physical) {
        for (int damage = 0; damage < 5; ++damage) {
          cv::Mat img, t, l;
          Inputs(size, size.area() + 31 * stride + 7 * damage + physical, physical == 1, &img, &t,
                 &l);
          const int y = (size.height / 2) / stride * stride, x = (size.width / 2) / stride * stride;
          const float nan = std::numeric_limits<float>::quiet_NaN();
          if (damage == 1) l.at<float>(y, x) = nan;           // a grid pixel without light
          if (damage == 2) img.at<cv::Vec3f>(y, x)[1] = nan;  // a lit value not finite
          if (damage == 3) l.at<float>(0, 0) = std::numeric_limits<float>::infinity();
          if (damage == 4) img.at<cv::Vec3f>(y, x)[0] = -0.0f, l.at<float>(y, x) = 1e-30f;
          for (double support : {0.0, 0.25, 0.9}) {
            for (double pct : {1.0, 50.0}) {
              const auto got = EstimateLightScale(img, l, t, pct, support, stride);
              const auto want = Reference(img, l, t, pct, support, stride);
              ASSERT_EQ(got.size(), 3u);
              for (int c = 0; c < 3; ++c) {
                const std::string where =
                    std::to_string(size.width) + "x" + std::to_string(size.height) + " stride " +
                    std::to_string(stride) + " physical " + std::to_string(physical) + " damage " +
                    std::to_string(damage) + " support " + std::to_string(support) + " pct " +
                    std::to_string(pct) + " c " + std::to_string(c);
                EXPECT_EQ(got[c].bound, want[c].bound) << where;
                EXPECT_EQ(got[c].source, want[c].source) << where;
                EXPECT_NEAR(got[c].fit, want[c].fit, kFitTolerance * std::abs(want[c].fit))
                    << where;
                EXPECT_NEAR(got[c].scale, want[c].scale, kFitTolerance * std::abs(want[c].scale))
                    << where;
                ++compared;
                if (want[c].fit != 0.0) {
                  ++fits;
                  worst = std::max(worst, std::abs(got[c].fit / want[c].fit - 1.0));
                }
              }
            }
          }
        }
      }
    }
  }
  EXPECT_GT(fits, 100);  // the fit's kernels ran, not only the bound's
  std::printf("%d estimates compared, %d with a usable fit; largest relative fit difference %.3g\n",
              compared, fits, worst);
}

}  // namespace
}  // namespace turbid
