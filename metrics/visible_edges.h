// Blind contrast-enhancement indicators at visible edges: e, r̄ and σ.
//
// Paper: N. Hautière, J.-P. Tarel, D. Aubert, É. Dumont, "Blind contrast enhancement assessment by
// gradient ratioing at visible edges", Image Analysis & Stereology 27(2):87-95, 2008 (ICS'07):
//   e = (n_r − n_o) / n_o                       (Eq. 7; n = number of visible edges)
//   r̄ = exp( (1/n_r) Σ_{P_i ∈ ℘_r} log r_i ),  r_i = ‖∇R(P_i)‖ / ‖∇I(P_i)‖   (Eqs. 8-9)
//   σ = n_s / (dim_x · dim_y)                    (Eq. 10; n_s = pixels saturated to black or white)
// Visible edges: Köhler's segmentation on 7×7 windows with a step of 4; a window is visible when
// its best threshold's mean Weber contrast 2·C(s0) exceeds 5 % (CIE visibility threshold).
//
// Two variants (docs/metrics-no-reference.md):
//   kIfsttar  reproduces the IFSTTAR MATLAB code (functionContrastAt5PerCent.m +
//             EvaluationDescriptorCalculation.m, "23/02/2011 IFSTTAR copyright", as in
//             xiaofeng94/BeDDE-for-defogging@ec95608) exactly, its quirks included: the min/max
//             maps of the pair test are shifted one pixel up-left and asymmetric, thresholds are
//             clamped to [1, 256], the visibility mask's contrast map is overwritten by later
//             windows, r̄ divides by n_r although non-finite log ratios are dropped, and σ counts
//             `== 0 | == 256`, so white saturation (255) is never counted on 8-bit data.
//   kPaper    (default) follows the paper: the separation test uses min/max of the same pixel pair
//             whose Weber contrast is summed, and σ counts black (0) and white (255) pixels;
//             everything else (window, step, mirrored padding of the pair maps, thresholds
//             [round(min), round(max)] within [1, 256], first argmax, 5 % rule, Sobel gradients,
//             r̄'s normalisation by n_r) as kIfsttar. Verified against the reference README's
//             "intended algorithm" values (bit-exact e and σ).
//
// Input convention: images are float32 [0, 1] (or 8-bit), 1 or 3 channels (BGR). These metrics are
// defined on 8-bit file values: float input is taken as file value / 255 and quantised back with
// round(255·v) (exact for images read from 8-bit files); colour is converted with
// OctaveRgbToGray(), which is what the published code's comment prescribes
// (double(rgb2gray(uint8(I)))).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>

namespace turbid {

enum class VisibleEdgeVariant {
  kPaper,    // "paper": the paper's definitions (default)
  kIfsttar,  // "ifsttar": bit-for-bit the published IFSTTAR MATLAB code, bugs included
};

std::string VisibleEdgeVariantName(VisibleEdgeVariant variant);  // "paper" | "ifsttar"
// Throws Error for names other than "paper" and "ifsttar".
VisibleEdgeVariant ParseVisibleEdgeVariant(const std::string& name);

struct VisibleEdgeOptions {
  // Which definition to compute (see the file comment). Default: the paper's.
  VisibleEdgeVariant variant = VisibleEdgeVariant::kPaper;
  // Visibility threshold on the mean Weber contrast 2·C(s0) of a window, (0, 1]. 0.05 = the CIE
  // 5 % threshold used by Hautière 2008 Sec. 3 (the code tests C(s0) > 0.05 / 2, the same thing).
  double visibility_threshold = 0.05;
  bool Check(std::string* why) const;
};

struct VisibleEdgeResult {
  double e = 0.0;  // rate of new visible edges (n_r − n_o)/n_o; ±inf/NaN when n_o = 0 (see docs)
  double r_mean = 0.0;  // geometric mean of gradient ratios at the restored image's visible edges
  double sigma = 0.0;   // saturated-pixel FRACTION of the restored image (not %), variant rules
  // The source paper's Table I column "m": most plausibly σ as the published code returns it, i.e.
  // the black-pixel fraction black_pixels / pixels on 8-bit data, whatever the variant (see docs).
  double m = 0.0;
  int64_t visible_original = 0;   // n_o: pixels in the original's visible-edge mask
  int64_t visible_restored = 0;   // n_r: pixels in the restored image's visible-edge mask
  int64_t finite_log_ratios = 0;  // terms of r̄'s sum (mask pixels with finite log(GR/GI))
  int64_t black_pixels = 0;       // restored gray pixels == 0
  int64_t white_pixels = 0;       // restored gray pixels == 255 (counted in σ only by kPaper)
  int64_t pixels = 0;             // rows · cols
  std::string variant;            // "paper" | "ifsttar"
  // Keys: variant, e, r_mean, sigma, sigma_percent, m, visible_original, visible_restored,
  // finite_log_ratios, black_pixels, white_pixels, pixels. Non-finite values become strings
  // "inf", "-inf", "nan".
  nlohmann::json ToJson() const;
};

// e, r̄ and σ of a restoration. `original` is the degraded input the restoration started from,
// `restored` the enhanced image. Same size required; channels may differ (each is made gray).
// Throws Error for empty images, size mismatch, unsupported types, NaN/inf, or bad options.
VisibleEdgeResult VisibleEdges(const VisibleEdgeOptions& options, const cv::Mat& original,
                               const cv::Mat& restored);

// The original's half of VisibleEdges, for scoring many restorations of one original (a sweep
// scores every method against the same degraded image): its 8-bit gray image, visible-edge mask
// and count n_o. VisibleEdges(options, AnalyseVisibleEdgeOriginal(options, original), restored)
// equals VisibleEdges(options, original, restored) in every field (tested).
struct VisibleEdgeOriginal {
  VisibleEdgeOptions options;  // what it was computed with (VisibleEdges checks they match)
  cv::Mat gray8;               // CV_8UC1, as the published code sees the original
  cv::Mat mask;                // CV_8UC1, 255 = visible edge pixel
  int64_t visible = 0;         // n_o
};
VisibleEdgeOriginal AnalyseVisibleEdgeOriginal(const VisibleEdgeOptions& options,
                                               const cv::Mat& original);
// A restored image whose gray values equal the original's (e.g. the unprocessed input) reuses the
// original's mask.
VisibleEdgeResult VisibleEdges(const VisibleEdgeOptions& options,
                               const VisibleEdgeOriginal& original, const cv::Mat& restored);

// The visible-edge mask alone (CV_8U, 255 = visible edge pixel) of a gray image given as CV_64F
// values 0..255 (e.g. from ToGray255()). Exposed for inspection, tests and benchmarks.
cv::Mat VisibleEdgeMask(const VisibleEdgeOptions& options, const cv::Mat& gray255);

// Octave's rgb2gray on uint8 (image package 2.14): round-half-away(0.298936 R + 0.587043 G +
// 0.114021 B) on 8-bit values; the coefficients are the 6-digit ones Octave uses. Input: 8-bit BGR
// (CV_8UC3). Output: CV_8UC1.
cv::Mat OctaveRgbToGray(const cv::Mat& bgr8);

// Any accepted input (CV_8U or CV_32F [0,1]; 1 or 3 channels) → CV_64FC1 gray with 8-bit values
// 0..255 exactly as the published code sees it: quantise to 8 bits, then OctaveRgbToGray for
// colour. `what` names the image in error messages.
cv::Mat ToGray255(const cv::Mat& image, const std::string& what);

// Quantises an accepted input to 8 bits (round(255·v), clamped) keeping channels; CV_8U passes
// through. Throws Error for empty, unsupported type/channels, or non-finite values.
cv::Mat ToEightBit(const cv::Mat& image, const std::string& what);

}  // namespace turbid
