// The exact median filter tarel's veil uses (enhancer/baselines/median.cc).
#pragma once

#include <opencv2/core.hpp>

namespace turbid {

// Median over an odd size x size window (border: reflect, as MATLAB's 'symmetric'), float32
// one-channel, exact: comparator networks shared between neighbouring windows
// (enhancer/baselines/median.cc; ~25 ms at 1360x1024 for size 11 on one core).
cv::Mat MedianFilter(const cv::Mat& image, int size);

}  // namespace turbid
