// The speed paths stream rows instead of building whole images (docs/performance-enhancer.md);
// each must give what the whole-image path gives.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "enhancer/deconvolution.h"
#include "enhancer/paper_methods.h"
#include "scenes/builtin.h"
#include "scenes/error.h"
#include "simulator/psf.h"
#include "simulator/render.h"

namespace turbid {
namespace {

TEST(StreamedPaths, DeconvolveRowsEqualsDeconvolveAndDirectFilter) {
  cv::Mat img(61, 83, CV_32F);
  cv::RNG(5).fill(img, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
  const cv::Mat psf = PsfKernel(PsfOptions{}).kernel;
  ASSERT_GT(psf.rows, 1);
  DeconvolutionOptions o;
  cv::Mat rows(img.size(), CV_32F);
  int next = 0;
  ASSERT_TRUE(DeconvolveRows(o, img, psf, [&](int y, const float* row) {
    EXPECT_EQ(y, next++);
    std::copy(row, row + img.cols, rows.ptr<float>(y));
  }));
  EXPECT_EQ(next, img.rows);
  EXPECT_EQ(cv::norm(rows, Deconvolve(o, img, psf), cv::NORM_INF), 0.0);
  // Independent reference: the inverse kernel applied directly (2-D correlation, mirrored
  // borders); the separable sum keeps 1 - 1e-7 of the kernel's energy.
  cv::Mat ref;
  cv::filter2D(img, ref, CV_32F, WienerInverseKernel(psf, o.nsr), cv::Point(-1, -1), 0,
               cv::BORDER_REFLECT_101);
  EXPECT_LE(cv::norm(rows, ref, cv::NORM_INF), 1e-4);
  // Paths that are not streamed say so and emit nothing.
  o.spatial_max_radius = 0;
  EXPECT_FALSE(DeconvolveRows(o, img, psf, [](int, const float*) { ADD_FAILURE(); }));
  EXPECT_THROW(
      DeconvolveRows(o, cv::Mat(4, 4, CV_32FC3, cv::Scalar::all(0)), psf, [](int, const float*) {}),
      Error);
}

TEST(StreamedPaths, FullEnhanceEqualsDetailedImage) {
  // FullEnhance skips the inspection intermediates (in-place dehaze, deblur rows straight into
  // CLAHE); its output must be the detailed pipeline's, bit for bit, gray and colour.
  BuiltinSceneOptions so;
  so.scale = 0.15;
  Scene scene = MakeBuiltinScene("hull", so);
  for (bool color : {false, true}) {
    if (color) {
      cv::merge(std::vector<cv::Mat>{scene.image * 0.8, scene.image * 0.95, scene.image},
                scene.image);
    }
    RenderOptions ro;
    ro.seed = 3;
    const RenderResult r = Render(ro, scene);
    for (bool contrast : {true, false}) {
      FullOptions o;
      o.contrast = contrast;
      const cv::Mat fast = FullEnhance(o, r.image, &scene, &r.sidecar);
      const FullResult slow = FullEnhanceDetailed(o, r.image, &scene, &r.sidecar);
      EXPECT_EQ(cv::norm(fast, slow.image, cv::NORM_INF), 0.0) << color << contrast;
      EXPECT_FALSE(slow.range_m.empty());
      bool deblurred = false;  // the streamed deblur path ran
      for (const std::string& step : slow.steps) deblurred |= step.rfind("deblur: wiener", 0) == 0;
      EXPECT_TRUE(deblurred);
    }
  }
}

}  // namespace
}  // namespace turbid
