#include "enhancer/blocks/guided_filter.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>
#include <string>
#include <vector>

#include "enhancer/simd_switch.h"
#include "core/error.h"

namespace turbid {
namespace {

// ---------------------------------------------------------------------------------------------
// The pre-optimisation guided filter of commit 6722196 (enhancer/guided_filter.cc then), for the
// paths later rewritten: the one-channel guide at radii > 12 (running column sums re-anchored
// every 64 rows, window sums by binary doubling) and the colour guide (running sums both ways).
// Today's filter must give the same values bit for bit.

// Binary-doubling window sums of `window` values of ext (w + window - 1 values).
std::vector<float> ReferenceWindowSums(const std::vector<float>& ext, int w, int window) {
  const int n = w + window - 1;
  std::vector<float> p = ext, q(n), out(w);
  int len = 1, offset = 0, rest = window;
  bool first = true;
  for (;;) {
    if (rest & 1) {
      for (int x = 0; x < w; ++x) out[x] = first ? p[offset + x] : out[x] + p[offset + x];
      first = false;
      offset += len;
    }
    rest >>= 1;
    if (rest == 0) break;
    for (int i = 0; i < n - 2 * len + 1; ++i) q[i] = p[i] + p[i + len];
    std::swap(p, q);
    len *= 2;
  }
  return out;
}

// Box sums (not means) of rows given by `value(y, x)`, clipped window, as the stream forms them:
// row y's column sums re-anchored from zero every 64 rows, else updated by the entering and
// leaving rows; then the window sums across.
template <typename Value>
std::vector<std::vector<float>> ReferenceBoxSumsGray(int h, int w, int r, Value value) {
  std::vector<float> col(w, 0.0f);
  std::vector<std::vector<float>> out(h);
  for (int y = 0; y < h; ++y) {
    if (y % 64 == 0) {
      std::fill(col.begin(), col.end(), 0.0f);
      for (int yy = std::max(y - r, 0); yy <= std::min(y + r, h - 1); ++yy)
        for (int x = 0; x < w; ++x) col[x] += value(yy, x);
    } else {
      const int add = y + r, sub = y - r - 1;
      for (int x = 0; x < w; ++x) {
        if (add < h && sub >= 0) {
          col[x] += value(add, x) - value(sub, x);
        } else if (add < h) {
          col[x] += value(add, x);
        } else if (sub >= 0) {
          col[x] -= value(sub, x);
        }
      }
    }
    std::vector<float> ext(w + 2 * r, 0.0f);
    std::copy(col.begin(), col.end(), ext.begin() + r);
    out[y] = ReferenceWindowSums(ext, w, 2 * r + 1);
  }
  return out;
}

cv::Mat ReferenceGuidedGrayLargeRadius(const cv::Mat& guide, const cv::Mat& src, int r,
                                       double eps_in) {
  const int h = guide.rows, w = guide.cols;
  const float eps = static_cast<float>(eps_in);
  auto count = [r](int t, int n) { return std::min(t + r, n - 1) - std::max(t - r, 0) + 1; };
  auto g = [&](int y, int x) { return guide.at<float>(y, x); };
  auto p = [&](int y, int x) { return src.at<float>(y, x); };
  const auto s_i = ReferenceBoxSumsGray(h, w, r, g);
  const auto s_p = ReferenceBoxSumsGray(h, w, r, p);
  // I^2 and I p: the step adds a*a - s*s in one expression, so they get their own loop.
  auto product_sums = [&](auto u, auto v) {
    std::vector<float> col(w, 0.0f);
    std::vector<std::vector<float>> out(h);
    for (int y = 0; y < h; ++y) {
      if (y % 64 == 0) {
        std::fill(col.begin(), col.end(), 0.0f);
        for (int yy = std::max(y - r, 0); yy <= std::min(y + r, h - 1); ++yy)
          for (int x = 0; x < w; ++x) col[x] += u(yy, x) * v(yy, x);
      } else {
        const int add = y + r, sub = y - r - 1;
        for (int x = 0; x < w; ++x) {
          if (add < h && sub >= 0) {
            col[x] += u(add, x) * v(add, x) - u(sub, x) * v(sub, x);
          } else if (add < h) {
            col[x] += u(add, x) * v(add, x);
          } else if (sub >= 0) {
            col[x] -= u(sub, x) * v(sub, x);
          }
        }
      }
      std::vector<float> ext(w + 2 * r, 0.0f);
      std::copy(col.begin(), col.end(), ext.begin() + r);
      out[y] = ReferenceWindowSums(ext, w, 2 * r + 1);
    }
    return out;
  };
  const auto s_ii = product_sums(g, g);
  const auto s_ip = product_sums(g, p);
  cv::Mat a(h, w, CV_32F), b(h, w, CV_32F);
  for (int y = 0; y < h; ++y) {
    const float inv_cy = 1.0f / static_cast<float>(count(y, h));
    for (int x = 0; x < w; ++x) {
      const float inv = (1.0f / static_cast<float>(count(x, w))) * inv_cy;
      const float mi = s_i[y][x] * inv, mp = s_p[y][x] * inv;
      const float var = s_ii[y][x] * inv - mi * mi;
      const float cov = s_ip[y][x] * inv - mi * mp;
      const float av = cov / (var + eps);
      a.at<float>(y, x) = av;
      b.at<float>(y, x) = mp - av * mi;
    }
  }
  const auto s_a = ReferenceBoxSumsGray(h, w, r, [&](int y, int x) { return a.at<float>(y, x); });
  const auto s_b = ReferenceBoxSumsGray(h, w, r, [&](int y, int x) { return b.at<float>(y, x); });
  cv::Mat q(h, w, CV_32F);
  for (int y = 0; y < h; ++y) {
    const float inv_cy = 1.0f / static_cast<float>(count(y, h));
    for (int x = 0; x < w; ++x) {
      const float inv = (1.0f / static_cast<float>(count(x, w))) * inv_cy;
      q.at<float>(y, x) = (s_a[y][x] * guide.at<float>(y, x) + s_b[y][x]) * inv;
    }
  }
  return q;
}

cv::Mat RandomImage(int rows, int cols, int channels, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat m(rows, cols, CV_32FC(channels));
  rng.fill(m, cv::RNG::UNIFORM, 0.0, 1.0);
  // Some structure (edges and smooth areas) besides noise.
  cv::Mat smooth;
  cv::GaussianBlur(m, smooth, cv::Size(0, 0), 3.0);
  cv::Mat blocks(rows, cols, CV_32FC(channels), cv::Scalar::all(0.2));
  blocks(cv::Rect(cols / 4, rows / 4, cols / 2, rows / 2)).setTo(cv::Scalar::all(0.8));
  return 0.3 * m + 0.4 * smooth + 0.3 * blocks;
}

// Max |a - b| over pixels at least `margin` from every border.
double InteriorMaxDiff(const cv::Mat& a, const cv::Mat& b, int margin) {
  const cv::Rect roi(margin, margin, a.cols - 2 * margin, a.rows - 2 * margin);
  cv::Mat d;
  cv::absdiff(a(roi), b(roi), d);
  double mx = 0;
  cv::minMaxLoc(d.reshape(1), nullptr, &mx);
  return mx;
}

// Box means by running sums both ways (the pre-optimisation BoxMeansRows), of whole planes.
std::vector<cv::Mat> ReferenceBoxMeans(const std::vector<cv::Mat>& planes, int r) {
  const int k_count = static_cast<int>(planes.size());
  const int h = planes[0].rows, w = planes[0].cols;
  std::vector<cv::Mat> means(k_count);
  for (cv::Mat& m : means) m.create(h, w, CV_32F);
  std::vector<std::vector<float>> col(k_count, std::vector<float>(w, 0.0f));
  std::vector<float> inv_cx(w);
  for (int x = 0; x < w; ++x)
    inv_cx[x] = 1.0f / static_cast<float>(std::min(x + r, w - 1) - std::max(x - r, 0) + 1);
  for (int yy = 0; yy < std::min(r, h); ++yy)
    for (int k = 0; k < k_count; ++k)
      for (int x = 0; x < w; ++x) col[k][x] += planes[k].at<float>(yy, x);
  for (int y = 0; y < h; ++y) {
    const int add = y + r, sub = y - r - 1;
    for (int k = 0; k < k_count; ++k) {
      for (int x = 0; x < w; ++x) {
        if (add < h && sub >= 0) {
          col[k][x] += planes[k].at<float>(add, x) - planes[k].at<float>(sub, x);
        } else if (add < h) {
          col[k][x] += planes[k].at<float>(add, x);
        } else if (sub >= 0) {
          col[k][x] -= planes[k].at<float>(sub, x);
        }
      }
    }
    const float inv_cy = 1.0f / static_cast<float>(std::min(y + r, h - 1) - std::max(y - r, 0) + 1);
    for (int k = 0; k < k_count; ++k) {
      float s = 0.0f;
      for (int x = 0; x <= std::min(r, w - 1); ++x) s += col[k][x];
      for (int x = 0; x < w; ++x) {
        means[k].at<float>(y, x) = s * (inv_cx[x] * inv_cy);
        const bool enter = x + r + 1 < w, leave = x - r >= 0;
        s += (enter ? col[k][x + r + 1] : 0.0f) - (leave ? col[k][x - r] : 0.0f);
      }
    }
  }
  return means;
}

// The pre-optimisation colour-guided filter (one-channel source).
cv::Mat ReferenceGuidedColor(const cv::Mat& guide, const cv::Mat& src, int r, double eps) {
  std::vector<cv::Mat> g;
  cv::split(guide, g);
  const std::vector<cv::Mat> planes = {
      g[0],           g[1],           g[2],           src,
      g[0].mul(g[0]), g[0].mul(g[1]), g[0].mul(g[2]), g[1].mul(g[1]),
      g[1].mul(g[2]), g[2].mul(g[2]), g[0].mul(src),  g[1].mul(src),
      g[2].mul(src)};
  const std::vector<cv::Mat> mean = ReferenceBoxMeans(planes, r);
  std::vector<cv::Mat> coef(4);
  for (cv::Mat& c : coef) c.create(src.size(), CV_32F);
  for (int y = 0; y < src.rows; ++y) {
    for (int x = 0; x < src.cols; ++x) {
      auto m = [&](int k) { return static_cast<double>(mean[k].at<float>(y, x)); };
      const double mu0 = m(0), mu1 = m(1), mu2 = m(2), mp = m(3);
      const double s00 = m(4) - mu0 * mu0 + eps, s01 = m(5) - mu0 * mu1, s02 = m(6) - mu0 * mu2,
                   s11 = m(7) - mu1 * mu1 + eps, s12 = m(8) - mu1 * mu2,
                   s22 = m(9) - mu2 * mu2 + eps;
      const double c0 = m(10) - mu0 * mp, c1 = m(11) - mu1 * mp, c2 = m(12) - mu2 * mp;
      const double i00 = s11 * s22 - s12 * s12, i01 = s02 * s12 - s01 * s22,
                   i02 = s01 * s12 - s02 * s11, i11 = s00 * s22 - s02 * s02,
                   i12 = s01 * s02 - s00 * s12, i22 = s00 * s11 - s01 * s01;
      const double det = s00 * i00 + s01 * i01 + s02 * i02;
      const double inv = 1.0 / det;
      const double v0 = (i00 * c0 + i01 * c1 + i02 * c2) * inv;
      const double v1 = (i01 * c0 + i11 * c1 + i12 * c2) * inv;
      const double v2 = (i02 * c0 + i12 * c1 + i22 * c2) * inv;
      coef[0].at<float>(y, x) = static_cast<float>(v0);
      coef[1].at<float>(y, x) = static_cast<float>(v1);
      coef[2].at<float>(y, x) = static_cast<float>(v2);
      coef[3].at<float>(y, x) = static_cast<float>(mp - v0 * mu0 - v1 * mu1 - v2 * mu2);
    }
  }
  const std::vector<cv::Mat> m = ReferenceBoxMeans(coef, r);
  return m[0].mul(g[0]) + m[1].mul(g[1]) + m[2].mul(g[2]) + m[3];
}

// The colour guide (dcp and cap on colour input): the same values as the pre-optimisation filter,
// on odd shapes, small and large radii, one- and three-channel sources.
TEST(GuidedFilter, ColorGuideEqualsPreOptimisationFilter) {
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(13, 3), cv::Size(131, 77)}) {
    const cv::Mat guide = RandomImage(size.height, size.width, 3, 31);
    const cv::Mat src = RandomImage(size.height, size.width, 1, 32);
    const cv::Mat src3 = RandomImage(size.height, size.width, 3, 33);
    for (int r : {1, 4, 30, 60}) {
      GuidedFilterOptions o;
      o.radius = r;
      o.eps = 1e-4;
      EXPECT_EQ(cv::norm(GuidedFilter(o, guide, src), ReferenceGuidedColor(guide, src, r, o.eps),
                         cv::NORM_INF),
                0.0)
          << size << " r " << r;
      std::vector<cv::Mat> planes;
      cv::split(src3, planes);
      for (cv::Mat& p : planes) p = ReferenceGuidedColor(guide, p, r, o.eps);
      cv::Mat expected;
      cv::merge(planes, expected);
      EXPECT_EQ(cv::norm(GuidedFilter(o, guide, src3), expected, cv::NORM_INF), 0.0)
          << size << " r " << r << " three-channel source";
    }
  }
}

// Radii > 12 with a one-channel guide (dcp r 60, cap r 30): the same values as the
// pre-optimisation filter, with the hand-written AVX2 kernels and without, on shapes with every
// row remainder, several anchor blocks and windows wider than the image.
TEST(GuidedFilter, LargeRadiusGrayGuideEqualsPreOptimisationFilter) {
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(13, 3), cv::Size(203, 150), cv::Size(97, 71)}) {
    const cv::Mat guide = RandomImage(size.height, size.width, 1, 21);
    const cv::Mat src = RandomImage(size.height, size.width, 1, 22);
    for (int r : {13, 30, 60}) {
      GuidedFilterOptions o;
      o.radius = r;
      o.eps = r == 60 ? 1e-4 : 1e-3;
      const cv::Mat expected = ReferenceGuidedGrayLargeRadius(guide, src, r, o.eps);
      const cv::Mat expected_self = ReferenceGuidedGrayLargeRadius(guide, guide, r, o.eps);
      for (bool avx2 : {true, false}) {
        enhancer_internal::SetHandWrittenAvx2(avx2);
        EXPECT_EQ(cv::norm(GuidedFilter(o, guide, src), expected, cv::NORM_INF), 0.0)
            << size << " r " << r << (avx2 ? " avx2" : " portable");
        EXPECT_EQ(cv::norm(GuidedFilter(o, guide, guide), expected_self, cv::NORM_INF), 0.0)
            << size << " r " << r << (avx2 ? " avx2" : " portable") << " self-guided";
      }
      enhancer_internal::SetHandWrittenAvx2(true);
    }
  }
}

// He 2013 Alg. 1 in double precision from integral images (clipped windows): the exact filter
// of float inputs, against which both float implementations' rounding is measured.
cv::Mat ExactGuidedGray(const cv::Mat& guide, const cv::Mat& src, int r, double eps) {
  const int h = guide.rows, w = guide.cols;
  auto box = [&](const cv::Mat& m) {
    cv::Mat s;
    cv::integral(m, s, CV_64F);
    cv::Mat out(m.size(), CV_64F);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const int y0 = std::max(0, y - r), y1 = std::min(h - 1, y + r);
        const int x0 = std::max(0, x - r), x1 = std::min(w - 1, x + r);
        const double sum = s.at<double>(y1 + 1, x1 + 1) - s.at<double>(y0, x1 + 1) -
                           s.at<double>(y1 + 1, x0) + s.at<double>(y0, x0);
        out.at<double>(y, x) = sum / ((y1 - y0 + 1) * (x1 - x0 + 1));
      }
    }
    return out;
  };
  cv::Mat i, p;
  guide.convertTo(i, CV_64F);
  src.convertTo(p, CV_64F);
  const cv::Mat mi = box(i), mp = box(p), mii = box(i.mul(i)), mip = box(i.mul(p));
  const cv::Mat a = (mip - mi.mul(mp)) / (mii - mi.mul(mi) + eps);
  const cv::Mat b = mp - a.mul(mi);
  const cv::Mat q = box(a).mul(i) + box(b);
  cv::Mat out;
  q.convertTo(out, CV_32F);
  return out;
}

// GuidedFilterGrayRunning (dcp's and cap's refinement) is GuidedFilter with running horizontal
// sums: not the same rounding, so the values are compared with a tolerance. Its justification:
// both filters are float implementations of the same formula, and both must lie within 1e-5 of
// the exact (double) filter; their float window sums carry relative errors of ~1e-7 (a few
// roundings of sums up to (2r+1)^2), which the variance cancellation mean(I^2) - mean(I)^2
// amplifies by mean(I^2) / (var + eps) in a = cov / (var + eps) — up to ~1e3 at eps = 1e-4 in flat
// regions, hence errors of a few 1e-6 on q in [0, 1] (measured: GuidedFilter up to 7.2e-6 from the
// exact filter on the flat input below, this filter up to 6.9e-6, the two 1.1e-6 apart). The
// hand-written AVX2 kernels and the portable ones give the same values bit for bit.
TEST(GuidedFilter, RunningSumVariantEqualsFilterToFloatRounding) {
  constexpr double kTolerance = 1e-5;
  struct Case {
    cv::Size size;
    int r;
    double eps;
    bool flat;  // low-contrast guide: var << eps, the worst amplification
  };
  for (const Case& c : {Case{{1360, 1024}, 60, 1e-4, false}, Case{{1360, 1024}, 60, 1e-4, true},
                        Case{{640, 480}, 30, 1e-3, false}, Case{{301, 77}, 60, 1e-4, true},
                        Case{{37, 500}, 13, 1e-2, false}, Case{{203, 150}, 25, 1e-3, false},
                        Case{{13, 3}, 30, 1e-3, false}, Case{{1, 1}, 60, 1e-4, false}}) {
    cv::Mat guide = RandomImage(c.size.height, c.size.width, 1, 31);
    cv::Mat src = RandomImage(c.size.height, c.size.width, 1, 32);
    if (c.flat) {
      guide = 0.05 * guide + 0.45;
      src = 0.1 * src + 0.8;
    }
    const std::string what = std::to_string(c.size.width) + "x" + std::to_string(c.size.height) +
                             " r " + std::to_string(c.r) + (c.flat ? " flat" : "");
    GuidedFilterOptions o;
    o.radius = c.r;
    o.eps = c.eps;
    const cv::Mat filter = GuidedFilter(o, guide, src);
    const cv::Mat exact = ExactGuidedGray(guide, src, c.r, c.eps);
    const cv::Mat running = GuidedFilterGrayRunning(guide, src, c.r, c.eps);
    EXPECT_LE(cv::norm(running, filter, cv::NORM_INF), kTolerance) << what;
    EXPECT_LE(cv::norm(running, exact, cv::NORM_INF), kTolerance) << what;
    EXPECT_LE(cv::norm(filter, exact, cv::NORM_INF), kTolerance) << what << " (GuidedFilter)";
    enhancer_internal::SetHandWrittenAvx2(false);
    const cv::Mat portable = GuidedFilterGrayRunning(guide, src, c.r, c.eps);
    enhancer_internal::SetHandWrittenAvx2(true);
    EXPECT_EQ(cv::norm(running, portable, cv::NORM_INF), 0.0) << what << " portable";
    // Self-guided too.
    EXPECT_LE(cv::norm(GuidedFilterGrayRunning(guide, guide, c.r, c.eps),
                       GuidedFilter(o, guide, guide), cv::NORM_INF),
              kTolerance)
        << what << " self-guided";
  }
}

// Radii 1..12 are GuidedFilter's own kernels; row_done sees every row once, in order, and what it
// writes is the result.
TEST(GuidedFilter, RunningSumVariantSmallRadiiAndRowCallback) {
  const cv::Mat guide = RandomImage(97, 71, 1, 41), src = RandomImage(97, 71, 1, 42);
  for (int r : {1, 4, 12, 13, 60}) {
    GuidedFilterOptions o;
    o.radius = r;
    o.eps = 1e-3;
    const cv::Mat plain = GuidedFilterGrayRunning(guide, src, r, o.eps);
    if (r <= 12) {
      EXPECT_EQ(cv::norm(plain, GuidedFilter(o, guide, src), cv::NORM_INF), 0.0) << r;
    }
    int next = 0;
    const cv::Mat doubled = GuidedFilterGrayRunning(guide, src, r, o.eps, [&](int y, float* row) {
      EXPECT_EQ(y, next++);
      for (int x = 0; x < guide.cols; ++x) row[x] *= 2.0f;
    });
    EXPECT_EQ(next, guide.rows);
    EXPECT_EQ(cv::norm(doubled, 2.0 * plain, cv::NORM_INF), 0.0) << r;
  }
  EXPECT_THROW(GuidedFilterGrayRunning(cv::Mat(4, 4, CV_32FC3), cv::Mat(4, 4, CV_32FC3), 20, 1e-3),
               Error);
}

TEST(GuidedFilter, DefaultsPassCheck) {
  std::string why;
  EXPECT_TRUE(GuidedFilterOptions{}.Check(&why)) << why;
  GuidedFilterOptions bad;
  bad.eps = 0;
  EXPECT_FALSE(bad.Check(&why));
  bad = {};
  bad.radius = -1;
  EXPECT_FALSE(bad.Check(&why));
  bad = {};
  bad.subsample = 0;
  EXPECT_FALSE(bad.Check(&why));
}

struct Case {
  int radius;
  double eps;
};

class GuidedVsOpenCv : public ::testing::TestWithParam<Case> {};

TEST_P(GuidedVsOpenCv, GrayGuideMatchesXimgprocAwayFromBorder) {
  const Case c = GetParam();
  const cv::Mat guide = RandomImage(120, 160, 1, 1);
  const cv::Mat src = RandomImage(120, 160, 1, 2);
  GuidedFilterOptions o;
  o.radius = c.radius;
  o.eps = c.eps;
  cv::Mat ours = GuidedFilter(o, guide, src), ref;
  cv::ximgproc::guidedFilter(guide, src, ref, c.radius, c.eps, CV_32F);
  EXPECT_LE(InteriorMaxDiff(ours, ref, 2 * c.radius), 1e-4);
  // Self-guided (the fused two-sum path).
  cv::Mat self = GuidedFilter(o, guide, guide), self_ref;
  cv::ximgproc::guidedFilter(guide, guide, self_ref, c.radius, c.eps, CV_32F);
  EXPECT_LE(InteriorMaxDiff(self, self_ref, 2 * c.radius), 1e-4);
}

TEST_P(GuidedVsOpenCv, ColorGuideMatchesXimgprocAwayFromBorder) {
  const Case c = GetParam();
  // Known limit: with eps < 1e-2 the 3x3 solve amplifies the float rounding of both
  // implementations' running sums (we differ by up to 5e-2 at eps 1e-4); docs/methods.md.
  if (c.eps < 1e-2) GTEST_SKIP() << "colour guide compared for eps >= 1e-2 only";
  const cv::Mat guide = RandomImage(90, 110, 3, 3);
  const cv::Mat src = RandomImage(90, 110, 3, 4);
  GuidedFilterOptions o;
  o.radius = c.radius;
  o.eps = c.eps;
  cv::Mat ours = GuidedFilter(o, guide, src), ref;
  cv::ximgproc::guidedFilter(guide, src, ref, c.radius, c.eps, CV_32F);
  ASSERT_EQ(ours.type(), CV_32FC3);
  EXPECT_LE(InteriorMaxDiff(ours, ref, 2 * c.radius), 1e-4);
}

INSTANTIATE_TEST_SUITE_P(Radii, GuidedVsOpenCv,
                         ::testing::Values(Case{1, 1e-2}, Case{2, 1e-2}, Case{4, 1e-2},
                                           Case{8, 0.16}, Case{4, 1e-4}, Case{15, 1e-3}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           // e.g. r4_eps1em4: readable CTest names instead of the raw bytes.
                           char buf[32];
                           std::snprintf(buf, sizeof buf, "r%d_eps%.0e", info.param.radius,
                                         info.param.eps);
                           std::string name(buf);
                           for (char& ch : name) {
                             if (ch == '-') ch = 'm';
                             if (ch == '+' || ch == '.') ch = '_';
                           }
                           return name;
                         });

// He 2013 Alg. 1 written with whole-image box means (BoxMean: running sums along the row, no
// fused kernels), double arithmetic for a and b.
cv::Mat ReferenceGuided(const cv::Mat& guide, const cv::Mat& src, int r, double eps) {
  cv::Mat g, p;
  guide.convertTo(g, CV_32F);
  src.convertTo(p, CV_32F);
  const cv::Mat mi = BoxMean(g, r), mp = BoxMean(p, r);
  const cv::Mat mii = BoxMean(g.mul(g), r), mip = BoxMean(g.mul(p), r);
  cv::Mat a(g.size(), CV_32F), b(g.size(), CV_32F);
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x) {
      const double var = mii.at<float>(y, x) - double{mi.at<float>(y, x)} * mi.at<float>(y, x);
      const double cov = mip.at<float>(y, x) - double{mi.at<float>(y, x)} * mp.at<float>(y, x);
      const double av = cov / (var + eps);
      a.at<float>(y, x) = static_cast<float>(av);
      b.at<float>(y, x) = static_cast<float>(mp.at<float>(y, x) - av * mi.at<float>(y, x));
    }
  return BoxMean(a, r).mul(g) + BoxMean(b, r);
}

TEST(GuidedFilter, EveryRadiusMatchesBoxMeanFormulaIncludingBorders) {
  // Radii 1..12 run the fused row kernels (window sums straight into the coefficients and the
  // output), 13+ the general path; all must follow the clipped-window rule on every pixel.
  const cv::Mat guide = RandomImage(45, 67, 1, 21);
  const cv::Mat src = RandomImage(45, 67, 1, 22);
  for (int r = 1; r <= 14; ++r) {
    GuidedFilterOptions o;
    o.radius = r;
    o.eps = 0.02;
    EXPECT_LE(cv::norm(GuidedFilter(o, guide, guide), ReferenceGuided(guide, guide, r, o.eps),
                       cv::NORM_INF),
              2e-5)
        << "self, r " << r;
    EXPECT_LE(
        cv::norm(GuidedFilter(o, guide, src), ReferenceGuided(guide, src, r, o.eps), cv::NORM_INF),
        2e-5)
        << "guided, r " << r;
  }
}

TEST(GuidedFilter, LongColumnsDoNotDrift) {
  // 1024 rows: the vertical running sums add and subtract a thousand rows; they must not drift
  // away from OpenCV's (whose box filter sums in double). Same 1e-4 bound as above, the measured
  // difference is ~1e-5 (float rounding of the variance in both implementations).
  const cv::Mat guide = RandomImage(1024, 40, 1, 11);
  const cv::Mat src = RandomImage(1024, 40, 1, 12);
  for (const Case c : {Case{2, 0.01}, Case{8, 0.16}}) {
    GuidedFilterOptions o;
    o.radius = c.radius;
    o.eps = c.eps;
    cv::Mat self_ref, ref;
    cv::ximgproc::guidedFilter(guide, guide, self_ref, c.radius, c.eps, CV_32F);
    cv::ximgproc::guidedFilter(guide, src, ref, c.radius, c.eps, CV_32F);
    EXPECT_LE(InteriorMaxDiff(GuidedFilter(o, guide, guide), self_ref, 2 * c.radius), 1e-4);
    EXPECT_LE(InteriorMaxDiff(GuidedFilter(o, guide, src), ref, 2 * c.radius), 1e-4);
  }
}

TEST(GuidedFilter, NonContiguousInputsAndTinyImages) {
  // A view into a larger image (row stride != width) gives the same result as its copy; images
  // narrower or shorter than the window use the clipped window everywhere.
  const cv::Mat big = RandomImage(60, 80, 1, 13);
  const cv::Mat view = big(cv::Rect(7, 5, 50, 40));
  GuidedFilterOptions o;
  o.radius = 3;
  const cv::Mat a = GuidedFilter(o, view, view), b = GuidedFilter(o, view.clone(), view.clone());
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  for (cv::Size s : {cv::Size(1, 9), cv::Size(9, 1), cv::Size(2, 3)}) {
    const cv::Mat img = RandomImage(s.height, s.width, 1, 14);
    o.radius = 8;
    const cv::Mat q = GuidedFilter(o, img, img);
    EXPECT_TRUE(cv::checkRange(q, true, nullptr, -0.5, 1.5));
    // Reference: every window covers the whole image (radius >= size), so a, b are the same
    // for all pixels: q = a I + b with the image's own mean and variance.
    cv::Scalar mean, sd;
    cv::meanStdDev(img, mean, sd);
    const double var = sd[0] * sd[0];
    const double av = var / (var + o.eps);
    for (int y = 0; y < img.rows; ++y)
      for (int x = 0; x < img.cols; ++x)
        EXPECT_NEAR(q.at<float>(y, x), av * img.at<float>(y, x) + (1 - av) * mean[0], 1e-5);
  }
}

TEST(GuidedFilter, StreamedRowsEqualWholeImageFilters) {
  const cv::Mat img = RandomImage(70, 90, 1, 15);
  std::vector<GuidedFilterOptions> opts(3);
  opts[0].radius = 2, opts[0].eps = 0.01;
  opts[1].radius = 8, opts[1].eps = 0.16;
  opts[2].radius = 8, opts[2].eps = 0.16, opts[2].subsample = 2;
  std::vector<cv::Mat> got(opts.size());
  for (cv::Mat& m : got) m.create(img.size(), CV_32F);
  int next = 0;
  GuidedFilterSelfRows(opts, img, [&](int y, const std::vector<const float*>& rows) {
    EXPECT_EQ(y, next++);
    for (size_t k = 0; k < rows.size(); ++k) {
      std::copy(rows[k], rows[k] + img.cols, got[k].ptr<float>(y));
    }
  });
  EXPECT_EQ(next, img.rows);
  for (size_t k = 0; k < opts.size(); ++k) {
    EXPECT_EQ(cv::norm(got[k], GuidedFilter(opts[k], img, img), cv::NORM_INF), 0.0) << k;
  }
  // Three channels stream too (tests/enhancer/color_paths_test.cc); two do not.
  EXPECT_THROW(GuidedFilterSelfRows(opts, cv::Mat(4, 4, CV_32FC2, cv::Scalar::all(0)),
                                    [](int, const std::vector<const float*>&) {}),
               Error);
}

TEST(GuidedFilter, BoxMeanMatchesOpenCvInteriorAndClippedAtBorder) {
  const cv::Mat src = RandomImage(50, 70, 2, 5);
  const int r = 3;
  cv::Mat ours = BoxMean(src, r), ref;
  cv::blur(src, ref, cv::Size(2 * r + 1, 2 * r + 1));
  EXPECT_LE(InteriorMaxDiff(ours, ref, r), 1e-6);
  // Corner: the mean of the clipped (r+1)x(r+1) window.
  cv::Scalar corner = cv::mean(src(cv::Rect(0, 0, r + 1, r + 1)));
  EXPECT_NEAR(ours.at<cv::Vec2f>(0, 0)[0], corner[0], 1e-6);
  EXPECT_NEAR(ours.at<cv::Vec2f>(0, 0)[1], corner[1], 1e-6);
}

TEST(GuidedFilter, ConstantImageIsFixedPointAndHugeRadiusIsFinite) {
  cv::Mat c(7, 5, CV_32F, cv::Scalar(0.3));
  GuidedFilterOptions o;
  o.radius = 100;  // larger than the image: clipped window
  cv::Mat q = GuidedFilter(o, c, c);
  double lo, hi;
  cv::minMaxLoc(q, &lo, &hi);
  EXPECT_NEAR(lo, 0.3, 1e-6);
  EXPECT_NEAR(hi, 0.3, 1e-6);
  cv::Mat one(1, 1, CV_32F, cv::Scalar(0.7));
  EXPECT_NEAR(GuidedFilter(o, one, one).at<float>(0, 0), 0.7f, 1e-6);
}

TEST(GuidedFilter, EdgePreservedAndNoiseSmoothed) {
  // A step plus small noise: the guided filter keeps the step (variance >> eps) and removes the
  // noise (variance << eps).
  cv::Mat step(64, 64, CV_32F, cv::Scalar(0.2));
  step.colRange(32, 64).setTo(0.8);
  cv::Mat noise(64, 64, CV_32F);
  cv::RNG(7).fill(noise, cv::RNG::NORMAL, 0.0, 0.01);
  cv::Mat noisy = step + noise;
  GuidedFilterOptions o;  // r 4, eps 0.01
  cv::Mat q = GuidedFilter(o, noisy, noisy);
  EXPECT_NEAR(q.at<float>(32, 29), 0.2, 0.03);
  EXPECT_NEAR(q.at<float>(32, 34), 0.8, 0.03);
  cv::Scalar mean_in, sd_in, mean_out, sd_out;
  cv::meanStdDev((noisy - step)(cv::Rect(5, 5, 20, 50)), mean_in, sd_in);
  cv::meanStdDev((q - step)(cv::Rect(5, 5, 20, 50)), mean_out, sd_out);
  EXPECT_LT(sd_out[0], 0.5 * sd_in[0]);
}

TEST(GuidedFilter, FastVariantCloseToExact) {
  const cv::Mat guide = RandomImage(128, 128, 1, 9);
  GuidedFilterOptions exact;
  exact.radius = 8;
  exact.eps = 0.04;
  GuidedFilterOptions fast = exact;
  fast.subsample = 2;
  cv::Mat a = GuidedFilter(exact, guide, guide);
  cv::Mat b = GuidedFilter(fast, guide, guide);
  cv::Mat d;
  cv::absdiff(a, b, d);
  EXPECT_LT(cv::mean(d)[0], 0.01);
  // Colour guide, fast variant too.
  const cv::Mat color = RandomImage(64, 64, 3, 10);
  cv::Mat g;
  cv::cvtColor(color, g, cv::COLOR_BGR2GRAY);
  cv::Mat qa = GuidedFilter(exact, color, g), qb = GuidedFilter(fast, color, g);
  cv::absdiff(qa, qb, d);
  EXPECT_LT(cv::mean(d)[0], 0.01);
}

TEST(GuidedFilter, BadInputsThrow) {
  GuidedFilterOptions o;
  cv::Mat a(4, 4, CV_32F, cv::Scalar(0)), b(5, 4, CV_32F, cv::Scalar(0));
  EXPECT_THROW(GuidedFilter(o, a, b), Error);
  EXPECT_THROW(GuidedFilter(o, cv::Mat(), a), Error);
  EXPECT_THROW(GuidedFilter(o, cv::Mat(4, 4, CV_8U), a), Error);
  o.eps = -1;
  EXPECT_THROW(GuidedFilter(o, a, a), Error);
}

}  // namespace
}  // namespace turbid
