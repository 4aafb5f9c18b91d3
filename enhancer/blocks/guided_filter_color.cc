// The guided filter with a colour guide (He 2013 eqs. 19-21): the coefficients from 13 box
// means of the guide, the source and their products, then their box means applied to the guide.
#include "enhancer/blocks/guided_filter_color.h"

#include <opencv2/core.hpp>
#include <vector>

#include "core/row_kernel.h"
#include "enhancer/blocks/box_filter.h"
#include "simulator/image_pool.h"

namespace turbid::guided_internal {
namespace {

TURBID_ROW_KERNEL void MultiplyRows(const float* __restrict u, const float* __restrict v,
                                    float* __restrict out, int w) {
  for (int x = 0; x < w; ++x) out[x] = u[x] * v[x];
}

// The colour-guide coefficients of one pixel (He 2013 eqs. 19-21) from the 13 box means.
TURBID_ROW_KERNEL void ColorCoefficientRow(const float* const* __restrict m, double eps,
                                           float* __restrict a0, float* __restrict a1,
                                           float* __restrict a2, float* __restrict bb, int w) {
  const float* __restrict m0 = m[0];
  const float* __restrict m1 = m[1];
  const float* __restrict m2 = m[2];
  const float* __restrict m3 = m[3];
  const float* __restrict m4 = m[4];
  const float* __restrict m5 = m[5];
  const float* __restrict m6 = m[6];
  const float* __restrict m7 = m[7];
  const float* __restrict m8 = m[8];
  const float* __restrict m9 = m[9];
  const float* __restrict m10 = m[10];
  const float* __restrict m11 = m[11];
  const float* __restrict m12 = m[12];
  for (int x = 0; x < w; ++x) {
    const double mu0 = m0[x], mu1 = m1[x], mu2 = m2[x], mp = m3[x];
    const double s00 = m4[x] - mu0 * mu0 + eps, s01 = m5[x] - mu0 * mu1, s02 = m6[x] - mu0 * mu2,
                 s11 = m7[x] - mu1 * mu1 + eps, s12 = m8[x] - mu1 * mu2,
                 s22 = m9[x] - mu2 * mu2 + eps;
    const double c0 = m10[x] - mu0 * mp, c1 = m11[x] - mu1 * mp, c2 = m12[x] - mu2 * mp;
    // Symmetric 3x3 inverse by cofactors; Sigma + eps I is positive definite for eps > 0.
    const double i00 = s11 * s22 - s12 * s12, i01 = s02 * s12 - s01 * s22,
                 i02 = s01 * s12 - s02 * s11, i11 = s00 * s22 - s02 * s02,
                 i12 = s01 * s02 - s00 * s12, i22 = s00 * s11 - s01 * s01;
    const double det = s00 * i00 + s01 * i01 + s02 * i02;
    const double inv = 1.0 / det;
    const double v0 = (i00 * c0 + i01 * c1 + i02 * c2) * inv;
    const double v1 = (i01 * c0 + i11 * c1 + i12 * c2) * inv;
    const double v2 = (i02 * c0 + i12 * c1 + i22 * c2) * inv;
    a0[x] = static_cast<float>(v0);
    a1[x] = static_cast<float>(v1);
    a2[x] = static_cast<float>(v2);
    bb[x] = static_cast<float>(mp - v0 * mu0 - v1 * mu1 - v2 * mu2);
  }
}

// q = mean a . I + mean b, in the order (and float roundings) of
// m0.mul(g0) + m1.mul(g1) + m2.mul(g2) + m3.
TURBID_ROW_KERNEL void ColorApplyRow(const float* __restrict m0, const float* __restrict m1,
                                     const float* __restrict m2, const float* __restrict m3,
                                     const float* __restrict g0, const float* __restrict g1,
                                     const float* __restrict g2, float* __restrict q, int w) {
  for (int x = 0; x < w; ++x) {
    const float p0 = m0[x] * g0[x], p1 = m1[x] * g1[x], p2 = m2[x] * g2[x];
    q[x] = ((p0 + p1) + p2) + m3[x];
  }
}

}  // namespace

// Colour guide (He 2013 eqs. 19-21): a = (Sigma + eps U)^-1 cov(I, p), b = mean p - a . mean I.
// The 13 planes (I, p, the 6 products I_i I_j and the 3 products I_i p) are box-averaged with the
// products formed row by row; the coefficients go to four full-size planes (the second box
// filter reads them).
std::vector<cv::Mat> ColorCoefficients(const std::vector<cv::Mat>& g, const cv::Mat& src, int r,
                                       double eps) {
  const int h = src.rows;
  const int w = src.cols;
  // Planes 0-3: g0, g1, g2, src; 4-9: g0g0 g0g1 g0g2 g1g1 g1g2 g2g2; 10-12: g0 src, g1 src, g2 src.
  static constexpr int kFactors[13][2] = {{0, -1}, {1, -1}, {2, -1}, {3, -1}, {0, 0},
                                          {0, 1},  {0, 2},  {1, 1},  {1, 2},  {2, 2},
                                          {0, 3},  {1, 3},  {2, 3}};
  const cv::Mat* base[4] = {&g[0], &g[1], &g[2], &src};
  const PlaneRows rows = [&](int k, int y, float* scratch) -> const float* {
    const float* u = base[kFactors[k][0]]->ptr<float>(y);
    if (kFactors[k][1] < 0) return u;
    MultiplyRows(u, base[kFactors[k][1]]->ptr<float>(y), scratch, w);
    return scratch;
  };
  std::vector<cv::Mat> coef(4);
  for (cv::Mat& c : coef) c.create(h, w, CV_32F);
  BoxMeansRows(13, h, w, r, rows, [&](int y, const std::vector<const float*>& m) {
    ColorCoefficientRow(m.data(), eps, coef[0].ptr<float>(y), coef[1].ptr<float>(y),
                        coef[2].ptr<float>(y), coef[3].ptr<float>(y), w);
  });
  return coef;
}

// The colour-guided output from the coefficients (their box means, then a . I + b).
cv::Mat ColorApply(const std::vector<cv::Mat>& coef, const std::vector<cv::Mat>& g, int r) {
  const int w = g[0].cols;
  cv::Mat q = internal::PooledMat(g[0].size(), CV_32F);
  BoxMeansRows(coef, r, [&](int y, const std::vector<const float*>& m) {
    ColorApplyRow(m[0], m[1], m[2], m[3], g[0].ptr<float>(y), g[1].ptr<float>(y),
                  g[2].ptr<float>(y), q.ptr<float>(y), w);
  });
  return q;
}

}  // namespace turbid::guided_internal
