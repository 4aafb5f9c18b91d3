// Images as `turbid score` feeds them to the metrics: integer files keep their raw values (no sRGB
// decode, no rescale) with the matching data range, so scores equal scikit-image's on the same
// files. Shared by the CLI and the Python package so both give the same numbers.
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace turbid {

struct MetricImage {
  cv::Mat pixels;            // float32, raw file values for 8/16-bit files, else as ReadImage
  double data_range = 1.0;   // 255 / 65535 for 8 / 16-bit files, 1 otherwise
};

// 8 or 16 for PNG (from the IHDR chunk) and 8 for JPEG; 0 when unknown (other formats).
int IntegerBitDepth(const std::string& path);

MetricImage LoadMetricImage(const std::string& path);

// Brings images with different bit depths to the [0, 1] scale so that they can be compared;
// returns the data range they then share. Null or empty entries are skipped.
double CommonScale(std::vector<MetricImage*> images);

}  // namespace turbid
