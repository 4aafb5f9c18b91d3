// Baseline fusion: Ancuti, Ancuti, Haber, Bekaert, "Enhancing underwater images and videos by
// fusion", CVPR 2012, §3-4.
// Every function takes float32 images in [0,1] with 1 or 3 channels (BGR order, linear) and returns
// the same size and channel count, finite and clamped to [0,1]. Empty input, another depth or
// channel count, or non-finite values throw Error; options are checked with Check and throw Error
// naming the parameter. Formulas, defaults and the behaviour on gray input:
// docs/methods-baselines.md.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "enhancer/baselines/clahe.h"

namespace turbid {

struct FusionOptions {
  // Laplacian-pyramid levels, >= 1; fewer are used on images too small for them. Ancuti 2012
  // blend with a multi-scale pyramid; five levels as in the comparison of the reproduced paper.
  int levels = 5;
  // Gray-world white balance of the first input (colour only). Ancuti 2012 §3.1.
  bool white_balance = true;
  // Largest gain the gray-world balance may apply to one channel, >= 1 (keeps a nearly absent red
  // channel from being multiplied into noise).
  double max_white_balance_gain = 4.0;
  // CLAHE of the second input's luminance (Ancuti 2012 §3.1: local adaptive histogram
  // equalisation); adapthisteq defaults.
  ClaheBaselineOptions clahe;
  // Width of the exposedness Gaussian around 0.5, > 0. Ancuti 2012 §3.2: σ = 0.25.
  double exposedness_sigma = 0.25;
  bool Check(std::string* why) const;
};

struct FusionResult {
  cv::Mat image;  // fused result, [0,1]
  // the two derived inputs (white-balanced, or the input image itself when not balanced;
  // contrast-enhanced)
  std::vector<cv::Mat> inputs;
  std::vector<cv::Mat> weights;  // their normalised CV_32FC1 weight maps (sum to 1 per pixel)
};

FusionResult FusionDetailed(const FusionOptions& options, const cv::Mat& image);
cv::Mat Fusion(const FusionOptions& options, const cv::Mat& image);

// Fusion weight of one input before normalisation (Ancuti 2012 §3.2): Laplacian contrast + local
// contrast + saliency + exposedness, CV_32FC1, >= 0.
cv::Mat FusionWeight(const cv::Mat& input, double exposedness_sigma);

// Multi-scale blend (Ancuti 2012 eq. 10): sum over k of Laplacian pyramid(input k) times Gaussian
// pyramid(weight k), collapsed. Weights must sum to 1 per pixel; inputs share size and channels.
// `levels` is capped so the coarsest level is at least 1 x 1. Not clamped.
cv::Mat PyramidBlend(const std::vector<cv::Mat>& inputs, const std::vector<cv::Mat>& weights,
                     int levels);

}  // namespace turbid
