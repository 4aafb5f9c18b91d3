// Pixel-error and contrast scores: MSE, PSNR (full reference) and CNR (no reference).
//
// MSE  = (1 / (N C)) sum over all N pixels and C channels of (x - y)^2, on the input's own scale.
// PSNR = 10 log10(L^2 / MSE), L = data range; identical images give +inf. Matches scikit-image
//        0.19 `mean_squared_error` / `peak_signal_noise_ratio(data_range=L)` to 1e-9 relative
//        (exact integer arithmetic for 8-bit inputs; double accumulation otherwise).
// CNR  = |mu_s - mu_b| / sqrt(sigma_s^2 + sigma_b^2), the contrast-to-noise ratio between a
//        signal region s and a background region b with the noise pooled from both regions
//        (population standard deviations): the two-region form of the CNR definitions reviewed by
//        M. Welvaert, Y. Rosseel, "On the definition of signal-to-noise ratio and contrast-to-noise
//        ratio for fMRI data", PLoS ONE 8(11):e77089, 2013 (the source paper cites its [8] for CNR
//        but states no formula). Without explicit regions, s and b
//        are the two classes of Otsu's threshold (N. Otsu, IEEE TSMC 9(1):62-66, 1979) on the
//        8-bit quantised luminance, so CNR measures how well the image's bright content
//        stands out from its dark content relative to the spread inside each. Colour images use
//        Rec. 601 luma Y = 0.299 R + 0.587 G + 0.114 B (as cv::cvtColor BGR2GRAY), gray images
//        their value. CNR is scale-free (same on [0,1] and [0,255] inputs).
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace turbid {

struct PsnrOptions {
  // Peak-to-peak value range L. 0 = from the input depth: 255 for 8-bit, 65535 for 16-bit, 1 for
  // float images ([0, 1] convention).
  double data_range = 0.0;
  bool Check(std::string* why) const;
};

// Mean squared error over all pixels and channels. Both images: same size, channels and depth
// (8U, 16U, 32F, 64F), finite; throws Error otherwise.
double Mse(const cv::Mat& reference, const cv::Mat& image);

// Peak signal-to-noise ratio in dB; +inf when the images are identical.
double Psnr(const PsnrOptions& options, const cv::Mat& reference, const cv::Mat& image);
// PSNR from an already computed MSE (shared work in the registry).
double PsnrFromMse(double mse, double data_range);

struct CnrOptions {
  // Optional region masks (CV_8U, same size as the image, non-zero = inside). When both are empty
  // the regions are the two Otsu classes of the luminance (bright = signal, dark = background).
  cv::Mat signal_mask;
  cv::Mat background_mask;
  // Peak value of the pixel scale, used only to quantise for Otsu's threshold. 0 = from depth.
  double data_range = 0.0;
  bool Check(std::string* why) const;
};

struct CnrResult {
  double cnr = 0.0;  // 0 when a region is empty (constant image); +inf when both regions are flat
                     // but differ
  double signal_mean = 0.0;
  double background_mean = 0.0;
  double signal_std = 0.0;
  double background_std = 0.0;
  long long signal_pixels = 0;
  long long background_pixels = 0;
  int otsu_threshold = -1;  // 0..255 on the quantised luminance; -1 when masks were given
};

// CNR of one image (1-4 channels; the 4th is ignored). Throws Error for empty / non-finite input,
// bad masks, or bad options.
CnrResult Cnr(const CnrOptions& options, const cv::Mat& image);

// Luminance as float32 on the input's scale: the single channel for gray, Rec. 601 luma for
// colour (BGR order). Shared by the registry between metrics that need a gray image.
cv::Mat Luminance(const cv::Mat& image);

}  // namespace turbid
