// Input validation shared by the metrics: one wording for every bad-input error.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace turbid {

// Throws Error("<what>: ...") when `image` is empty, has an unsupported depth (8U, 16U, 32F, 64F
// accepted) or channel count (1-4), or holds NaN / infinite values.
void CheckMetricImage(const cv::Mat& image, const std::string& what);

// CheckMetricImage on both, then throws when sizes or channel counts differ.
void CheckMetricPair(const cv::Mat& reference, const cv::Mat& image, const std::string& metric);

// 255 for 8-bit, 65535 for 16-bit, 1 for float images.
double DefaultDataRange(int depth);

}  // namespace turbid
