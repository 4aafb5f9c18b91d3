// The blind light scale's veil-model fit as a transcription in double, shared by the tests of
// `full`'s light scale (color_paths_test.cc, full_light_scale_test.cc): the normal equations
// summed sample by sample as cv::Matx, Cholesky, the 80 % residual trim by std::nth_element and a
// second solve. samples[i] = (x0, x1, x2, y); false when the fit is refused. Then the choice
// between the fit and the ratio bound.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <opencv2/core.hpp>
#include <vector>

#include "enhancer/paper/full.h"

namespace turbid {

inline bool ReferenceFitVeilModel(const std::vector<cv::Vec4d>& samples, cv::Vec3d* c) {
  if (samples.size() < 16) return false;
  std::vector<char> use(samples.size(), 1);
  for (int pass = 0; pass < 2; ++pass) {
    cv::Matx33d ata = cv::Matx33d::zeros();
    cv::Vec3d atb(0, 0, 0);
    for (size_t i = 0; i < samples.size(); ++i) {
      if (!use[i]) continue;
      const cv::Vec3d x(samples[i][0], samples[i][1], samples[i][2]);
      ata += x * x.t();
      atb += x * samples[i][3];
    }
    cv::Vec3d solution;
    if (!cv::solve(ata, atb, solution, cv::DECOMP_CHOLESKY)) return false;
    cv::Vec3d eig;
    cv::eigen(ata, eig);
    if (!(eig[2] > 1e-9 * eig[0])) return false;
    *c = solution;
    if (pass == 1) break;
    std::vector<double> residuals(samples.size());
    for (size_t i = 0; i < samples.size(); ++i) {
      residuals[i] = std::abs(solution[0] * samples[i][0] + solution[1] * samples[i][1] +
                              solution[2] * samples[i][2] - samples[i][3]);
    }
    std::vector<double> sorted = residuals;
    const size_t k = sorted.size() * 8 / 10;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
    for (size_t i = 0; i < samples.size(); ++i) use[i] = residuals[i] <= sorted[k];
  }
  return std::isfinite((*c)[0]) && std::isfinite((*c)[1]) && std::isfinite((*c)[2]);
}

// One channel's estimate from its ratio bound and its samples: the fit when usable (0 < c1,
// 0 <= c2 <= c1) and the smaller of fit and bound, else the bound.
inline void ReferenceChooseLightScale(const std::vector<cv::Vec4d>& samples, double bound,
                                      LightScaleEstimate* e) {
  e->bound = bound;
  cv::Vec3d fit;
  if (ReferenceFitVeilModel(samples, &fit) && fit[1] > 0 && fit[2] >= 0 && fit[2] <= fit[1]) {
    e->fit = fit[1];
    e->scale = std::min(e->fit, e->bound);
    e->source = e->fit <= e->bound ? "fit" : "bound";
  } else {
    e->scale = e->bound;
    e->source = "bound (no usable fit)";
  }
}

}  // namespace turbid
