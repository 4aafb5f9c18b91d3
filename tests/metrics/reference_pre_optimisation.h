// The pre-optimisation implementations (commit 6722196) of the visible-edge indicators, UIQM and
// UCIQE, kept for the tests that prove the optimised code gives the same output.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "metrics/no_reference.h"

namespace turbid::reference {

cv::Mat ReferenceOctaveRgbToGray(const cv::Mat& bgr8);
cv::Mat ReferenceToGray255(const cv::Mat& image, const std::string& what);
cv::Mat ReferenceVisibleEdgeMask(const VisibleEdgeOptions& options, const cv::Mat& gray255);
VisibleEdgeResult ReferenceVisibleEdges(const VisibleEdgeOptions& options, const cv::Mat& original,
                                        const cv::Mat& restored);
UiqmResult ReferenceUiqm(const UiqmOptions& options, const cv::Mat& image);
UciqeResult ReferenceUciqe(const UciqeOptions& options, const cv::Mat& image);

}  // namespace turbid::reference
