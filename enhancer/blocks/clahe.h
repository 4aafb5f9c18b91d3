// Contrast-limited adaptive histogram equalisation with MATLAB `adapthisteq` semantics
// (Zuiderveld, "Contrast limited adaptive histogram equalization", Graphics Gems IV, 1994; MATLAB
// Image Processing Toolbox documentation of adapthisteq): the paper's last step (§III-A.5,
// Rayleigh target, α = 0.4).
//
// adapthisteq semantics reproduced here (docs/methods.md has the details):
//  - the image is split into tiles_y x tiles_x contextual regions; when the size is not divisible
//    by the tile count, or the tile size would be odd, the image is padded by mirroring (MATLAB
//    'symmetric') to the next multiple with an even tile size, half the padding before the first
//    row/column and the rest after the last (adapthisteq's parseInputs), and the padding is
//    dropped at the end;
//  - values are binned as imhist bins [0,1] data: bin = round(v * (bins - 1));
//  - clip limit as a fraction c in [0,1]: with P pixels per tile, the count limit is
//    ceil(P / bins) + round(c * (P - ceil(P / bins))); the excess above it is redistributed as
//    adapthisteq's clipHistogram does (an even share per bin, then the remainder one count at a
//    time with a growing stride);
//  - the mapping of each tile is the cumulative histogram shaped to the target distribution
//    (uniform, Rayleigh with parameter α, exponential with parameter α) in [0,1];
//  - the output is bilinear interpolation of the four neighbouring tile mappings (tile centres);
//    pixels in the outer half-tiles use the nearest mappings (as adapthisteq does).
// Input values are binned over [0,1] (clamped); output is in [0,1].
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace turbid {

enum class ClaheDistribution { kUniform, kRayleigh, kExponential };
// "uniform" | "rayleigh" | "exponential"; the name form throws Error for an unknown name.
ClaheDistribution ClaheDistributionFromName(const std::string& name);
std::string ClaheDistributionName(ClaheDistribution distribution);

struct ClaheOptions {
  // Contextual regions along x and y, >= 2 each (adapthisteq 'NumTiles' [8 8], paper default).
  int tiles_x = 8;
  int tiles_y = 8;
  // Clip limit as a fraction in [0,1]: 0 clips to the flat histogram (least contrast), 1 does
  // not clip (plain AHE). adapthisteq 'ClipLimit' 0.01, the paper's default.
  double clip_limit = 0.01;
  // Histogram bins, in [2, 65536] (adapthisteq 'NBins' 256).
  int bins = 256;
  // Target histogram shape (adapthisteq 'Distribution'; the paper uses Rayleigh).
  ClaheDistribution distribution = ClaheDistribution::kRayleigh;
  // Rayleigh / exponential parameter α, > 0 (adapthisteq 'Alpha' 0.4, paper default).
  double alpha = 0.4;
  // Brightness-keeping target (not in adapthisteq; `full`'s clahe_target_mean): α is chosen per
  // image, by bisection on log α in [1e-3, 1e3], so that the mean of the mapped bins (each pixel
  // through its own tile's mapping, before the bilinear blend) equals the mean of the binned
  // input; `alpha` is then unused. The fixed Rayleigh(0.4) target has a mean near 0.5 whatever
  // the scene, so it lifts a dark image towards mid-grey. Ignored for the uniform target.
  bool keep_mean = false;
  // keep_mean's floor: the mapped mean is max(input mean, min_mean), in [0, 0.6], so an
  // underexposed image is still brought up to this mean (and no further).
  double min_mean = 0.0;
  // Not a method parameter: a colour image is in R, G, B order (turbid's is B, G, R). Only the
  // luminance weights depend on it; the values are the same as for the reordered image.
  bool rgb = false;

  bool Check(std::string* why) const;
};

// What one equalisation did: the target parameter used (keep_mean: the one chosen; 0 for the
// uniform target), the mean of the binned input (b / (bins - 1) over the padded tiles), the mean
// aimed at (keep_mean: max(input mean, min_mean); else 0) and the mean of the mapped bins (before
// the bilinear blend between tiles).
struct ClaheStats {
  double alpha = 0.0;
  double input_mean = 0.0;
  double target_mean = 0.0;
  double mapped_mean = 0.0;
};

// CLAHE of a one-channel CV_32F image (values clamped to [0,1] for binning). Colour images
// (CV_32FC3) are equalised on luminance (Rec. 709) and the channels rescaled by the luminance
// ratio (hue kept), as ClaheColor below. Throws Error for empty / non-float / other channel
// counts / non-finite values, or options failing Check.
cv::Mat Clahe(const ClaheOptions& options, const cv::Mat& image, ClaheStats* stats = nullptr);

// For pipelines that produce their image row by row (no full-size float image before CLAHE):
// ClaheNewBins allocates the bin-index image (CV_8U for bins <= 256, else CV_16U), ClaheBinRow
// fills its row y from `width` floats (throws Error for non-finite values), and ClaheFromBins
// equalises it. The result equals Clahe(options, image) of the one-channel image those rows form.
cv::Mat ClaheNewBins(const ClaheOptions& options, cv::Size size);
void ClaheBinRow(const ClaheOptions& options, const float* row, cv::Mat& bins, int y);
cv::Mat ClaheFromBins(const ClaheOptions& options, const cv::Mat& bins,
                      ClaheStats* stats = nullptr);
// The same for colour: ClaheBinColorRow bins row y's Rec. 709 luminance (written to `lum`,
// bins.cols floats) from `width` BGR pixels in [0, 1] (R, G, B when options.rgb);
// ClaheColorFromBins equalises and rescales `image` (CV_32FC3, those rows) in place. The result
// equals Clahe(options, image). `after_row(row, y)`, when given, is called on each row (3 * cols
// floats) as soon as it is final, while it is still in cache (e.g. a curve applied per row).
void ClaheBinColorRow(const ClaheOptions& options, const float* bgr, float* lum, cv::Mat& bins,
                      int y);
void ClaheColorFromBins(const ClaheOptions& options, const cv::Mat& bins, cv::Mat& image,
                        ClaheStats* stats = nullptr,
                        const std::function<void(float*, int)>& after_row = {});

// The per-tile mapping tables (tiles_y*tiles_x rows, `bins` columns, output values in [0,1]) of
// a one-channel image after padding: exposed so tests can pin known histograms.
cv::Mat ClaheTileMappings(const ClaheOptions& options, const cv::Mat& gray);

// One tile's mapping from its histogram (counts per bin, `pixels` in total): clip, redistribute,
// cumulate, shape to the target. Exposed for the known-histogram tests.
std::vector<float> ClaheMapHistogram(const ClaheOptions& options, std::vector<int> histogram,
                                     int pixels);

}  // namespace turbid
