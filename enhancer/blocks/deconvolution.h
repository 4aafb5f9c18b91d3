// Deconvolution with a known PSF (paper §III-A.4: J_deblur = DECONV(J_plane, h_psf), with the
// generalized-Gaussian PSF of eq. 7 built by simulator/psf.h).
//  - Wiener: J = F^-1[ conj(H) G / (|H|^2 + NSR) ] (Gonzalez & Woods, Digital Image Processing,
//    3rd ed., §5.8, eq. 5.8-6 with a constant noise-to-signal power ratio K = NSR).
//  - Richardson-Lucy: u <- u (h^T * (g / (h * u))) (Richardson, JOSA 62(1) 1972; Lucy, AJ 79(6)
//    1974), started from g, with a floor on the denominator.
// Edges: the image is padded by mirroring, and the padded frame is tapered towards its own
// circular blur over a raised-cosine ramp (the idea of MATLAB's edgetaper) so the periodic FFT sees
// no jump; the image region itself is untouched. Wiener with small PSFs runs in the spatial domain
// instead: the inverse filter is computed once by FFT on a small grid, truncated where it is
// negligible, and applied as a sum of separable 1-D passes (its SVD) with mirrored borders.
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <string>

namespace turbid {

enum class DeconvolutionMethod { kWiener, kRichardsonLucy };
// "wiener" | "richardson_lucy"; throws Error for other names.
DeconvolutionMethod DeconvolutionMethodFromName(const std::string& name);
std::string DeconvolutionMethodName(DeconvolutionMethod method);

struct DeconvolutionOptions {
  DeconvolutionMethod method = DeconvolutionMethod::kWiener;
  // Wiener noise-to-signal power ratio K, in [1e-8, 10]. Larger: less sharpening, less noise.
  // 0.01 (our choice; the paper does not state one) restores a T = 4, q = 0.9 blur without
  // amplifying 8-bit quantisation noise visibly.
  double nsr = 0.01;
  // Richardson-Lucy iterations, in [1, 1000].
  int iterations = 20;
  // Mirror-pad and taper the frame (against wrap-around ringing); off only for tests.
  bool taper = true;
  // Wiener in the spatial domain (separable passes) when the truncated inverse filter has a
  // radius <= this, pixels, in [0, 64] (0: always FFT).
  int spatial_max_radius = 12;

  bool Check(std::string* why) const;
};

// Deconvolves `image` (CV_32F, 1 or 3 channels; each channel alone) with the normalised,
// odd-sized CV_32FC1 kernel `psf`. Returns the same size and type, not clamped. A 1x1 kernel
// returns a copy. Throws Error for empty or mismatched inputs or options failing Check.
cv::Mat Deconvolve(const DeconvolutionOptions& options, const cv::Mat& image, const cv::Mat& psf);

// Deconvolve on the spatial Wiener path, streamed: emit(y, row) receives output row y
// (`image.cols * channels` floats, interleaved, valid during the call) in order, with no full-size
// output. Returns false without emitting when the options and PSF select another path (FFT
// Wiener, Richardson-Lucy, a 1x1 PSF): use Deconvolve then. Throws Error as Deconvolve does, and
// for images with other than 1 or 3 channels.
bool DeconvolveRows(const DeconvolutionOptions& options, const cv::Mat& image, const cv::Mat& psf,
                    const std::function<void(int, const float*)>& emit);

// DeconvolveRows over an image given row by row: source(y) returns input row y (size.width *
// channels floats). For output row y it is asked for rows in [y - k, y + k] only (k: the inverse
// filter's radius, at most spatial_max_radius), so a producer can keep the last 2k + 1 rows.
bool DeconvolveRowsFrom(const DeconvolutionOptions& options, cv::Size size, int channels,
                        const std::function<const float*(int)>& source, const cv::Mat& psf,
                        const std::function<void(int, const float*)>& emit);

// The spatial Wiener inverse filter (odd square CV_32FC1) for `psf` at `nsr`, truncated where
// |w| < 1e-4 max|w| (exposed for tests).
cv::Mat WienerInverseKernel(const cv::Mat& psf, double nsr);

// How the spatial Wiener path applies its inverse filter: `kernel` (odd square CV_32FC1) as the
// sum of its SVD's separable terms until they hold 1 - 1e-7 of its energy, mirrored borders
// (BORDER_REFLECT_101), on an image of 1 or 3 interleaved channels (each channel alone); exposed
// for tests.
cv::Mat ApplySeparableKernel(const cv::Mat& image, const cv::Mat& kernel);

// Circular-free convolution helper used by tests: image * psf with mirrored borders.
cv::Mat ConvolveMirrored(const cv::Mat& image, const cv::Mat& psf);

}  // namespace turbid
