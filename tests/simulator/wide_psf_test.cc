// PSF kernels wider than the image (2R + 1 > width or height): every convolution by the PSF keeps
// the border rule it uses for small kernels (BORDER_REFLECT_101, reflections repeated as often as
// the kernel needs) and stays finite, at every image size from 1x1 up. Reference: a direct gather
// with cv::borderInterpolate, which reflects any offset into the image.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "simulator/psf.h"
#include "simulator/render.h"
#include "tests/simulator/test_scenes.h"

namespace turbid {
namespace {

// out(x) = sum_u k(u) J(x + u), reflect-101 at any distance from the image.
cv::Mat DirectConvolution(const cv::Mat& image, const cv::Mat& kernel) {
  const int ch = image.channels(), ry = kernel.rows / 2, rx = kernel.cols / 2;
  cv::Mat out(image.size(), image.type());
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x)
      for (int c = 0; c < ch; ++c) {
        double sum = 0.0;
        for (int j = -ry; j <= ry; ++j)
          for (int i = -rx; i <= rx; ++i) {
            const int yy = cv::borderInterpolate(y + j, image.rows, cv::BORDER_REFLECT_101);
            const int xx = cv::borderInterpolate(x + i, image.cols, cv::BORDER_REFLECT_101);
            sum += kernel.at<float>(j + ry, i + rx) * image.ptr<float>(yy)[xx * ch + c];
          }
        out.ptr<float>(y)[x * ch + c] = static_cast<float>(sum);
      }
  return out;
}

cv::Mat RandomImage(int width, int height, int channels, int seed) {
  cv::Mat m(height, width, CV_32FC(channels));
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0.0, 1.0);
  return m;
}

bool AllFinite(const cv::Mat& m) { return !m.empty() && cv::checkRange(m); }

// A wide kernel: sigma = 0.5 / sqrt(q) pixels. Gaussian (p = 2, separable) or non-separable
// (T = 1, p = 1). `radius_px` about 20 (the case: 41 wide on a 32x24 image) or 10.
PsfOptions Wide(bool separable, int radius_px = 20) {
  PsfOptions o;
  o.optical_thickness = separable ? 4.0 : 1.0;
  if (radius_px == 20)
    o.forward_scatter = separable ? 0.01 : 0.05;
  else
    o.forward_scatter = separable ? 0.05 : 0.2;
  return o;
}

// Every side from 1 to 7, then around the kernel's radius and width 2R + 1.
std::vector<int> Sides(int radius) {
  std::vector<int> sides = {1, 2, 3, 4, 5, 6, 7};
  for (int s : {radius, 2 * radius, 2 * radius + 1, 2 * radius + 3})
    if (s > 7) sides.push_back(s);
  return sides;
}

TEST(WidePsf, ApplyPsfEqualsTheDirectConvolutionAtEverySize) {
  for (const bool separable : {true, false}) {
    const Psf psf = PsfKernel(Wide(separable, 10));
    ASSERT_GT(psf.radius_px, 7);
    ASSERT_EQ(psf.separable, separable);
    for (const int h : Sides(psf.radius_px))
      for (const int w : Sides(psf.radius_px)) {
        const cv::Mat image = RandomImage(w, h, 3, w * 100 + h);
        const cv::Mat out = ApplyPsf(psf, image);
        ASSERT_TRUE(AllFinite(out)) << w << "x" << h;
        EXPECT_LE(cv::norm(out, DirectConvolution(image, psf.kernel), cv::NORM_INF), 2e-5)
            << w << "x" << h << (separable ? " separable" : " general");
      }
  }
}

TEST(WidePsf, RenderBlursTinyImagesLikeTheDirectConvolution) {
  // beta = 0, no light, noise or snow: the image is J * h, for the separable (row-streamed or
  // whole-image) path and the general kernel, at every size up to past the kernel's width.
  for (const bool separable : {true, false}) {
    RenderOptions o;
    o.water.beta_rgb_per_m = {0, 0, 0};
    o.water.beta_gray_per_m = 0;
    o.water.ambient_rgb = {1, 1, 1};
    o.water.ambient_gray = 1;
    o.light.lights.clear();
    o.snow.enabled = false;
    o.sensor.enabled = false;
    o.camera.bit_depth = 32;
    o.psf = Wide(separable);
    const Psf psf = PsfKernel(o.psf);
    for (const int h : Sides(psf.radius_px))
      for (const int w : Sides(psf.radius_px)) {
        const Scene scene = testing::MakePlaneScene(w, h, 2.0, 3, 50.0);
        const RenderResult r = Render(o, scene);
        ASSERT_TRUE(AllFinite(r.image)) << w << "x" << h;
        EXPECT_LE(cv::norm(r.image, DirectConvolution(r.lit, psf.kernel), cv::NORM_INF), 2e-5)
            << w << "x" << h << (separable ? " separable" : " general");
      }
  }
}

TEST(WidePsf, EveryPsfModeRendersTinyImagesFinite) {
  // Default water and light (veil, attenuation), snow and noise, with the wide kernel fixed,
  // depth-dependent and turbidity-dependent, 1x1 .. 9x9 and a few wider than tall.
  for (int mode = 0; mode < 3; ++mode) {
    RenderOptions o;
    o.psf = Wide(true);
    o.psf.depth_dependent = mode == 1;
    o.psf.turbidity_dependent = mode == 2;
    o.psf.max_radius_px = 96;
    o.psf.forward_scatter = 1e-4;  // sigma 50 px: R capped at 96, 193 wide
    std::vector<cv::Size> sizes;
    for (int s = 1; s <= 9; ++s) sizes.push_back({s, s});
    sizes.push_back({40, 1});
    sizes.push_back({1, 40});
    sizes.push_back({64, 3});
    for (const cv::Size& size : sizes) {
      const Scene scene = testing::MakePlaneScene(size.width, size.height, 3.0);
      const RenderResult r = Render(o, scene);
      EXPECT_TRUE(AllFinite(r.image)) << "mode " << mode << " " << size;
    }
  }
}

TEST(WidePsf, TurbidityDependentKernelsWiderThanTheImage) {
  PsfOptions o = Wide(true);
  o.turbidity_dependent = true;
  for (int h = 1; h <= 12; h += 1 + h / 4)
    for (int w = 1; w <= 12; w += 1 + w / 4) {
      const cv::Mat image = RandomImage(w, h, 3, 7 * w + h);
      cv::Mat thickness(h, w, CV_32FC3, cv::Scalar(0.5, 2.0, 6.0));  // three exact levels
      const TurbidityPsf plan = PlanTurbidityPsf(o, thickness);
      const cv::Mat out = ApplyTurbidityPsf(plan, image);
      ASSERT_TRUE(AllFinite(out)) << w << "x" << h;
      // Each channel has one level: its whole kernel by the direct convolution.
      std::vector<cv::Mat> in_planes, out_planes;
      cv::split(image, in_planes);
      cv::split(out, out_planes);
      for (int c = 0; c < 3; ++c) {
        const cv::Mat expected = DirectConvolution(in_planes[c], plan.LevelKernel(c));
        EXPECT_LE(cv::norm(out_planes[c], expected, cv::NORM_INF), 2e-5)
            << w << "x" << h << " channel " << c;
      }
    }
}

}  // namespace
}  // namespace turbid
