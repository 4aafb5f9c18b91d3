// Internals of the guided filter (guided_filter.cc): the colour-guide path. Not part of the API.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace turbid::guided_internal {

// Colour guide g (three CV_32FC1 planes), one-channel source: the coefficients a (three planes)
// and b of He 2013 eqs. 19-21 over the clipped (2r+1)^2 window, at the guide's resolution.
std::vector<cv::Mat> ColorCoefficients(const std::vector<cv::Mat>& g, const cv::Mat& src, int r,
                                       double eps);

// The colour-guided output from the coefficients: their box means, then a . I + b.
cv::Mat ColorApply(const std::vector<cv::Mat>& coef, const std::vector<cv::Mat>& g, int r);

}  // namespace turbid::guided_internal
