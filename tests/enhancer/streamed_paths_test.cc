// The speed paths stream rows instead of building whole images (docs/performance-enhancer.md);
// each must give what the whole-image path gives.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "enhancer/clahe.h"
#include "enhancer/deconvolution.h"
#include "enhancer/guided_filter.h"
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
      DeconvolveRows(o, cv::Mat(4, 4, CV_32FC2, cv::Scalar::all(0)), psf, [](int, const float*) {}),
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

TEST(StreamedPaths, SimplifiedGrayEqualsWholeImagePipeline) {
  // The one-channel path streams both guided filters into the boost and CLAHE's binning; it must
  // give the whole-image pipeline (eq. 9, clamp, CLAHE) bit for bit.
  cv::Mat img(83, 101, CV_32F);
  cv::RNG(9).fill(img, cv::RNG::UNIFORM, 0.05, 0.9);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 1.2);
  for (bool contrast : {true, false}) {
    SimplifiedOptions o;
    o.contrast = contrast;
    GuidedFilterOptions f, g;
    f.radius = o.fine_radius, f.eps = o.fine_eps;
    g.radius = o.coarse_radius, g.eps = o.coarse_eps;
    const cv::Mat i_f = GuidedFilter(f, img, img), i_g = GuidedFilter(g, img, img);
    const float a = static_cast<float>(o.alpha), one_minus_a = static_cast<float>(1.0 - o.alpha);
    cv::Mat expect(img.size(), CV_32F);
    for (int y = 0; y < img.rows; ++y)
      for (int x = 0; x < img.cols; ++x) {
        const float v = i_g.at<float>(y, x) * one_minus_a + i_f.at<float>(y, x) * a;
        expect.at<float>(y, x) = std::min(std::max(v, 0.0f), 1.0f);
      }
    if (contrast) expect = Clahe(o.clahe, expect);
    EXPECT_EQ(cv::norm(SimplifiedEnhance(o, img), expect, cv::NORM_INF), 0.0) << contrast;
  }
}

TEST(StreamedPaths, SimplifiedGrayNamesTheRowOfANonFiniteInput) {
  // The streamed path does not scan the input first; a NaN or infinity anywhere must still be
  // reported as the up-front check reports it, with or without CLAHE and with the fast filter.
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  for (float value : bad)
    for (cv::Point at : {cv::Point(0, 0), cv::Point(48, 0), cv::Point(20, 17), cv::Point(48, 39),
                         cv::Point(0, 39)})
      for (int variant = 0; variant < 3; ++variant) {
        cv::Mat img(40, 49, CV_32F, cv::Scalar(0.4));
        img.at<float>(at) = value;
        SimplifiedOptions o;
        o.contrast = variant != 1;
        o.coarse_subsample = variant == 2 ? 2 : 1;
        try {
          SimplifiedEnhance(o, img);
          ADD_FAILURE() << value << " at " << at << " variant " << variant << " passed";
        } catch (const Error& e) {
          EXPECT_NE(
              std::string(e.what()).find("simplified: input image has non-finite values (row " +
                                         std::to_string(at.y) + ")"),
              std::string::npos)
              << e.what();
        }
      }
  // Finite extremes pass the check; the filters' own overflow is reported without a row.
  cv::Mat huge(40, 49, CV_32F, cv::Scalar(0.4));
  huge.at<float>(10, 10) = 3e38f;
  try {
    SimplifiedEnhance(SimplifiedOptions{}, huge);
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find("row"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace turbid
