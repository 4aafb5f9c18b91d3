// CLAHE, deconvolution and plane fit, each against an independent reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/deconvolution.h"
#include "enhancer/blocks/plane_fit.h"
#include "core/error.h"
#include "simulator/psf.h"

namespace turbid {
namespace {

double Psnr(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d = a - b;
  const double mse = cv::mean(d.mul(d))[0];
  return 10.0 * std::log10(1.0 / std::max(mse, 1e-20));
}

TEST(Clahe, DefaultsPassCheckAndNamesRoundTrip) {
  std::string why;
  EXPECT_TRUE(ClaheOptions{}.Check(&why)) << why;
  for (const char* n : {"uniform", "rayleigh", "exponential"}) {
    EXPECT_EQ(ClaheDistributionName(ClaheDistributionFromName(n)), n);
  }
  EXPECT_THROW(ClaheDistributionFromName("gauss"), Error);
  ClaheOptions bad;
  bad.clip_limit = 1.5;
  EXPECT_FALSE(bad.Check(&why));
}

TEST(Clahe, UnclippedUniformMappingIsTheCdf) {
  // clip 1: no clipping (plain AHE); the uniform target maps each bin to the CDF.
  ClaheOptions o;
  o.clip_limit = 1.0;
  o.bins = 4;
  o.distribution = ClaheDistribution::kUniform;
  const std::vector<float> m = ClaheMapHistogram(o, {10, 0, 30, 60}, 100);
  EXPECT_FLOAT_EQ(m[0], 0.1f);
  EXPECT_FLOAT_EQ(m[1], 0.1f);
  EXPECT_FLOAT_EQ(m[2], 0.4f);
  EXPECT_FLOAT_EQ(m[3], 1.0f);
}

TEST(Clahe, ClipLimitFollowsAdapthisteq) {
  // P = 100, bins 4: minClip = 25, clip = 25 + round(0.2 * 75) = 40. Histogram {0, 0, 0, 100}:
  // excess 60, even share 15 per bin -> {15, 15, 15, 40}, leftover 15 handed out one at a time
  // (stride max(floor(4/15), 1) = 1) to bins below the limit, each sweep starting one bin later
  // (adapthisteq's k = k + 1): +3, +5, +7 -> {18, 20, 22, 40}.
  ClaheOptions o;
  o.clip_limit = 0.2;
  o.bins = 4;
  o.distribution = ClaheDistribution::kUniform;
  const std::vector<float> m = ClaheMapHistogram(o, {0, 0, 0, 100}, 100);
  EXPECT_FLOAT_EQ(m[0], 0.18f);
  EXPECT_FLOAT_EQ(m[1], 0.38f);
  EXPECT_FLOAT_EQ(m[2], 0.60f);
  EXPECT_FLOAT_EQ(m[3], 1.0f);
}

TEST(Clahe, RayleighMappingClosedForm) {
  // Rayleigh target: sqrt(-2 a^2 ln(1 - vmax F)), vmax = 1 - exp(-1 / (2 a^2)).
  ClaheOptions o;
  o.clip_limit = 1.0;
  o.bins = 2;
  const std::vector<float> m = ClaheMapHistogram(o, {50, 50}, 100);
  const double a = 0.4, h = 2 * a * a, vmax = 1 - std::exp(-1 / h);
  EXPECT_NEAR(m[0], std::sqrt(-h * std::log(1 - vmax * 0.5)), 1e-6);
  EXPECT_NEAR(m[1], 1.0, 1e-6);
  o.distribution = ClaheDistribution::kExponential;
  const std::vector<float> e = ClaheMapHistogram(o, {50, 50}, 100);
  EXPECT_NEAR(e[0], -std::log(1 - (1 - std::exp(-a)) * 0.5) / a, 1e-6);
}

// keep_mean: a dark textured image (mean ~0.15, 64x64 so the 8x8 tiles need no padding). The
// reference mapped mean is computed here from ClaheTileMappings with the alpha the equalisation
// reports (each pixel through its own tile's mapping), independent of the solver's fraction grid.
TEST(Clahe, KeepMeanChoosesTheAlphaThatKeepsTheMean) {
  cv::Mat g(64, 64, CV_32F);
  cv::RNG rng(5);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      g.at<float>(y, x) = static_cast<float>(0.05 + 0.002 * x + 0.001 * y + rng.uniform(0.0, 0.04));
  double binned = 0.0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) binned += std::round(g.at<float>(y, x) * 255.0) / 255.0;
  binned /= g.total();
  auto mapped_mean = [&](const ClaheOptions& o) {
    const cv::Mat maps = ClaheTileMappings(o, g);
    double sum = 0.0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const int b = static_cast<int>(std::round(g.at<float>(y, x) * 255.0));
        sum += maps.at<float>((y / 8) * 8 + x / 8, b);
      }
    return sum / g.total();
  };
  for (ClaheDistribution dist : {ClaheDistribution::kRayleigh, ClaheDistribution::kExponential}) {
    ClaheOptions o;
    o.distribution = dist;
    ClaheStats fixed;
    const cv::Mat out_fixed = Clahe(o, g, &fixed);
    EXPECT_DOUBLE_EQ(fixed.alpha, 0.4);
    EXPECT_NEAR(fixed.input_mean, binned, 1e-12);
    EXPECT_NEAR(fixed.mapped_mean, mapped_mean(o), 1e-6);
    o.keep_mean = true;
    ClaheStats kept;
    const cv::Mat out = Clahe(o, g, &kept);
    EXPECT_NEAR(kept.input_mean, binned, 1e-12);
    EXPECT_NEAR(kept.mapped_mean, binned, 1e-6) << ClaheDistributionName(dist);
    ClaheOptions check = o;
    check.keep_mean = false;
    check.alpha = kept.alpha;
    EXPECT_NEAR(mapped_mean(check), binned, 1e-3) << ClaheDistributionName(dist);
    // The image itself (bilinear blend between tiles) keeps its mean within 0.01; the fixed
    // target lifts it by more than 0.1, so the check can fail.
    EXPECT_NEAR(cv::mean(out)[0], binned, 0.01) << ClaheDistributionName(dist);
    if (dist == ClaheDistribution::kRayleigh) {
      EXPECT_GT(cv::mean(out_fixed)[0] - binned, 0.1);
    }
  }
  // The floor: an image darker than min_mean is brought up to it.
  ClaheOptions floor;
  floor.keep_mean = true;
  floor.min_mean = 0.3;
  ClaheStats lifted;
  const cv::Mat up = Clahe(floor, g, &lifted);
  EXPECT_DOUBLE_EQ(lifted.target_mean, 0.3);
  EXPECT_NEAR(lifted.mapped_mean, 0.3, 1e-6);
  EXPECT_NEAR(cv::mean(up)[0], 0.3, 0.01);
  floor.min_mean = 0.7;
  std::string why;
  EXPECT_FALSE(floor.Check(&why));
  // The uniform target has no parameter: keep_mean changes nothing.
  ClaheOptions u;
  u.distribution = ClaheDistribution::kUniform;
  const cv::Mat a = Clahe(u, g);
  u.keep_mean = true;
  ClaheStats su;
  const cv::Mat b = Clahe(u, g, &su);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_EQ(su.alpha, 0.0);
}

TEST(Clahe, ConstantImageAndPaddingAndInterpolation) {
  // A constant image: every tile has one full bin; output is the mapping of that bin everywhere.
  ClaheOptions o;
  o.distribution = ClaheDistribution::kUniform;
  cv::Mat c(37, 53, CV_32F, cv::Scalar(0.5));  // not divisible by 8: padded
  cv::Mat out = Clahe(o, c);
  double lo, hi;
  cv::minMaxLoc(out, &lo, &hi);
  EXPECT_NEAR(lo, hi, 1e-6);
  // Tiles are independent: a left/right split image gives different mappings left and right,
  // and the output varies smoothly (bilinear) across the tile boundary, monotone in x.
  cv::Mat ramp(64, 64, CV_32F);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) ramp.at<float>(y, x) = (x < 32 ? 0.2f : 0.6f) + 0.001f * (y % 8);
  cv::Mat r = Clahe(o, ramp);
  EXPECT_EQ(r.size(), ramp.size());
  EXPECT_TRUE(cv::checkRange(r, true, nullptr, 0.0, 1.0 + 1e-6));
  const cv::Mat maps = ClaheTileMappings(o, ramp);
  EXPECT_EQ(maps.rows, 64);
  EXPECT_EQ(maps.cols, 256);
}

TEST(Clahe, OutputIsBilinearBlendOfTileMappings) {
  // Independent reference of the interpolation (adapthisteq makeClaheImage): with tiles of even
  // size and no padding (96 x 64, 8 x 8 tiles of 12 x 8), pixel i lies between tile centres
  // floor(t) and floor(t) + 1 with t = (i - tile/2) / tile, clamped to the outer tiles; the
  // output blends the four tile mappings of its bin bilinearly.
  cv::Mat img(64, 96, CV_32F);
  cv::RNG(3).fill(img, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 2.0);
  img = img * 2.0 - 0.5;  // values outside [0, 1] too: clamped for binning
  for (ClaheDistribution d : {ClaheDistribution::kUniform, ClaheDistribution::kRayleigh}) {
    ClaheOptions o;
    o.distribution = d;
    const cv::Mat maps = ClaheTileMappings(o, img);
    const cv::Mat out = Clahe(o, img);
    auto neighbours = [](int i, int tile, int tiles, int* lo, int* hi, double* w) {
      const double t = (i - tile / 2.0) / tile;
      const int f = static_cast<int>(std::floor(t));
      *lo = std::clamp(f, 0, tiles - 1);
      *hi = std::clamp(f + 1, 0, tiles - 1);
      *w = (f < 0 || f >= tiles - 1) ? 0.0 : t - f;
    };
    double worst = 0.0;
    for (int y = 0; y < img.rows; ++y) {
      for (int x = 0; x < img.cols; ++x) {
        const double v = std::clamp(static_cast<double>(img.at<float>(y, x)), 0.0, 1.0);
        const int bin = static_cast<int>(std::lround(v * 255.0));
        int y0, y1, x0, x1;
        double wy, wx;
        neighbours(y, 8, 8, &y0, &y1, &wy);
        neighbours(x, 12, 8, &x0, &x1, &wx);
        auto m = [&](int ty, int tx) { return maps.at<float>(ty * 8 + tx, bin); };
        const double ref = (1 - wy) * ((1 - wx) * m(y0, x0) + wx * m(y0, x1)) +
                           wy * ((1 - wx) * m(y1, x0) + wx * m(y1, x1));
        worst = std::max(worst, std::fabs(out.at<float>(y, x) - ref));
      }
    }
    EXPECT_LE(worst, 1e-6);
  }
}

TEST(Clahe, RowByRowBinsEqualWholeImage) {
  cv::Mat img(37, 53, CV_32F);  // padded sizes
  cv::RNG(4).fill(img, cv::RNG::UNIFORM, -0.2, 1.2);
  for (int bins : {256, 1024}) {
    ClaheOptions o;
    o.bins = bins;
    cv::Mat b = ClaheNewBins(o, img.size());
    for (int y = 0; y < img.rows; ++y) ClaheBinRow(o, img.ptr<float>(y), b, y);
    EXPECT_EQ(cv::norm(ClaheFromBins(o, b), Clahe(o, img), cv::NORM_INF), 0.0) << bins;
  }
  ClaheOptions o;
  cv::Mat b = ClaheNewBins(o, cv::Size(40, 1));
  std::vector<float> bad(40, 0.1f);
  bad[5] = std::numeric_limits<float>::infinity();  // inside the first 32-pixel vector block
  EXPECT_THROW(ClaheBinRow(o, bad.data(), b, 0), Error);
  bad[5] = 0.1f;
  bad[37] = std::numeric_limits<float>::quiet_NaN();  // in the scalar tail
  EXPECT_THROW(ClaheBinRow(o, bad.data(), b, 0), Error);
  o.bins = 1024;
  EXPECT_THROW(ClaheFromBins(o, b), Error);  // 8-bit bins for 1024-bin options
}

TEST(Clahe, GrayAndColourTinyAndExtremeImagesFinite) {
  ClaheOptions o;
  for (cv::Size s : {cv::Size(1, 1), cv::Size(3, 3), cv::Size(17, 5)}) {
    for (double v : {0.0, 1.0, 0.3}) {
      cv::Mat g(s, CV_32F, cv::Scalar(v)), c(s, CV_32FC3, cv::Scalar(v, v * 0.5, 1 - v));
      EXPECT_TRUE(cv::checkRange(Clahe(o, g), true, nullptr, 0.0, 1.0 + 1e-6));
      EXPECT_TRUE(cv::checkRange(Clahe(o, c), true, nullptr, 0.0, 1.0 + 1e-6));
    }
  }
  EXPECT_THROW(Clahe(o, cv::Mat()), Error);
  cv::Mat nan(4, 4, CV_32F, cv::Scalar(std::nan("")));
  EXPECT_THROW(Clahe(o, nan), Error);
}

cv::Mat TestPattern(int rows, int cols) {
  cv::Mat m(rows, cols, CV_32F, cv::Scalar(0.2));
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      if (((x / 8) + (y / 8)) % 2 == 0) m.at<float>(y, x) = 0.8f;
    }
  cv::circle(m, cv::Point(cols / 2, rows / 2), rows / 5, cv::Scalar(0.5), -1);
  return m;
}

TEST(Deconvolution, WienerAndRichardsonLucyRecoverBlurredPattern) {
  // Band-limited pattern (checkerboard and disc, pre-smoothed sigma 1 px) so the blur is
  // invertible at the frequencies it holds.
  cv::Mat sharp;
  cv::GaussianBlur(TestPattern(96, 128), sharp, cv::Size(0, 0), 1.0);
  PsfOptions p;  // paper T 4, q 0.9 but wider: sigma scaled x3 so the blur matters
  const Psf psf = PsfKernel(p, 3.0);
  const cv::Mat blurred = ConvolveMirrored(sharp, psf.kernel);
  const double before = Psnr(blurred, sharp);
  DeconvolutionOptions w;
  w.nsr = 1e-4;
  w.spatial_max_radius = 0;  // FFT path
  const cv::Mat wf = Deconvolve(w, blurred, psf.kernel);
  EXPECT_GT(Psnr(wf, sharp), before + 10.0) << "before " << before;
  EXPECT_GT(Psnr(wf, sharp), 30.0);
  // Spatial separable Wiener agrees with the FFT Wiener.
  w.spatial_max_radius = 64;
  const cv::Mat ws = Deconvolve(w, blurred, psf.kernel);
  EXPECT_GT(Psnr(ws, sharp), 30.0);
  DeconvolutionOptions rl;
  rl.method = DeconvolutionMethod::kRichardsonLucy;
  rl.iterations = 50;
  const cv::Mat r = Deconvolve(rl, blurred, psf.kernel);
  EXPECT_GT(Psnr(r, sharp), before + 3.0) << Psnr(r, sharp);
}

TEST(Deconvolution, DeltaIsIdentityAndBadPsfThrows) {
  const cv::Mat img = TestPattern(16, 16);
  cv::Mat one(1, 1, CV_32F, cv::Scalar(1));
  cv::Mat out = Deconvolve(DeconvolutionOptions{}, img, one);
  EXPECT_EQ(cv::norm(out, img, cv::NORM_INF), 0.0);
  EXPECT_THROW(Deconvolve(DeconvolutionOptions{}, img, cv::Mat(2, 2, CV_32F, cv::Scalar(0.25))),
               Error);
  std::string why;
  EXPECT_TRUE(DeconvolutionOptions{}.Check(&why)) << why;
}

TEST(PlaneFit, ThreePointsExactAndLeastSquares) {
  const Plane truth{cv::normalize(cv::Vec3d(0.1, -0.3, -1.0)), 2.5};
  std::vector<cv::Vec3d> pts;
  for (double x : {-0.5, 0.4, 0.1, -0.2})
    for (double y : {-0.3, 0.2}) {
      // Point on the plane along ray (x, y, 1).
      const cv::Vec3d ray(x, y, 1);
      pts.push_back(ray * (-truth.offset_m / truth.normal.dot(ray)));
    }
  const Plane p3 = FitPlaneToPoints({pts[0], pts[3], pts[5]});
  EXPECT_NEAR(cv::norm(p3.normal - truth.normal), 0, 1e-9);
  EXPECT_NEAR(p3.offset_m, truth.offset_m, 1e-9);
  const Plane pn = FitPlaneToPoints(pts);
  EXPECT_NEAR(cv::norm(pn.normal - truth.normal), 0, 1e-9);
  EXPECT_THROW(FitPlaneToPoints({pts[0], pts[1]}), Error);
  EXPECT_THROW(FitPlaneToPoints({{0, 0, 1}, {0, 0, 2}, {0, 0, 3}}), Error);
}

TEST(PlaneFit, RansacFromDepthIgnoresOutliers) {
  CameraIntrinsics cam{100, 100, 39.5, 29.5, 80, 60};
  const Plane truth{cv::normalize(cv::Vec3d(0.2, 0.1, -1.0)), 3.0};
  cv::Mat depth = DepthFromPlane(truth, cam);
  // 30 % outliers: a box sticking out.
  depth(cv::Rect(0, 0, 40, 27)).setTo(1.0);
  PlaneFitOptions o;
  o.stride_px = 2;
  const PlaneFitResult r = FitPlaneToDepth(o, cam, depth);
  EXPECT_NEAR(cv::norm(r.plane.normal - truth.normal), 0, 1e-4);
  EXPECT_NEAR(r.plane.offset_m, truth.offset_m, 1e-3);
  cv::Mat nan(10, 10, CV_32F, cv::Scalar(std::nan("")));
  EXPECT_THROW(FitPlaneToDepth(o, cam, nan), Error);
}

}  // namespace
}  // namespace turbid
