// Fused SSIM kernel in double precision, for float and 16-bit inputs (metrics/ssim.cc picks it).
// Same definition as metrics/ssim.h (Wang 2004 Eq. 13, scikit-image reflect borders and crop);
// this header only exists so that the kernel can live in its own file.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace turbid::ssim_internal {

// One channel of SSIM with the five Gaussian-windowed moments accumulated in float64. taps: the
// 2r + 1 normalised, symmetric Gaussian weights (r = radius). offset: subtracted from every value
// before the products (data_range / 2), which keeps the moments small; the variances are
// shift-invariant and the means get it back. c1, c2: the stabilisers. map: CV_32F of the input's
// size to fill (every pixel), or nullptr (then only the cropped region is computed). Returns the
// mean of the map over the crop (r pixels on each side). Deterministic: the same bits whatever the
// OpenCV thread count.
double FusedDoubleSsimChannel(const cv::Mat& reference, const cv::Mat& image, int channel,
                              const std::vector<double>& taps, double offset, double c1, double c2,
                              cv::Mat* map);

}  // namespace turbid::ssim_internal
