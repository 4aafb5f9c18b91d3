// UIQM, the underwater image quality measure.
//
// Paper: K. Panetta, C. Gao, S. Agaian, "Human-visual-system-inspired underwater image quality
// measures", IEEE J. Oceanic Eng. 41(3):541-551, 2016:
//   UIQM = c1·UICM + c2·UISM + c3·UIConM, c = 0.0282, 0.2953, 3.5753   (Eq. 13)
//   UICM  = −0.0268·√(μ²_RG + μ²_YB) + 0.1586·√(σ²_RG + σ²_YB), α-trimmed means, α = 0.1 (Eq. 5)
//   UISM  = Σ_c λ_c EME(channel_c × Sobel-edge map), EME on k1×k2 blocks (Eqs. 6-8)
//   UIConM = logAMEE on blocks (Eq. 11)
//
// Matched implementation (variant kFunieGanCompat, "funiegan-compat"): xahidbuffon/FUnIE-GAN
// Evaluation/uqim_utils.py@8f934c8 getUIQM, the most copied Python UIQM, quirks included:
//   trimmed mean sums one element fewer than its weight assumes; λ_B = 0.144 (typo of 0.114);
//   edge map = channel × (Sobel magnitude scaled to max 255); 10×10 blocks, remainder rows/cols
//   dropped; EME = 2/(k1 k2) Σ ln(max/min) (blocks with min = 0 add 0); UIConM = −1/(k1 k2)
//   Σ r ln r, r = (max−min)/(max+min) over each 10×10×3 block (plain arithmetic, no PLIP).
// kCorrected ("corrected"): the same pipeline with the two plain bugs fixed — the trimmed mean
// sums exactly the K − T_L − T_R elements it divides by, λ_B = 0.114 — computed in double.
//
// Input: float32 [0,1] (taken as file value / 255 and quantised to 8 bits, see ToEightBit) or
// 8-bit, BGR or gray (gray is replicated to 3 channels, so UICM = 0, as the reference did).
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>

namespace turbid {

enum class UiqmVariant {
  kFunieGanCompat,  // "funiegan-compat": FUnIE-GAN uqim_utils.py exactly (float32 arithmetic)
  kCorrected,       // "corrected": off-by-one trimmed mean and λ_B fixed, double arithmetic
};

std::string UiqmVariantName(UiqmVariant variant);
UiqmVariant ParseUiqmVariant(const std::string& name);  // throws Error for unknown names

struct UiqmOptions {
  // Which implementation to reproduce. Default: the published FUnIE-GAN code.
  UiqmVariant variant = UiqmVariant::kFunieGanCompat;
  // EME / UIConM block side in pixels, >= 2 (FUnIE-GAN: 10). Images smaller than one block throw.
  int block_size = 10;
  // α-trimming fraction on each side for UICM's means, [0, 0.5) (Panetta 2016: 0.1).
  double alpha_trim = 0.1;
  bool Check(std::string* why) const;
};

struct UiqmResult {
  double uiqm = 0.0;              // 0.0282·uicm + 0.2953·uism + 3.5753·uiconm
  double uicm = 0.0;              // colourfulness
  double uism = 0.0;              // sharpness
  double uiconm = 0.0;            // contrast
  std::string variant;            // "funiegan-compat" | "corrected"
  nlohmann::json ToJson() const;  // keys: variant, uiqm, uicm, uism, uiconm
};

// Throws Error for empty/unsupported/non-finite input, images smaller than one block, or bad
// options. A flat channel (Sobel max 0) gives UISM term 0 (the reference produces NaN there).
UiqmResult Uiqm(const UiqmOptions& options, const cv::Mat& image);

}  // namespace turbid
