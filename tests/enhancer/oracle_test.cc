// The oracles (enhancer/oracle.h): oracle_exact reaches float precision on noise-free float
// renders (one PSF and the range-dependent one); the MMSE oracle is a ceiling on noisy 8-bit
// renders (PSNR and SSIM at least those of the input, simplified and clahe); masked open water is
// counted and does not ring into its neighbours.
#include "enhancer/oracle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "enhancer/registry.h"
#include "metrics/full_reference.h"
#include "metrics/ssim.h"
#include "scenes/builtin.h"
#include "scenes/error.h"
#include "simulator/psf.h"
#include "simulator/render.h"

namespace turbid {
namespace {

double MaxAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  double hi = 0;
  cv::minMaxLoc(d.reshape(1), nullptr, &hi);
  return hi;
}

double PsnrOf(const cv::Mat& reference, const cv::Mat& image) {
  return Psnr(PsnrOptions{}, reference, image);
}
double SsimOf(const cv::Mat& reference, const cv::Mat& image) {
  return Ssim(SsimOptions{}, reference, image).mean;
}

Scene Builtin(const std::string& name, double scale) {
  BuiltinSceneOptions so;
  so.scale = scale;
  return MakeBuiltinScene(name, so);
}

TEST(Oracle, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(OracleOptions{}.Check(&why)) << why;
  EXPECT_TRUE(OracleExactOptions{}.Check(&why)) << why;
  OracleOptions bad;
  bad.middle_radius = bad.coarse_radius;
  EXPECT_FALSE(bad.Check(&why));
}

TEST(Oracle, BothEntriesArePrivilegedAndSayWhatTheyRead) {
  for (const char* name : {"oracle", "oracle_exact"}) {
    const MethodInfo& info = FindMethod(name);
    EXPECT_TRUE(info.privileged) << name;
    EXPECT_TRUE(IsPrivileged(name, nlohmann::json::object())) << name;
    EXPECT_NE(info.inputs.find("sensor noise"), std::string::npos) << name;
    EXPECT_TRUE(info.needs_sidecar && info.needs_geometry) << name;
  }
}

TEST(Oracle, NeedsSceneAndSidecar) {
  cv::Mat img(8, 8, CV_32F, cv::Scalar(0.5));
  EXPECT_THROW(Enhance("oracle", {}, EnhanceInput{img, nullptr, nullptr}), Error);
  EXPECT_THROW(Enhance("oracle_exact", {}, EnhanceInput{img, nullptr, nullptr}), Error);
  EXPECT_THROW(Enhance("oracle", {{"coarse_radius", 1}}, EnhanceInput{img, nullptr, nullptr}),
               Error);
}

// The even-extension inverse undoes the reflect-101 blur the renderer applies, for the Gaussian
// (separable) kernel and a 2-D generalized-Gaussian one.
TEST(Oracle, DeconvolveReflect101InvertsApplyPsf) {
  cv::Mat img(37, 52, CV_32FC3);
  cv::randu(img, 0.0, 1.0);
  for (double thickness : {4.0, 2.0}) {
    PsfOptions o;
    o.optical_thickness = thickness;
    const Psf psf = PsfKernel(o);
    ASSERT_FALSE(psf.is_delta);
    const cv::Mat blurred = ApplyPsf(psf, img);
    EXPECT_GT(MaxAbsDiff(blurred, img), 0.05);
    const cv::Mat back = DeconvolveReflect101(blurred, psf.kernel, 0.0);
    EXPECT_LE(MaxAbsDiff(back, img), 1e-5) << "T = " << thickness;
  }
}

// Noise-free float renders: beta and the light keep t (E_A + E_L) away from 0 and I below the
// clipping point, so every step of the inverse is well conditioned and the error is float
// rounding. Snow stays on (re-rendered from the seed and subtracted).
RenderOptions NoiseFreeFloat(bool depth_dependent_psf, bool turbidity_psf = false) {
  RenderOptions o;
  o.psf.turbidity_dependent = turbidity_psf;
  o.sensor.enabled = false;
  o.camera.bit_depth = 32;
  o.water.beta_rgb_per_m = {0.5, 0.4, 0.3};
  o.water.beta_gray_per_m = 0.4;
  o.water.backscatter = true;
  o.psf.depth_dependent = depth_dependent_psf;
  o.light.lights[0].power = 2.0;  // keeps I below 1 (the default 8 saturates near the LED)
  return o;
}

TEST(Oracle, ExactInverseReachesFloatPrecisionOnNoiseFreeFloatRenders) {
  for (const char* name : {"hull", "seafloor", "room"}) {
    const Scene scene = Builtin(name, 0.125);
    double max_range = 0;
    cv::minMaxLoc(Renderer(scene).range_m(), nullptr, &max_range);
    for (int mode : {0, 1, 2}) {
      // 0: one PSF; 1: range-dependent width; 2: turbidity-dependent (T = beta r per pixel).
      const bool depth_dependent = mode == 1;
      RenderOptions options = NoiseFreeFloat(depth_dependent, mode == 2);
      // Widths sigma sqrt(r / r_max) <= sigma: wider kernels make the blur numerically singular
      // (the float rounding of the render, divided by the kernel's smallest frequency response,
      // exceeds 1e-5).
      options.psf.reference_range_m = max_range;
      const RenderResult r = Render(options, scene);
      double hi = 0;
      cv::minMaxLoc(r.image.reshape(1), nullptr, &hi);
      ASSERT_LT(hi, 1.0) << name << ": the render clips; the test needs an unclipped one";
      const OracleResult out = OracleExactEnhance(OracleExactOptions{}, r.image, scene, r.sidecar);
      EXPECT_EQ(out.masked_pixels, 0) << name;
      EXPECT_LE(MaxAbsDiff(out.image, scene.image), 1e-5)
          << name
          << (mode == 2 ? " turbidity-dependent PSF"
                        : (depth_dependent ? " range-dependent PSF" : " one PSF"))
          << ", " << out.iterations << " iterations, residual " << out.residual;
      if (mode > 0) {
        EXPECT_GT(out.iterations, 1) << name;
      }
      // The lit target returns J (unclipped here).
      OracleExactOptions lit;
      lit.target = "lit";
      EXPECT_LE(MaxAbsDiff(OracleExactEnhance(lit, r.image, scene, r.sidecar).image, r.lit), 1e-5)
          << name;
    }
  }
}

// The ceiling: on noisy 8-bit renders with every default degradation (snow, Poisson-Gaussian
// noise, PSF), the oracle's PSNR and SSIM are at least those of the input and of the blind
// methods simplified and clahe, and far above oracle_exact's where t is small.
TEST(Oracle, IsACeilingOnNoisy8BitRenders) {
  for (const char* name : {"hull", "seafloor", "room"}) {
    const Scene scene = Builtin(name, 0.25);
    for (double beta : {0.7, 1.5}) {
      RenderOptions o;
      o.water.beta_rgb_per_m = {beta, beta, beta};
      o.water.beta_gray_per_m = beta;
      o.seed = 7;
      const RenderResult r = Render(o, scene);
      EnhanceInput in{r.image, &scene, &r.sidecar};
      const cv::Mat oracle = Enhance("oracle", nlohmann::json::object(), in);
      const double psnr = PsnrOf(scene.image, oracle), ssim = SsimOf(scene.image, oracle);
      EXPECT_GE(psnr, PsnrOf(scene.image, r.image)) << name << " beta " << beta << ": input";
      EXPECT_GE(ssim, SsimOf(scene.image, r.image)) << name << " beta " << beta << ": input";
      for (const char* blind : {"simplified", "clahe"}) {
        const cv::Mat out = Enhance(blind, nlohmann::json::object(), in);
        EXPECT_GE(psnr, PsnrOf(scene.image, out)) << name << " beta " << beta << ": " << blind;
        EXPECT_GE(ssim, SsimOf(scene.image, out)) << name << " beta " << beta << ": " << blind;
      }
      const cv::Mat exact = Enhance("oracle_exact", nlohmann::json::object(), in);
      EXPECT_GT(psnr, PsnrOf(scene.image, exact)) << name << " beta " << beta;
    }
  }
}

// Open water (NaN depth) is masked: counted, filled with the prior mean, finite, and the pixels
// next to it are recovered about as well as the rest (no ringing from the masked values).
TEST(Oracle, MasksOpenWaterWithoutRinging) {
  Scene scene = Builtin("seafloor", 0.25);
  const cv::Rect hole(30, 20, 25, 18);
  scene.depth_m(hole).setTo(std::numeric_limits<float>::quiet_NaN());
  scene.normals.release();
  RenderOptions o;
  o.seed = 3;
  const RenderResult r = Render(o, scene);
  const OracleResult out = OracleEnhance(OracleOptions{}, r.image, scene, r.sidecar);
  EXPECT_EQ(out.masked_pixels, hole.area());
  ASSERT_TRUE(cv::checkRange(out.image));
  bool reported = false;
  for (const std::string& s : out.steps) reported = reported || s.rfind("masked: ", 0) == 0;
  EXPECT_TRUE(reported);
  cv::Mat hole_mask(scene.image.size(), CV_8U, cv::Scalar(0));
  hole_mask(hole).setTo(255);
  cv::Mat near;
  cv::dilate(hole_mask, near, cv::Mat::ones(7, 7, CV_8U));
  near &= ~hole_mask;  // a 3-pixel ring around the hole
  cv::Mat rest = ~near & ~hole_mask;
  cv::Mat err = out.image - scene.image;
  err = err.mul(err);
  const double ring = std::sqrt(cv::mean(err, near)[0]);
  const double elsewhere = std::sqrt(cv::mean(err, rest)[0]);
  EXPECT_LE(ring, 1.5 * elsewhere + 0.01) << "ring " << ring << " elsewhere " << elsewhere;
}

}  // namespace
}  // namespace turbid
