// The slow, obviously-correct small-angle forward scatter (psf.model "small_angle") that the fast
// path (simulator/psf_small_angle.h: shared widths, a DFT of the mirrored image, the glow
// interpolated between widths) is checked against: every pixel and channel gathers with its own
// Gaussian, at its own range, by direct summation over integer offsets (to 12 sigma) with the
// mirrored border of cv::borderInterpolate, in double:
//   out(x) = J(x) + (e^{b_f r(x)} - 1) sum_{i,j} g_x(i) g_y(j) J(x - i, y - j) / (sum g_x sum g_y),
//   g(i) = exp(-i^2 / (2 sigma^2)),  sigma_x = |fx| sqrt(<psi^2> / 2),  sigma_y likewise,
//   <psi^2> = b_f r <theta^2> / (3 (1 - e^{-b_f r})),  b_f = b (1 - b_b/b),
// <theta^2> = PhaseFunction::MeanSquareAngle(pi/2). Written out again here (not calling the code
// under test). CV_64FC(channels).
#pragma once

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

#include "scenes/scene.h"
#include "simulator/phase_function.h"
#include "simulator/veil.h"

namespace turbid::testing {

// The normalised weights that pixel `at` of an axis of length n gathers from each pixel of the
// axis under a Gaussian of sigma (0: a delta), offsets to 12 sigma, mirrored as OpenCV does.
inline std::vector<double> ReferenceAxisWeights(int at, int n, double sigma) {
  std::vector<double> w(static_cast<size_t>(n), 0.0);
  if (sigma <= 0.0) {
    w[at] = 1.0;
    return w;
  }
  const int radius = static_cast<int>(std::ceil(12.0 * sigma)) + 1;
  double total = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    const double g = std::exp(-0.5 * i * i / (sigma * sigma));
    w[cv::borderInterpolate(at - i, n, cv::BORDER_REFLECT_101)] += g;
    total += g;
  }
  for (double& v : w) v /= total;
  return w;
}

// J blurred at (x, y) of channel c with per-axis sigmas, by the weights above.
inline double ReferenceGaussianAt(const cv::Mat& image, int c, int x, int y, double sigma_x,
                                  double sigma_y) {
  const std::vector<double> wx = ReferenceAxisWeights(x, image.cols, sigma_x);
  const std::vector<double> wy = ReferenceAxisWeights(y, image.rows, sigma_y);
  const int ch = image.channels();
  double sum = 0.0;
  for (int q = 0; q < image.rows; ++q) {
    if (wy[q] == 0.0) continue;
    const float* row = image.ptr<float>(q);
    double s = 0.0;
    for (int p = 0; p < image.cols; ++p) s += wx[p] * row[p * ch + c];
    sum += wy[q] * s;
  }
  return sum;
}

inline cv::Mat ReferenceSmallAnglePsf(const VeilWater& water, const CameraIntrinsics& camera,
                                      const cv::Mat& range_m, const cv::Mat& image) {
  const PhaseFunction phase(water.phase);
  const double forward_share = 1.0 - phase.BackscatterRatio();
  const double theta2 = phase.MeanSquareAngle(3.14159265358979323846 / 2.0);
  const int ch = image.channels();
  cv::Mat out(image.size(), CV_64FC(ch));
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x)
      for (int c = 0; c < ch; ++c) {
        const double j = image.ptr<float>(y)[x * ch + c];
        const double r = range_m.at<float>(y, x);
        const double bf = water.b_per_m[c] * forward_share;
        double value = j;
        if (!std::isnan(r) && bf > 0.0) {
          const double tau = bf * r;
          const double psi2 = theta2 * (tau > 1e-8 ? tau / (1.0 - std::exp(-tau)) : 1.0) / 3.0;
          const double sigma = std::sqrt(psi2 / 2.0);
          value +=
              std::expm1(tau) * ReferenceGaussianAt(image, c, x, y, std::abs(camera.fx) * sigma,
                                                    std::abs(camera.fy) * sigma);
        }
        out.ptr<double>(y)[x * ch + c] = value;
      }
  return out;
}

}  // namespace turbid::testing
