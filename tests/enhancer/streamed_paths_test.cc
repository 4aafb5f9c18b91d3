// The speed paths stream rows instead of building whole images (docs/performance-enhancer.md);
// each must give what the whole-image path gives.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/deconvolution.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/simplified.h"
#include "scenes/builtin.h"
#include "core/cpu.h"
#include "core/error.h"
#include "simulator/psf.h"
#include "simulator/render.h"

namespace turbid {
namespace {

// ApplySeparableKernel as it was before its vertical passes went strip by strip for all terms
// (the pre-optimisation implementation of commit be04b57, enhancer/deconvolution.cc
// ApplySeparableRowsFrom, as plain loops): per output row and SVD term, the vertical pass over
// the whole row, its mirrored border, then the horizontal pass added into the row (kernels wider
// than 25: each product added on its own).
cv::Mat ReferenceApplySeparable(const cv::Mat& image, const cv::Mat& kernel) {
  cv::Mat k64;
  kernel.convertTo(k64, CV_64F);
  cv::SVD svd(k64, cv::SVD::FULL_UV);
  const double total = cv::sum(svd.w.mul(svd.w))[0];
  const int kr = kernel.rows, kc = kernel.cols, ry = kr / 2, rx = kc / 2;
  std::vector<std::vector<float>> cols, rows;
  double captured = 0.0;
  for (int i = 0; i < svd.w.rows; ++i) {
    const double s = svd.w.at<double>(i);
    captured += s * s;
    std::vector<float> c(kr), r(kc);
    for (int j = 0; j < kr; ++j) c[j] = static_cast<float>(svd.u.at<double>(j, i) * std::sqrt(s));
    for (int j = 0; j < kc; ++j) r[j] = static_cast<float>(svd.vt.at<double>(i, j) * std::sqrt(s));
    cols.push_back(c);
    rows.push_back(r);
    if (captured >= (1.0 - 1e-7) * total) break;
  }
  auto reflect = [](int i, int n) {
    if (n == 1) return 0;
    const int period = 2 * n - 2;
    i %= period;
    if (i < 0) i += period;
    return i < n ? i : period - i;
  };
  const int h = image.rows, w = image.cols, c = image.channels(), n = w * c;
  cv::Mat out(image.size(), image.type());
  std::vector<float> ext(static_cast<size_t>(w + 2 * rx) * c);
  for (int y = 0; y < h; ++y) {
    float* acc = out.ptr<float>(y);
    std::fill(acc, acc + n, 0.0f);
    for (size_t t = 0; t < cols.size(); ++t) {
      float* mid = ext.data() + rx * c;
      for (int x = 0; x < n; ++x) {
        float s = cols[t][0] * image.ptr<float>(reflect(y - ry, h))[x];
        for (int j = 1; j < kr; ++j) s += cols[t][j] * image.ptr<float>(reflect(y + j - ry, h))[x];
        mid[x] = s;
      }
      for (int x = 0; x < w + 2 * rx; ++x) {
        if (x >= rx && x < w + rx) continue;
        for (int ch = 0; ch < c; ++ch) ext[x * c + ch] = mid[reflect(x - rx, w) * c + ch];
      }
      for (int x = 0; x < n; ++x) {
        if (kc <= 25) {
          float s = rows[t][0] * ext[x];
          for (int i = 1; i < kc; ++i) s += rows[t][i] * ext[x + c * i];
          acc[x] += s;
        } else {
          for (int i = 0; i < kc; ++i) acc[x] += rows[t][i] * ext[x + c * i];
        }
      }
    }
  }
  return out;
}

// Every bit equal (any NaN equals any NaN).
bool SameBits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int y = 0; y < a.rows; ++y) {
    const float* pa = a.ptr<float>(y);
    const float* pb = b.ptr<float>(y);
    for (int x = 0; x < a.cols * a.channels(); ++x) {
      if (std::isnan(pa[x]) && std::isnan(pb[x])) continue;
      if (std::memcmp(&pa[x], &pb[x], sizeof(float)) != 0) return false;
    }
  }
  return true;
}

TEST(StreamedPaths, SeparableKernelEqualsPreOptimisationImplementation) {
  // Bit for bit with the CPU level capped below FMA, within 1e-5 relative at the machine's level
  // (FMA; symmetric kernels also folded, their taps made exactly even). Kernels of rank 1 to 5 (2
  // to 4 terms share the strips) and of full rank (every term), 3 to 27 wide (27: the loops for
  // kernels wider than 25), the Wiener inverse of the default PSF; images smaller than the kernel,
  // odd sizes, rows shorter and longer than a strip (512 values) and not a multiple of it, gray and
  // colour.
  cv::RNG rng(11);
  std::vector<cv::Mat> kernels;
  for (int k : {3, 5, 9, 15, 27}) {
    for (int rank : {1, 2, 3, 4, 5}) {
      if (rank > k) continue;
      cv::Mat kernel(k, k, CV_32F, cv::Scalar(0));
      for (int t = 0; t < rank; ++t) {
        cv::Mat a(k, 1, CV_32F), b(1, k, CV_32F);
        rng.fill(a, cv::RNG::UNIFORM, -1.0, 1.0);
        rng.fill(b, cv::RNG::UNIFORM, -1.0, 1.0);
        kernel += a * b;
      }
      kernels.push_back(kernel);
    }
    cv::Mat full(k, k, CV_32F);
    rng.fill(full, cv::RNG::UNIFORM, -1.0, 1.0);
    kernels.push_back(full);
  }
  // Symmetric kernels (every SVD term even: the folded even-tap kernels at the FMA level), of
  // rank 1 to 3, 5 to 15 wide, and one with an odd term (a mirror-antisymmetric part: the
  // general kernels).
  for (int k : {5, 9, 15}) {
    for (int rank : {1, 2, 3}) {
      cv::Mat kernel(k, k, CV_32F, cv::Scalar(0));
      for (int t = 0; t < rank; ++t) {
        cv::Mat a(k, 1, CV_32F);
        rng.fill(a, cv::RNG::UNIFORM, -1.0, 1.0);
        for (int j = 0; j < k / 2; ++j) a.at<float>(k - 1 - j) = a.at<float>(j);
        kernel += a * a.t();
      }
      kernels.push_back(kernel);
    }
    cv::Mat odd(k, 1, CV_32F);
    rng.fill(odd, cv::RNG::UNIFORM, -1.0, 1.0);
    for (int j = 0; j <= k / 2; ++j) odd.at<float>(k - 1 - j) = -odd.at<float>(j);
    kernels.push_back(kernels.back() + 0.5 * odd * odd.t());
  }
  kernels.push_back(WienerInverseKernel(PsfKernel(PsfOptions{}).kernel, 1e-3));
  const std::vector<cv::Size> sizes = {{1, 1},   {3, 2},    {7, 5},     {23, 37},
                                       {83, 61}, {517, 19}, {1030, 13}, {171, 9}};
  int compared = 0;
  for (const cv::Mat& kernel : kernels) {
    for (const cv::Size& size : sizes) {
      for (int channels : {1, 3}) {
        cv::Mat img(size, CV_32FC(channels));
        rng.fill(img, cv::RNG::UNIFORM, -2.0, 2.0);
        const cv::Mat want = ReferenceApplySeparable(img, kernel);
        // Without FMA the same bits; with it (issue 29 item 6) within float rounding of the sums.
        SetCpuLevelCap(CpuLevel::kAvx2);
        const cv::Mat exact = ApplySeparableKernel(img, kernel);
        SetCpuLevelCap(CpuLevel::kAvx512);
        ASSERT_TRUE(SameBits(exact, want))
            << "kernel " << kernel.rows << " size " << size << " channels " << channels;
        const cv::Mat got = ApplySeparableKernel(img, kernel);
        // The fused kernels at 8 lanes (avx2+fma) and 16 (avx512): the same bits.
        SetCpuLevelCap(CpuLevel::kAvx2Fma);
        const cv::Mat narrow = ApplySeparableKernel(img, kernel);
        SetCpuLevelCap(CpuLevel::kAvx512);
        ASSERT_TRUE(SameBits(narrow, got))
            << "kernel " << kernel.rows << " size " << size << " channels " << channels;
        double scale = 1.0;
        cv::minMaxLoc(cv::abs(want), nullptr, &scale);
        ASSERT_LE(cv::norm(got, want, cv::NORM_INF), 1e-5 * std::max(1.0, scale))
            << "kernel " << kernel.rows << " size " << size << " channels " << channels;
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, static_cast<int>(kernels.size() * sizes.size() * 2));
}

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
