// Internals of the MMSE oracle (enhancer/oracle/oracle.cc and mmse.cc), exposed for the tests;
// not part of the API.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <opencv2/core.hpp>

#include "enhancer/oracle/oracle.h"

namespace turbid::oracle_internal {

// Per channel, over the pixels not masked: the sums of the posterior variance, of est - prior and
// of its square (in double), and how many pixels.
struct DetailSums {
  double posterior[3] = {0, 0, 0}, detail[3] = {0, 0, 0}, detail_sq[3] = {0, 0, 0};
  long long count = 0;
};

// The quantisation noise of the camera's codes, taken in the coded domain and carried to linear
// light: a code step Delta = 1 / (2^bits - 1) is Delta s(v) in linear light, s = d decode / d code
// at the code of the linear value v, so the variance is (Delta s(v))^2 / 12. Linear coding: s = 1.
// sRGB (IEC 61966-2-1): s = 1 / 12.92 below v = 0.0031308, else (2.4 / 1.055) v^(1.4 / 2.4)
// (the derivative of ((code + 0.055) / 1.055)^2.4 at code = 1.055 v^(1 / 2.4) - 0.055). Float
// outputs: 0.
struct CodedQuantisation {
  float step_var = 0.0f;  // Delta^2 / 12
  bool srgb = false;

  float Variance(float v) const {
    if (!srgb) return step_var;
    const float x = std::min(std::max(v, 0.0f), 1.0f);
    if (x <= 0.0031308f) return step_var * static_cast<float>(1.0 / (12.92 * 12.92));
    // s^2 = (2.4 / 1.055)^2 x^(2.8 / 2.4)
    return step_var * 5.17520271f * std::pow(x, 1.16666667f);
  }
};

struct OracleMmseResult {
  cv::Mat estimate;   // MMSE estimate of h * rho (censored pixels raised onto their bound)
  cv::Mat prior;      // prior mean of the finest level (also raised)
  cv::Mat posterior;  // posterior variance
  cv::Mat masked;     // CV_8UC1, 255 where some channel's t < mask_transmission
  int masked_pixels = 0;
  int censored_pixels = 0;  // pixels with a channel above clip_level (no weight)
  // With with_detail only: estimate - prior (float) and its sums (OracleEnhance's deblur).
  cv::Mat detail;
  DetailSums detail_sums;
};

// Full-size buffers come from the renderer's recycling pool (simulator/image_pool.h): the
// oracle needs a few dozen per call, and fresh pages for each cost more than its arithmetic.
cv::Mat NewLike(const cv::Mat& m);

// Pixels where any channel of t is below `floor` (NaN depth has t = 0): CV_8UC1, 255 = masked.
cv::Mat MaskBelow(const cv::Mat& t, double floor);

// The oracle's last step: v = prior + detail where masked is 0, prior where it is not (detail
// empty: v = prior, masked unused), times irradiance (empty: not), then cv::patchNaNs(v, 0),
// cv::min(v, 1.0) and cv::max(v, 0.0), with their values bit for bit (-0 included: OpenCV's
// vector max makes it +0, its scalar loop keeps it). CV_32F, 1 or 3 channels, masked CV_8UC1;
// out may be prior.
void FinishImage(const cv::Mat& prior, const cv::Mat& detail, const cv::Mat& masked,
                 const cv::Mat& irradiance, cv::Mat& out);

// The oracle's data term and estimate: the noise variance max(box7(I), 0) shot_gain + floor_var
// + quantisation.Variance(box7(I))
// (7x7 local mean, reflected borders), u = (I - snow - veil) / max(t E, 1e-12) with weight
// a = (t E)^2 / variance (0 where masked or where I > clip_level), then the hierarchical MMSE
// (docs/methods.md, "oracle"). All maps are the image's size and type. with_detail: also the
// detail and its sums (made as the estimate's rows are).
OracleMmseResult OracleMmse(const OracleOptions& o, const cv::Mat& image,
                            const cv::Mat& transmission, const cv::Mat& irradiance,
                            const cv::Mat& snow, const cv::Mat& veil, double shot_gain,
                            double floor_var, double clip_level, bool with_detail = false,
                            const CodedQuantisation& quantisation = {});

// Row y of the truth maps: t, e, snow and veil set to that row of the transmission, irradiance,
// snow and veil (the image's cols * channels values each, valid until the next call). OracleMmse
// asks for each row once, in order of y.
using TruthRowFn = std::function<void(int y, const float*& t, const float*& e, const float*& snow,
                                      const float*& veil)>;

// OracleMmse with the truth maps as rows (OracleEnhance makes them there: no full-size maps).
// keep_estimate false (with_detail only): the estimate and the posterior variance are made as
// rows for the detail and its sums but not kept (returned empty; OracleEnhance's deblur reads
// only the prior, the detail and the sums).
OracleMmseResult OracleMmse(const OracleOptions& o, const cv::Mat& image,
                            const TruthRowFn& truth_row, double shot_gain, double floor_var,
                            double clip_level, bool with_detail = false, bool keep_estimate = true,
                            const CodedQuantisation& quantisation = {});

}  // namespace turbid::oracle_internal
