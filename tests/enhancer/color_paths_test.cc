// The colour paths of `full` and `simplified` are streamed (issue 18 item 1): interleaved guided
// filter and deconvolution rows, fused per-row steps, CLAHE binned as rows come. Each must give
// what the pre-optimisation implementation (commit 6722196) gives, bit for bit. The Reference*
// functions below are that implementation's colour code: every channel split into its own plane,
// filtered alone, merged back, with whole-image steps in between. Issue 29 item 6: the colour
// guided filter now sums its windows as running sums (enhancer/blocks/guided_segments.h), equal
// to the plane-by-plane filter within kFilterTolerance (and to a double-precision transcription,
// tests/enhancer/guided_segments_test.cc); the pipelines around it are still compared bit for
// bit, with that filter inside the reference.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/cpu.h"
#include "core/error.h"
#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/deconvolution.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/method.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/simplified.h"
#include "enhancer/paper/simplified_rows.h"
#include "enhancer/select.h"
#include "enhancer/simd_switch.h"
#include "tests/enhancer/veil_fit_reference.h"
#include "scenes/builtin.h"
#include "scenes/image_io.h"
#include "simulator/psf.h"
#include "simulator/render.h"
#include "tests/enhancer/color_reference.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

using color_reference::ReferenceNoiseSigma;
using color_reference::SameBits;

// ---- The pre-optimisation implementation (commit 6722196), colour parts.

void ReferenceClampUnit(cv::Mat& m) {
  cv::patchNaNs(m, 0.0);
  cv::min(m, 1.0, m);
  cv::max(m, 0.0, m);
}

// |colour filter - plane-by-plane filter| bound on [0, 1] data (issue 29: 1e-5 relative).
constexpr double kFilterTolerance = 1e-5;

cv::Mat ReferenceGuidedFilterSelf(const GuidedFilterOptions& o, const cv::Mat& image) {
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (cv::Mat& p : planes) p = GuidedFilter(o, p, p);
  cv::Mat out;
  cv::merge(planes, out);
  return out;
}

cv::Mat ReferenceDeconvolve(const DeconvolutionOptions& o, const cv::Mat& image,
                            const cv::Mat& psf) {
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (cv::Mat& p : planes) p = Deconvolve(o, p, psf);
  cv::Mat out;
  cv::merge(planes, out);
  return out;
}

// Clahe's colour branch: Rec. 709 luminance equalised, channels scaled by the ratio.
cv::Mat ReferenceClahe(const ClaheOptions& options, const cv::Mat& image) {
  cv::Mat lum(image.size(), CV_32F);
  for (int y = 0; y < image.rows; ++y) {
    const cv::Vec3f* s = image.ptr<cv::Vec3f>(y);
    float* l = lum.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      l[x] = 0.0722f * s[x][0] + 0.7152f * s[x][1] + 0.2126f * s[x][2];
    }
  }
  const cv::Mat eq = Clahe(options, lum);
  cv::Mat out(image.size(), CV_32FC3);
  for (int y = 0; y < image.rows; ++y) {
    const cv::Vec3f* s = image.ptr<cv::Vec3f>(y);
    const float* l = lum.ptr<float>(y);
    const float* e = eq.ptr<float>(y);
    cv::Vec3f* d = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.cols; ++x) {
      if (l[x] <= 1e-6f) {
        d[x] = cv::Vec3f(e[x], e[x], e[x]);
        continue;
      }
      const float g = e[x] / l[x];
      for (int c = 0; c < 3; ++c) d[x][c] = std::min(std::max(s[x][c] * g, 0.0f), 1.0f);
    }
  }
  return out;
}

cv::Mat ReferenceSimplified(const SimplifiedOptions& o, const cv::Mat& image) {
  ValidateEnhanceImage(image, "simplified");
  GuidedFilterOptions fine, coarse;
  fine.radius = o.fine_radius;
  fine.eps = o.fine_eps;
  coarse.radius = o.coarse_radius;
  coarse.eps = o.coarse_eps;
  coarse.subsample = o.coarse_subsample;
  const cv::Mat i_f = GuidedFilterSelf(fine, image);  // checked against the plane-by-plane one
  const cv::Mat i_g = GuidedFilterSelf(coarse, image);
  cv::Mat out;
  if (o.coarse_subsample == 1) {
    // The streamed path's boost in float (issue 29 item 6, third round; simplified_rows.h, whose
    // test bounds it against double precision): one FMA with the AVX2 + FMA kernel, a product
    // and a sum with the portable one.
    const bool fma =
        KernelCpuLevel() >= CpuLevel::kAvx2Fma && simplified_internal::BoostOutAvx2Fma() != nullptr;
    const float alpha = static_cast<float>(o.alpha);
    out.create(image.size(), CV_32FC3);
    const float* f = i_f.ptr<float>();
    const float* g = i_g.ptr<float>();
    float* q = out.ptr<float>();
    for (size_t i = 0; i < out.total() * 3; ++i) {
      const float d = f[i] - g[i];
      q[i] = fma ? std::fma(alpha, d, g[i]) : g[i] + alpha * d;
    }
  } else {
    cv::addWeighted(i_g, 1.0 - o.alpha, i_f, o.alpha, 0.0, out);
  }
  ReferenceClampUnit(out);
  if (o.contrast) out = ReferenceClahe(o.clahe, out);
  ReferenceClampUnit(out);
  return out;
}

// EstimateLightScale (public) and the Immerkaer noise estimate behind adaptive denoising, as they
// were: every channel in its own pass, the normal equations as cv::Matx sums, one float chain per
// row.
double ReferencePercentile(std::vector<float>& values, double percentile) {
  const size_t k = static_cast<size_t>(std::floor(percentile / 100.0 * (values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

std::vector<LightScaleEstimate> ReferenceEstimateLightScale(const cv::Mat& denoised,
                                                            const cv::Mat& light,
                                                            const cv::Mat& transmission,
                                                            double percentile, double support) {
  const int stride =
      std::max(1, static_cast<int>(std::floor(std::sqrt(denoised.total() / 65536.0))));
  const int ch = denoised.channels(), lc = light.channels(), tc = transmission.channels();
  std::vector<LightScaleEstimate> out(ch);
  std::vector<float> ratios;
  std::vector<cv::Vec4d> samples;
  for (int c = 0; c < ch; ++c) {
    const int l_at = lc == 1 ? 0 : c, t_at = tc == 1 ? 0 : c;
    float w_max = 0.0f;
    for (int y = 0; y < denoised.rows; y += stride) {
      const float* t = transmission.ptr<float>(y);
      const float* l = light.ptr<float>(y);
      for (int x = 0; x < denoised.cols; x += stride) {
        w_max = std::max(w_max, (1.0f - t[x * tc + t_at]) * l[x * lc + l_at]);
      }
    }
    if (!(w_max > 0.0f) || !std::isfinite(w_max)) continue;
    const float w_min = static_cast<float>(support) * w_max;
    ratios.clear();
    samples.clear();
    for (int y = 0; y < denoised.rows; y += stride) {
      const float* in = denoised.ptr<float>(y);
      const float* t = transmission.ptr<float>(y);
      const float* l = light.ptr<float>(y);
      for (int x = 0; x < denoised.cols; x += stride) {
        const double ti = t[x * tc + t_at], li = l[x * lc + l_at], v = in[x * ch + c];
        const float w = static_cast<float>((1.0 - ti) * li);
        if (!std::isfinite(v) || !std::isfinite(li)) continue;
        if (w >= w_min) ratios.push_back(static_cast<float>(std::max(v, 0.0) / w));
        samples.push_back(cv::Vec4d(ti, (1.0 - ti) * li, ti * li, v));
      }
    }
    if (ratios.empty()) continue;
    ReferenceChooseLightScale(samples, std::max(0.0, ReferencePercentile(ratios, percentile)),
                              &out[c]);
  }
  return out;
}

// ---- Inputs.

cv::Mat SmoothNoise(int rows, int cols, int seed) {
  cv::Mat img(rows, cols, CV_32FC3);
  cv::RNG(seed).fill(img, cv::RNG::UNIFORM, 0.02, 0.95);
  if (rows > 2 && cols > 2) cv::GaussianBlur(img, img, cv::Size(0, 0), 1.3);
  return img;
}

const std::vector<cv::Size>& OddSizes() {
  static const std::vector<cv::Size> sizes = {{1, 1},  {2, 3},   {7, 5},    {5, 33},
                                              {31, 2}, {83, 61}, {101, 77}, {257, 129}};
  return sizes;
}

struct ColorRender {
  std::string name;
  Scene scene;
  RenderResult render;
};

// The colour hull (gray texture tinted per channel, as the bench's) and the seafloor, rendered
// (Jerlov 3C, seed 1, linear) at test scales.
const std::vector<ColorRender>& Renders() {
  static const std::vector<ColorRender> renders = [] {
    std::vector<ColorRender> out;
    for (const char* name : {"hull", "seafloor"}) {
      for (double scale : {0.1, 0.27}) {
        BuiltinSceneOptions so;
        so.scale = scale;
        ColorRender c;
        c.scene = MakeBuiltinScene(name, so);
        if (c.scene.image.channels() == 1) {
          const cv::Mat g = c.scene.image;
          cv::merge(std::vector<cv::Mat>{g * 0.8, g * 0.95, g}, c.scene.image);
        }
        RenderOptions o;
        o.water.type = "3C";
        o.seed = 1;
        o.camera.encoding = CameraEncoding::kLinear;
        c.render = Render(o, c.scene);
        c.name = std::string(name) + "@" + std::to_string(c.render.image.cols) + "x" +
                 std::to_string(c.render.image.rows);
        out.push_back(std::move(c));
      }
    }
    return out;
  }();
  return renders;
}

// Real colour photographs from $TURBID_DATA (linear [0, 1] BGR), empty when it is not set.
std::vector<std::pair<std::string, cv::Mat>> RealFrames() {
  std::vector<std::pair<std::string, cv::Mat>> frames;
  const auto dir = testing::DataDir();
  if (!dir) return frames;
  for (const char* rel :
       {"uieb_waternet/616.png", "euvp_funiegan/A/1.jpg", "subvo/images/frame_00_00_21.000.jpg"}) {
    try {
      cv::Mat img = ReadImage(*dir + "/" + rel);
      if (img.channels() == 3) frames.emplace_back(rel, img);
    } catch (const Error&) {
      // A frame the data folder does not have: the others still run.
    }
  }
  return frames;
}

// ---- Building blocks.

TEST(ColorPaths, SelectKthEqualsNthElement) {
  // The percentiles of `full` (t_med, exposure, light-scale bound, the fit's trim) use it.
  cv::RNG rng(17);
  // Sizes on both sides of the four count tables (16384 candidates), with tails of 0 to 3.
  for (size_t n : {1, 2, 3, 17, 64, 65, 1000, 16383, 16384, 16387, 40000, 100001}) {
    for (int kind = 0; kind < 4; ++kind) {
      std::vector<float> f(n);
      std::vector<double> d(n);
      for (size_t i = 0; i < n; ++i) {
        double v = rng.uniform(-2.0, 2.0);
        if (kind == 1) v = std::round(v * 3) / 3;           // many ties, -0 and +0
        if (kind == 2) v = 0.5 + 1e-7 * rng.uniform(0, 8);  // values a few ulps apart
        if (kind == 3 && i % 7 == 0) v = (i % 14 == 0 ? 1 : -1) * HUGE_VAL;
        f[i] = static_cast<float>(v);
        d[i] = v;
      }
      for (size_t k : {size_t{0}, n / 3, n / 2, n * 8 / 10, n - 1}) {
        std::vector<float> fs = f;
        std::nth_element(fs.begin(), fs.begin() + static_cast<std::ptrdiff_t>(k), fs.end());
        // Every kernel level (the float keys' bucket kept sixteen at a time with AVX-512).
        for (CpuLevel level : {CpuLevel::kAvx512, CpuLevel::kScalar}) {
          SetCpuLevelCap(level);
          std::vector<float> f_scratch = f;  // SelectKth uses its input as scratch
          EXPECT_EQ((enhancer_internal::SelectKth<float, uint32_t>(f_scratch, k)), fs[k])
              << n << " " << k << " " << CpuLevelName(level);
        }
        SetCpuLevelCap(CpuLevel::kAvx512);
        std::vector<double> ds = d, d_scratch = d;
        std::nth_element(ds.begin(), ds.begin() + static_cast<std::ptrdiff_t>(k), ds.end());
        EXPECT_EQ((enhancer_internal::SelectKth<double, uint64_t>(d_scratch, k)), ds[k])
            << n << " " << k;
      }
    }
  }
}

TEST(ColorPaths, GuidedFilterInterleavedMatchesPlaneByPlane) {
  for (const cv::Size& size : OddSizes()) {
    const cv::Mat img = SmoothNoise(size.height, size.width, size.area());
    for (int r : {1, 2, 4, 8, 12, 13}) {
      GuidedFilterOptions o;
      o.radius = r;
      o.eps = r == 8 ? 0.16 : 0.003;
      const cv::Mat expect = ReferenceGuidedFilterSelf(o, img);
      const cv::Mat got = GuidedFilterSelf(o, img);
      EXPECT_LE(cv::norm(got, expect, cv::NORM_INF), kFilterTolerance) << size << " r " << r;
      cv::Mat rows(img.size(), CV_32FC3);
      GuidedFilterSelfRows({o}, img, [&](int y, const std::vector<const float*>& q) {
        std::memcpy(rows.ptr<float>(y), q[0], sizeof(float) * 3 * img.cols);
      });
      EXPECT_TRUE(SameBits(rows, got)) << size << " r " << r << " (rows)";
    }
  }
}

TEST(ColorPaths, GuidedFilterRowsMatchPlaneByPlaneAcrossWidths) {
  // Widths around the segment sizes of the running-sum filter (8 segments of multiples of 8
  // pixels), every radius 1..12, rows past a re-anchoring (64 rows), both kernel sets.
  for (int width : {120, 127, 128, 129, 131, 136, 250, 256, 257, 263, 700}) {
    const cv::Mat img = SmoothNoise(70, width, 29 + width);
    for (int r = 1; r <= 12; ++r) {
      GuidedFilterOptions o;
      o.radius = r;
      o.eps = r % 2 == 0 ? 0.16 : 0.003;
      const cv::Mat expect = ReferenceGuidedFilterSelf(o, img);
      for (bool avx2 : {true, false}) {
        enhancer_internal::SetHandWrittenAvx2(avx2);
        EXPECT_LE(cv::norm(GuidedFilterSelf(o, img), expect, cv::NORM_INF), kFilterTolerance)
            << width << " r " << r << " avx2 " << avx2;
      }
      enhancer_internal::SetHandWrittenAvx2(true);
    }
  }
}

TEST(ColorPaths, DeconvolveInterleavedEqualsPlaneByPlane) {
  const cv::Mat psf = PsfKernel(PsfOptions{}).kernel;
  for (const cv::Size& size : OddSizes()) {
    const cv::Mat img = SmoothNoise(size.height, size.width, 7 + size.area());
    const cv::Mat expect = ReferenceDeconvolve(DeconvolutionOptions{}, img, psf);
    EXPECT_TRUE(SameBits(Deconvolve(DeconvolutionOptions{}, img, psf), expect)) << size;
    cv::Mat rows(img.size(), CV_32FC3);
    ASSERT_TRUE(DeconvolveRows(DeconvolutionOptions{}, img, psf, [&](int y, const float* row) {
      std::memcpy(rows.ptr<float>(y), row, sizeof(float) * 3 * img.cols);
    }));
    EXPECT_TRUE(SameBits(rows, expect)) << size << " (rows)";
  }
  // Two channels are neither streamed nor interleaved.
  EXPECT_THROW(DeconvolveRows(DeconvolutionOptions{}, cv::Mat(4, 4, CV_32FC2, cv::Scalar::all(0)),
                              psf, [](int, const float*) {}),
               Error);
}

TEST(ColorPaths, ClaheFromColorBinsEqualsWholeImage) {
  for (const cv::Size& size : OddSizes()) {
    cv::Mat img = SmoothNoise(size.height, size.width, 3 + size.area());
    img.at<cv::Vec3f>(0, 0) = cv::Vec3f(0, 0, 0);  // luminance 0: the gray branch
    for (bool keep_mean : {false, true}) {
      ClaheOptions o;
      o.keep_mean = keep_mean;
      o.min_mean = 0.18;
      const cv::Mat expect = ReferenceClahe(o, img);
      cv::Mat bins = ClaheNewBins(o, img.size());
      std::vector<float> lum(img.cols);
      for (int y = 0; y < img.rows; ++y)
        ClaheBinColorRow(o, img.ptr<float>(y), lum.data(), bins, y);
      cv::Mat out = img.clone();
      ClaheColorFromBins(o, bins, out);
      EXPECT_TRUE(SameBits(out, expect)) << size << " keep_mean " << keep_mean;
      EXPECT_TRUE(SameBits(Clahe(o, img), expect)) << size;
    }
  }
}

TEST(ColorPaths, ClaheColorKernelsEqualPortableLoops) {
  // The luminance and the ratio step (8 or 16 pixels per vector step, the rest one at a time)
  // against the whole-image reference, with the portable loops as well: every width up to 3
  // vector steps past a multiple of 16, dark pixels (the gray branch) at every lane, values beyond
  // [0, 1] (the ratio's clamp), -0, and the R, G, B order.
  for (int width = 1; width <= 51; ++width) {
    cv::Mat img = SmoothNoise(19, width, 41 + width) * 1.3;
    img -= cv::Scalar::all(0.1);
    for (int x = 0; x < width; x += 3) img.at<cv::Vec3f>(x % 19, x) = cv::Vec3f(0, 0, 0);
    if (width > 4) img.at<cv::Vec3f>(5, 4) = cv::Vec3f(-0.0f, 2e-7f, -0.0f);  // l <= 1e-6
    if (width > 9) img.at<cv::Vec3f>(7, 9) = cv::Vec3f(-0.5f, 0.2f, 0.9f);
    // Every kernel level: 16 pixels per vector step (avx512), 8 (avx2+fma), the portable loops.
    for (CpuLevel level : {CpuLevel::kAvx512, CpuLevel::kAvx2Fma, CpuLevel::kScalar}) {
      SetCpuLevelCap(level);
      const char* avx2 = CpuLevelName(level);
      for (bool rgb : {false, true}) {
        ClaheOptions o;
        o.rgb = rgb;
        // R, G, B order: the same values as the reordered image's B, G, R result.
        cv::Mat bgr_in;  // a new buffer: cvtColor into img's would reorder img itself
        if (rgb) {
          cv::cvtColor(img, bgr_in, cv::COLOR_RGB2BGR);
        } else {
          bgr_in = img;
        }
        cv::Mat expect = ReferenceClahe(ClaheOptions{}, bgr_in);
        if (rgb) cv::cvtColor(expect, expect, cv::COLOR_BGR2RGB);
        cv::Mat bins = ClaheNewBins(o, img.size());
        std::vector<float> lum(img.cols);
        for (int y = 0; y < img.rows; ++y) {
          ClaheBinColorRow(o, img.ptr<float>(y), lum.data(), bins, y);
        }
        cv::Mat out = img.clone();
        ClaheColorFromBins(o, bins, out);
        EXPECT_TRUE(SameBits(out, expect)) << width << " level " << avx2 << " rgb " << rgb;
      }
    }
    SetCpuLevelCap(CpuLevel::kAvx512);
  }
}

// CLAHE of a one-channel image written out pixel by pixel (no row LUT, no sub-histograms, no
// shared quantiles): the arithmetic of ClaheRowsT / MappingsT before perf5-simp (be04b57), for
// the gray path that both colour methods' CLAHE uses. Tile mappings from each tile's histogram
// counted over the mirrored padding and shaped by ClaheMapHistogram; per pixel the two tile rows'
// mappings blended vertically (up + wy (dn - up)), then horizontally as left + wx (right - left)
// with right = 0 past the last tile column, clamped to [0, 1].
cv::Mat ReferenceClaheGray(const ClaheOptions& o, const cv::Mat& gray) {
  auto pad_amount = [](int n, int tiles, int* dim) {
    int pad = 0;
    *dim = n / tiles;
    if (n % tiles != 0) *dim = n / tiles + 1, pad = *dim * tiles - n;
    if (*dim % 2 != 0) pad += tiles, *dim += 1;
    return pad;
  };
  auto mirror = [](int i, int n) {
    const int period = 2 * n;
    int m = i % period;
    if (m < 0) m += period;
    return m < n ? m : period - 1 - m;
  };
  int tile_h, tile_w;
  const int pre_y = pad_amount(gray.rows, o.tiles_y, &tile_h) / 2;
  const int pre_x = pad_amount(gray.cols, o.tiles_x, &tile_w) / 2;
  cv::Mat bin(gray.size(), CV_32S);
  const float scale = static_cast<float>(o.bins - 1);
  for (int y = 0; y < gray.rows; ++y) {
    for (int x = 0; x < gray.cols; ++x) {
      const float c = std::min(std::max(0.0f, gray.at<float>(y, x)), 1.0f);
      bin.at<int>(y, x) = static_cast<int>(c * scale + 0.5f);
    }
  }
  std::vector<std::vector<float>> maps;
  for (int ty = 0; ty < o.tiles_y; ++ty) {
    for (int tx = 0; tx < o.tiles_x; ++tx) {
      std::vector<int> hist(o.bins, 0);
      for (int y = ty * tile_h; y < (ty + 1) * tile_h; ++y) {
        for (int x = tx * tile_w; x < (tx + 1) * tile_w; ++x) {
          ++hist[bin.at<int>(mirror(y - pre_y, gray.rows), mirror(x - pre_x, gray.cols))];
        }
      }
      maps.push_back(ClaheMapHistogram(o, hist, tile_h * tile_w));
    }
  }
  auto neighbours = [](int i, int pre, int tile, int tiles, int* lo, int* hi, float* w) {
    const double t = (static_cast<double>(i + pre) - tile / 2) / tile;
    const int f = static_cast<int>(std::floor(t));
    if (f < 0) {
      *lo = *hi = 0, *w = 0.0f;
    } else if (f >= tiles - 1) {
      *lo = *hi = tiles - 1, *w = 0.0f;
    } else {
      *lo = f, *hi = f + 1, *w = static_cast<float>(t - f);
    }
  };
  cv::Mat out(gray.size(), CV_32F);
  for (int y = 0; y < gray.rows; ++y) {
    int up, dn, lo, hi;
    float wy, wx;
    neighbours(y, pre_y, tile_h, o.tiles_y, &up, &dn, &wy);
    for (int x = 0; x < gray.cols; ++x) {
      neighbours(x, pre_x, tile_w, o.tiles_x, &lo, &hi, &wx);
      const int b = bin.at<int>(y, x);
      auto blend = [&](int tx) {
        const float u = maps[up * o.tiles_x + tx][b], d = maps[dn * o.tiles_x + tx][b];
        return u + wy * (d - u);
      };
      const float left = blend(lo);
      const float right = lo + 1 < o.tiles_x ? blend(lo + 1) : 0.0f;
      out.at<float>(y, x) = std::min(std::max(left + wx * (right - left), 0.0f), 1.0f);
    }
  }
  return out;
}

TEST(ColorPaths, ClaheRowLutsAndMappingsEqualPixelByPixelReference) {
  // The row LUT (blend and pairs in one AVX2 pass: bins not a multiple of 8 reach its scalar
  // tails, in the inner tile columns and the last one, whose differences are multiplied by a
  // weight of 0 and so cannot show), the 8-bit histogram counting (eight indices per load; runs
  // shorter than 8 and padded columns), and the quantiles shared between tiles (few pixels per
  // tile: shared; many: not): hand-written and portable kernels.
  struct Case {
    int rows, cols, tiles_x, tiles_y, bins;
  };
  const Case cases[] = {{37, 53, 8, 8, 256}, {48, 64, 2, 3, 7},   {61, 45, 5, 7, 9},
                        {30, 90, 3, 2, 100}, {33, 29, 4, 4, 1000}, {64, 80, 8, 8, 2},
                        {120, 160, 2, 2, 13}};
  for (const Case& c : cases) {
    cv::Mat img(c.rows, c.cols, CV_32F);
    cv::RNG(c.bins + c.cols).fill(img, cv::RNG::UNIFORM, -0.1, 1.1);
    cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
    for (ClaheDistribution d : {ClaheDistribution::kRayleigh, ClaheDistribution::kUniform,
                                ClaheDistribution::kExponential}) {
      ClaheOptions o;
      o.tiles_x = c.tiles_x, o.tiles_y = c.tiles_y, o.bins = c.bins, o.distribution = d;
      const cv::Mat expect = ReferenceClaheGray(o, img);
      // Every kernel level (the row LUT's blend at 16 lanes, at 8, and the portable loops).
      for (CpuLevel level : {CpuLevel::kAvx512, CpuLevel::kAvx2Fma, CpuLevel::kScalar}) {
        SetCpuLevelCap(level);
        EXPECT_TRUE(SameBits(Clahe(o, img), expect))
            << c.rows << "x" << c.cols << " tiles " << c.tiles_x << "x" << c.tiles_y << " bins "
            << c.bins << " level " << CpuLevelName(level) << " distribution "
            << static_cast<int>(d);
      }
      SetCpuLevelCap(CpuLevel::kAvx512);
    }
  }
}

TEST(ColorPaths, LightScaleAndNoiseEstimatesEqualReference) {
  // Both feed `full` (blind light scale, adaptive denoising epsilon): equal to the old code on
  // renders (through FullEnhanceDetailed's intermediates) and on random maps, gray and colour.
  // The ratio bound is the same value; the fit (and so a scale taken from it) within 1e-5
  // relative, issue 29 item 6's rule: with one-channel t and L on colour the normal equations are
  // summed four samples per vector, one partial sum per lane (branch full4), not in sample order
  // (at most 4.7e-14 relative in tests/enhancer/full_light_scale_test.cc).
  constexpr double kFitTolerance = 1e-5;
  for (const ColorRender& r : Renders()) {
    const FullResult d =
        FullEnhanceDetailed(FullOptions{}, r.render.image, &r.scene, &r.render.sidecar);
    EXPECT_EQ(d.noise_sigma, ReferenceNoiseSigma(r.render.image)) << r.name;
    ASSERT_FALSE(d.light.empty());
    // d.light is scaled; the estimate is scale-invariant in the ratio's sense only, so compare on
    // the unscaled-equivalent map: any positive map does.
    for (int lc : {1, 3}) {
      cv::Mat light = d.light;
      if (lc == 1) cv::extractChannel(d.light, light, 1);
      const auto got = EstimateLightScale(d.denoised, light, d.transmission, 1.0, 0.25);
      const auto want = ReferenceEstimateLightScale(d.denoised, light, d.transmission, 1.0, 0.25);
      ASSERT_EQ(got.size(), want.size());
      for (size_t c = 0; c < got.size(); ++c) {
        EXPECT_NEAR(got[c].scale, want[c].scale, kFitTolerance * std::abs(want[c].scale))
            << r.name << " c " << c;
        EXPECT_NEAR(got[c].fit, want[c].fit, kFitTolerance * std::abs(want[c].fit))
            << r.name << " c " << c;
        EXPECT_EQ(got[c].bound, want[c].bound) << r.name << " c " << c;
        EXPECT_EQ(got[c].source, want[c].source) << r.name << " c " << c;
      }
    }
  }
  for (const cv::Size& size : OddSizes()) {
    for (int ch : {1, 3}) {
      cv::Mat img(size, CV_32FC(ch)), t(size, CV_32FC(ch)), l(size, CV_32F);
      cv::RNG rng(size.area() + ch);
      rng.fill(img, cv::RNG::UNIFORM, 0.0, 1.0);
      rng.fill(t, cv::RNG::UNIFORM, 0.1, 1.0);
      rng.fill(l, cv::RNG::UNIFORM, 0.0, 2.0);
      const auto got = EstimateLightScale(img, l, t, 5.0, 0.25);
      const auto want = ReferenceEstimateLightScale(img, l, t, 5.0, 0.25);
      for (size_t c = 0; c < got.size(); ++c) {
        EXPECT_EQ(got[c].scale, want[c].scale) << size << " ch " << ch;
        EXPECT_EQ(got[c].fit, want[c].fit) << size << " ch " << ch;
      }
      const FullResult d = FullEnhanceDetailed(FullOptions{}, img, nullptr, nullptr);
      EXPECT_EQ(d.noise_sigma, ReferenceNoiseSigma(img)) << size << " ch " << ch;
    }
  }
  // One-channel t and L with three channels (the default `full`: the fits run side by side), with
  // every channel finite, then with a non-finite value in one channel or in L (the channels'
  // sample sets then differ or lose a pixel).
  for (const cv::Size& size : OddSizes()) {
    for (int damage = 0; damage < 4; ++damage) {
      cv::Mat img(size, CV_32FC3), t(size, CV_32F), l(size, CV_32F);
      cv::RNG rng(size.area() + 7 * damage);
      rng.fill(img, cv::RNG::UNIFORM, -0.1, 1.0);
      rng.fill(t, cv::RNG::UNIFORM, 0.1, 1.0);
      rng.fill(l, cv::RNG::UNIFORM, 0.0, 2.0);
      const int y = size.height / 2, x = size.width / 2 - size.width / 2 % 2;
      if (damage == 1) img.at<cv::Vec3f>(0, 0)[1] = std::numeric_limits<float>::quiet_NaN();
      if (damage == 2) img.at<cv::Vec3f>(y, x)[2] = std::numeric_limits<float>::infinity();
      if (damage == 3) l.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
      for (double pct : {1.0, 30.0}) {
        const auto got = EstimateLightScale(img, l, t, pct, 0.25);
        const auto want = ReferenceEstimateLightScale(img, l, t, pct, 0.25);
        for (size_t c = 0; c < got.size(); ++c) {
          EXPECT_NEAR(got[c].scale, want[c].scale, kFitTolerance * std::abs(want[c].scale))
              << size << " damage " << damage << " c " << c;
          EXPECT_NEAR(got[c].fit, want[c].fit, kFitTolerance * std::abs(want[c].fit))
              << size << " damage " << damage << " c " << c;
          EXPECT_EQ(got[c].bound, want[c].bound) << size << " damage " << damage << " c " << c;
          EXPECT_EQ(got[c].source, want[c].source) << size << " damage " << damage << " c " << c;
        }
      }
    }
  }
}

// ---- simplified.

TEST(ColorPaths, SimplifiedEqualsReference) {
  std::vector<std::pair<std::string, cv::Mat>> inputs;
  for (const cv::Size& size : OddSizes()) {
    inputs.emplace_back("noise " + std::to_string(size.width) + "x" + std::to_string(size.height),
                        SmoothNoise(size.height, size.width, 11 + size.area()));
  }
  for (const ColorRender& r : Renders()) inputs.emplace_back(r.name, r.render.image);
  for (auto& f : RealFrames()) inputs.push_back(f);
  // Values beyond [0, 1] on both sides (the boost's clamp).
  inputs.emplace_back("out of range", SmoothNoise(29, 41, 3) * 3.0 - 1.0);
  for (const auto& [name, img] : inputs) {
    for (int variant = 0; variant < 4; ++variant) {
      SimplifiedOptions o;
      o.contrast = variant != 1;
      if (variant == 2) o.alpha = 0.37, o.coarse_subsample = 2;   // fast filter: not streamed
      if (variant == 3) o.fine_radius = 1, o.coarse_radius = 14;  // unfused radius
      EXPECT_TRUE(SameBits(SimplifiedEnhance(o, img), ReferenceSimplified(o, img)))
          << name << " variant " << variant;
    }
  }
}

TEST(ColorPaths, SimplifiedEqualsReferenceOnLargeImages) {
  // Images over 8 MiB: the boosted rows go to the output with non-temporal stores and CLAHE's
  // binning reads a cached copy. 1024 pixels: every row 32-byte aligned (streamed); 1031: rows
  // alternate between aligned and not (the plain stores), in one image.
  for (const cv::Size& size : {cv::Size(1024, 760), cv::Size(1031, 731)}) {
    const cv::Mat img = SmoothNoise(size.height, size.width, 17);
    EXPECT_TRUE(SameBits(SimplifiedEnhance(SimplifiedOptions{}, img),
                         ReferenceSimplified(SimplifiedOptions{}, img)))
        << size;
  }
}

TEST(ColorPaths, SimplifiedNamesTheRowOfANonFiniteInput) {
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  for (float value : bad)
    for (cv::Point at : {cv::Point(0, 0), cv::Point(48, 39), cv::Point(20, 17)})
      for (int channel = 0; channel < 3; ++channel) {
        cv::Mat img(40, 49, CV_32FC3, cv::Scalar::all(0.4));
        img.at<cv::Vec3f>(at)[channel] = value;
        try {
          SimplifiedEnhance(SimplifiedOptions{}, img);
          ADD_FAILURE() << value << " at " << at << " passed";
        } catch (const Error& e) {
          EXPECT_EQ(std::string(e.what()), "simplified: input image has non-finite values (row " +
                                               std::to_string(at.y) + ")");
        }
      }
  // Finite values that overflow the filters are clamped, as before.
  cv::Mat huge(40, 49, CV_32FC3, cv::Scalar::all(0.4));
  huge.at<cv::Vec3f>(10, 10)[1] = 3e38f;
  EXPECT_TRUE(SameBits(SimplifiedEnhance(SimplifiedOptions{}, huge),
                       ReferenceSimplified(SimplifiedOptions{}, huge)));
}

// ---- full: FullEnhance streams colour; FullEnhanceDetailed keeps the whole-image steps (with
// the building blocks checked above against the plane-by-plane ones).

std::vector<std::pair<std::string, FullOptions>> FullVariants() {
  std::vector<std::pair<std::string, FullOptions>> v;
  for (const char* name : {"full", "full_literal", "full_matched", "full_physical"}) {
    v.emplace_back(name, FullVariantDefaults(name));
  }
  FullOptions o;
  o.contrast = false;
  v.emplace_back("no contrast", o);
  o = FullOptions{};
  o.clahe_target_mean = true;
  v.emplace_back("clahe_target_mean", o);
  o = FullOptions{};
  o.denoise = false;
  v.emplace_back("no denoise", o);
  o = FullOptions{};
  o.light = false;
  o.keep_detail = 0;
  v.emplace_back("no light, no detail", o);
  o = FullOptions{};
  o.deblur = false;
  v.emplace_back("no deblur", o);
  o = FullOptions{};
  o.deconvolution.method = DeconvolutionMethod::kRichardsonLucy;
  o.deconvolution.iterations = 2;
  v.emplace_back("richardson_lucy", o);
  o = FullOptions{};
  o.dehaze = false;
  v.emplace_back("no dehaze", o);
  o = FullOptions{};
  o.beta_per_m = 0;
  v.emplace_back("beta 0", o);
  // t and E_L at full resolution (the streamed path reads the maps' rows as they are) and at an
  // odd subsample (its rows upsampled one at a time).
  for (int subsample : {1, 3}) {
    o = FullOptions{};
    o.light_subsample = subsample;
    v.emplace_back("light_subsample " + std::to_string(subsample), o);
  }
  return v;
}

TEST(ColorPaths, FullEqualsWholeImagePipelineOnRenders) {
  for (const ColorRender& r : Renders()) {
    for (const auto& [name, o] : FullVariants()) {
      const cv::Mat fast = FullEnhance(o, r.render.image, &r.scene, &r.render.sidecar);
      const FullResult slow = FullEnhanceDetailed(o, r.render.image, &r.scene, &r.render.sidecar);
      EXPECT_TRUE(SameBits(fast, slow.image)) << r.name << " " << name;
    }
  }
}

TEST(ColorPaths, FullEqualsWholeImagePipelineWithoutGeometry) {
  // No scene and no sidecar: the frontal plane, the default LED; every size, tiny ones included.
  for (const cv::Size& size : OddSizes()) {
    const cv::Mat img = SmoothNoise(size.height, size.width, 5 + size.area());
    for (const auto& [name, o] : FullVariants()) {
      EXPECT_TRUE(SameBits(FullEnhance(o, img, nullptr, nullptr),
                           FullEnhanceDetailed(o, img, nullptr, nullptr).image))
          << size << " " << name;
    }
  }
}

TEST(ColorPaths, FullAndSimplifiedEqualReferenceOnRealFrames) {
  TURBID_REQUIRE_DATA(data);
  const auto frames = RealFrames();
  ASSERT_FALSE(frames.empty()) << "no colour frame found under " << data;
  for (const auto& [name, img] : frames) {
    const FullOptions o;
    EXPECT_TRUE(SameBits(FullEnhance(o, img, nullptr, nullptr),
                         FullEnhanceDetailed(o, img, nullptr, nullptr).image))
        << name;
    EXPECT_TRUE(SameBits(SimplifiedEnhance(SimplifiedOptions{}, img),
                         ReferenceSimplified(SimplifiedOptions{}, img)))
        << name;
  }
}

TEST(ColorPaths, FullNamesTheRowOfANonFiniteInput) {
  // The streamed colour path checks the input through its noise estimate (adaptive denoising):
  // every corner, edge and inner value is caught, with the message of the up-front check; an
  // input whose finite values overflow the estimate gives the whole-image pipeline's output.
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  FullOptions fixed;
  fixed.denoise_adaptive = false;
  for (const FullOptions& o : {FullOptions{}, fixed})
    for (float value : bad)
      for (cv::Point at : {cv::Point(0, 0), cv::Point(48, 0), cv::Point(0, 39), cv::Point(48, 39),
                           cv::Point(20, 17), cv::Point(1, 38)})
        for (int channel = 0; channel < 3; ++channel) {
          cv::Mat img(40, 49, CV_32FC3, cv::Scalar::all(0.4));
          img.at<cv::Vec3f>(at)[channel] = value;
          try {
            FullEnhance(o, img, nullptr, nullptr);
            ADD_FAILURE() << value << " at " << at << " passed";
          } catch (const Error& e) {
            EXPECT_EQ(std::string(e.what()),
                      "full: input image has non-finite values (row " + std::to_string(at.y) + ")");
          }
        }
  for (const cv::Size& size : {cv::Size(49, 40), cv::Size(2, 9), cv::Size(9, 2)}) {
    cv::Mat huge(size, CV_32FC3, cv::Scalar::all(0.4));
    huge.at<cv::Vec3f>(size.height / 2, size.width / 2) = {3e38f, -3e38f, 3e38f};
    EXPECT_TRUE(SameBits(FullEnhance(FullOptions{}, huge, nullptr, nullptr),
                         FullEnhanceDetailed(FullOptions{}, huge, nullptr, nullptr).image))
        << size;
    huge.at<cv::Vec3f>(0, 0)[1] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(FullEnhance(FullOptions{}, huge, nullptr, nullptr), Error) << size;
  }
}

TEST(ColorPaths, PortableKernelsGiveTheSameOutput) {
  // With the hand-written AVX2 kernels off (the gray building blocks' portable twins, and the
  // colour guided filter's portable kernels, whose roundings differ from the FMA ones: the
  // references run with them too), the colour paths still equal the reference.
  const ColorRender& r = Renders()[0];
  enhancer_internal::SetHandWrittenAvx2(false);
  const cv::Mat full = FullEnhance(FullOptions{}, r.render.image, &r.scene, &r.render.sidecar);
  const cv::Mat simplified = SimplifiedEnhance(SimplifiedOptions{}, r.render.image);
  const cv::Mat full_ref =
      FullEnhanceDetailed(FullOptions{}, r.render.image, &r.scene, &r.render.sidecar).image;
  const cv::Mat simplified_ref = ReferenceSimplified(SimplifiedOptions{}, r.render.image);
  enhancer_internal::SetHandWrittenAvx2(true);
  EXPECT_TRUE(SameBits(full, full_ref));
  EXPECT_TRUE(SameBits(simplified, simplified_ref));
}

}  // namespace
}  // namespace turbid
