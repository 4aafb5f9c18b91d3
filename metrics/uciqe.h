// UCIQE, the underwater colour image quality evaluation.
//
// Paper: M. Yang, A. Sowmya, "An underwater color image quality evaluation metric", IEEE Trans.
// Image Process. 24(12):6062-6071, 2015:
//   UCIQE = c1·σ_c + c2·con_l + c3·μ_s, c = 0.4680, 0.2745, 0.2576   (Eq. 4)
// σ_c: chroma spread, con_l: luminance contrast (top 1 % − bottom 1 %), μ_s: mean saturation.
//
// Matched implementation (variant kJouUipCompat, "jou-uip-compat"): JOU-UIP/UCIQE UCIQE.py@02a3cf3
// uciqe(1, path), the Python port of the widely copied UCIQE.m:
//   OpenCV 8-bit Lab (cv::cvtColor BGR→Lab on uint8), every channel / 255, a and b keep the +128
//   offset; chr = √(a² + b²);
//   σ_c = √(mean |1 − (mean(chr)/chr)²|);   μ_s = mean(chr / √(chr² + L²));
//   con_l: 65536-bin histogram of L over [min L, max L], cdf, first bin with cdf > 0.01 (ilow) and
//   first with cdf >= 0.99 (ihigh), con_l = (ihigh − ilow)/65535 (stretchlim transcribed).
//
// Input: float32 [0,1] (file value / 255, quantised to 8 bits) or 8-bit; BGR or gray (gray is
// replicated to 3 channels).
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>

namespace turbid {

enum class UciqeVariant {
  kJouUipCompat,  // "jou-uip-compat": JOU-UIP UCIQE.py exactly
};

std::string UciqeVariantName(UciqeVariant variant);
UciqeVariant ParseUciqeVariant(const std::string& name);  // throws Error for unknown names

struct UciqeOptions {
  // Which implementation to reproduce. Default (and only): JOU-UIP UCIQE.py.
  UciqeVariant variant = UciqeVariant::kJouUipCompat;
  bool Check(std::string* why) const;
};

struct UciqeResult {
  double uciqe = 0.0;  // 0.4680·chroma_spread + 0.2745·luminance_contrast + 0.2576·saturation
  double chroma_spread = 0.0;       // σ_c as the reference computes it (var_chr)
  double luminance_contrast = 0.0;  // con_l (con_lum)
  double mean_saturation = 0.0;     // μ_s (aver_sat)
  std::string variant;              // "jou-uip-compat"
  nlohmann::json ToJson() const;    // keys: variant, uciqe, chroma_spread, luminance_contrast,
                                    // mean_saturation
};

// Throws Error for empty/unsupported/non-finite input or bad options. (Chroma is never 0 with
// OpenCV's offset Lab, so the reference's divisions by chroma are always defined.)
UciqeResult Uciqe(const UciqeOptions& options, const cv::Mat& image);

}  // namespace turbid
