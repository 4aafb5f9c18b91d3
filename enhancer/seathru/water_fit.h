// Sea-thru's water estimate from real RGB-D (D. Akkaynak, T. Treibitz, "Sea-thru: A Method for
// Removing Water From Underwater Images", CVPR 2019): the backscatter
// B_c(r) = B∞_c (1 − e^{−β^B_c r}) + J'_c e^{−β'_c r} fitted to the darkest pixels per range bin,
// the illuminant by a local space average colour of the direct signal, and β^D_c(r) as a two-term
// exponential a e^{b r} + c e^{d r} fitted to the illuminant's decay with range. Several images of
// the same water are fitted together. Where this differs from the paper and from its public
// re-implementations, docs/cli/water.md says how and why. Channels are R, G, B (index 0 = R)
// everywhere in this header; images are turbid's B, G, R.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/fields.h"

namespace turbid {

using Rgb3 = std::array<double, 3>;  // R, G, B

struct WaterFitOptions {
  int range_bins = 10;         // backscatter: evenly spaced bins over [min, max] range (paper: 10)
  double dark_percent = 1.0;   // backscatter: darkest % of each bin by R+G+B (paper: 1)
  int illuminant_layers = 12;  // illuminant: range layers of the local average
  double illuminant_extent = 0.1;  // illuminant: box radius as a fraction of the longer side
  int attenuation_bins = 24;       // β^D: range bins of the illuminant's log
  // β^D: true = the illuminant's scale k_c is fitted with β^D (ln Ê = ln k − β^D(r) r); false =
  // the paper's fixed Ê = f·a with f = 2 (grey-world reflectance 0.5).
  bool fit_illuminant_scale = true;
  bool Check(std::string* why) const;
};
const Fields<WaterFitOptions>& WaterFitFields();

// One frame: linear image (CV_32FC3, B, G, R, [0, 1]) and range along the ray (CV_32FC1, metres,
// NaN or <= 0 = invalid), same size.
struct WaterFitFrame {
  cv::Mat image;
  cv::Mat range_m;
  std::string name;
};

struct BackscatterFit {
  Rgb3 b_inf{}, beta_b{}, j_prime{}, beta_prime{};  // per channel; β in 1/m
  Rgb3 rms{};                                       // residual RMS over the dark pixels
  // The dark pixels used (range, R, G, B), and per range bin: centre, count, the median of the dark
  // pixels, the fitted curve there.
  std::vector<std::array<float, 4>> dark;
  std::vector<double> bin_range_m;
  std::vector<Rgb3> bin_dark_median, bin_fitted;
  double Evaluate(int c, double r) const;  // B_c(r)
};

struct AttenuationFit {
  Rgb3 a{}, b{}, c{}, d{};  // β^D_c(r) = a e^{b r} + c e^{d r}, 1/m
  Rgb3 log_scale{};         // ln k_c (the illuminant's scale)
  Rgb3 rms{};               // residual RMS of ln Ê over the bins
  // Per range bin: centre, pixel count, the per-pixel estimate −ln(Ê/k)/r (median) and the fit.
  std::vector<double> bin_range_m;
  std::vector<int> bin_count;
  std::vector<Rgb3> bin_beta, bin_fitted;
  double Beta(int c, double r) const;  // β^D_c(r)
};

struct WaterFit {
  BackscatterFit backscatter;
  AttenuationFit attenuation;
  double min_range_m = 0.0, max_range_m = 0.0;
  long long valid_pixels = 0;
  int frames = 0;
};

// Fits the water to the frames together. Throws Error when they hold too few valid pixels or
// ranges (fewer than 2 non-empty range bins).
WaterFit FitWater(const std::vector<WaterFitFrame>& frames, const WaterFitOptions& options = {});

// Backscatter only (the first stage), for tests and the enhancer.
BackscatterFit FitBackscatter(const std::vector<WaterFitFrame>& frames,
                              const WaterFitOptions& options);
// The direct signal D = max(I − B(r), 0) (B, G, R; 0 where the range is invalid).
cv::Mat DirectSignal(const WaterFitFrame& frame, const BackscatterFit& backscatter);
// The local space average colour of D (B, G, R): a normalised box average of half-width
// radius·max(w, h) over the pixels of similar range (range layers with linear weights, a bilateral
// grid); 0 where the range is invalid.
cv::Mat LocalAverageColour(const cv::Mat& direct, const cv::Mat& range_m,
                           const WaterFitOptions& options);

}  // namespace turbid
