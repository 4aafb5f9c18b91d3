// NumPy .npy arrays (format versions 1.0-3.0) as depth maps: 2-D, C order, little-endian float32,
// float64 or uint16 (the dtypes depth exports use: float metres, or integer millimetres). Own reader:
// the header is a Python dict literal, parsed strictly for the three keys NumPy writes. Anything else
// (Fortran order, 3-D, big-endian, other dtypes, truncation) is an Error naming the file.
// Format: https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace turbid {

struct NpyArray {
  cv::Mat values;         // CV_32FC1 (float64 narrowed to float32; uint16 converted exactly)
  bool integer = false;   // true when the file's dtype is an integer type ('<u2')
  std::string dtype;      // the descr as stored: "<f4", "<f8" or "<u2"
};

// True when the file starts with the .npy magic "\x93NUMPY" (false for short or unreadable files).
bool IsNpyFile(const std::string& path);

// Reads a 2-D array; rows = shape[0], cols = shape[1]. Throws Error("<path>: <problem>").
NpyArray ReadNpy(const std::string& path);

}  // namespace turbid
