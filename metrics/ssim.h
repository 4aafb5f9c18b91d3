// Structural similarity (SSIM). Wang, Bovik, Sheikh, Simoncelli, "Image quality assessment: from
// error visibility to structural similarity", IEEE TIP 13(4), 2004, Eq. 13 with the Gaussian
// window of Sec. III-C (11x11, sigma 1.5) and K1 = 0.01, K2 = 0.03.
//
// Matches scikit-image 0.19 `structural_similarity(gaussian_weights=True, sigma=1.5,
// use_sample_covariance=False, data_range=R)` to <= 1e-6 absolute (tests/metrics/ssim_test.cc):
//   - local moments are Gaussian-filtered with scipy.ndimage 'reflect' borders (d c b a | a b c d),
//     kernel radius int(truncate * sigma + 0.5) = 5 taps each side (truncate = 3.5);
//   - population (co)variances: E[xy] - E[x]E[y];
//   - the mean is taken over the map with (win_size - 1) / 2 = 5 pixels cropped on each side;
//   - colour: SSIM per channel, then the plain mean over channels.
// MATLAB's `ssim` differs: it filters with 'replicate' borders and averages the whole map (no
// crop), so its numbers differ from ours by up to ~1e-3 on typical images (docs/metrics.md).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace turbid {

struct SsimOptions {
  // Standard deviation of the Gaussian window in pixels, > 0. Wang 2004 Sec. III-C: 1.5.
  double sigma = 1.5;
  // Kernel radius = int(truncate * sigma + 0.5); 3.5 gives the 11-tap window of Wang 2004 and is
  // what scikit-image hard-codes for gaussian_weights=True. Range (0, 20].
  double truncate = 3.5;
  // Luminance stabiliser C1 = (k1 * data_range)^2. Wang 2004 Eq. 7: 0.01. Range (0, 1).
  double k1 = 0.01;
  // Contrast/structure stabiliser C2 = (k2 * data_range)^2. Wang 2004 Eq. 9: 0.03. Range (0, 1).
  double k2 = 0.03;
  // Dynamic range L of the pixel values (max - min possible). 0 = from the input depth: 255 for
  // 8-bit, 65535 for 16-bit, 1 for float images (our in-memory convention is [0, 1]).
  double data_range = 0.0;
  // Also return the full-size per-pixel SSIM map (costs one float image per channel).
  bool compute_map = false;
  // false (default): the fused kernels, one pass per row band (8-bit: float32 moments, whose
  // centred products are exact; 16-bit and float: float64 moments); within 1e-6 of scikit-image
  // (docs/metrics.md gives the measured worst cases). true: the plain double-precision path for
  // every depth (OpenCV sepFilter2D on five full-size CV_64F moment images), ~1e-12 from
  // scikit-image and several times slower; for cross-checks and bit-level comparisons.
  bool exact_double = false;

  bool Check(std::string* why) const;
};

struct SsimResult {
  double mean = 0.0;                // mean over channels of the per-channel cropped-map means
  std::vector<double> per_channel;  // one cropped-map mean per channel, in the input's order
  cv::Mat map;                      // CV_32FC(n), full size; empty unless compute_map
};

// Both images: same size and channel count (1-4), depth 8U, 16U, 32F or 64F, at least
// (2 * radius + 1) pixels in each dimension (11 with the defaults). Float inputs must be finite.
// Throws Error otherwise. Constant images are fine: C1, C2 > 0 keep the formula defined (two equal
// constant images score exactly 1). The result does not depend on the OpenCV thread count.
SsimResult Ssim(const SsimOptions& options, const cv::Mat& reference, const cv::Mat& image);

// Kernel radius for the options (5 with the defaults); the crop used for the mean.
int SsimRadius(const SsimOptions& options);

}  // namespace turbid
