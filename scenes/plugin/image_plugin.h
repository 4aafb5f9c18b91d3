// The interface between scenes/image_codecs.cc and the OpenImageIO plugin (turbid_oiio.so), which
// is built from this tree with the same compiler, libstdc++ and OpenCV, so C++ types cross it.
#pragma once

#include <opencv2/core.hpp>

#include <string>

// Decodes the file `path` whose bytes are `*bytes` into *image (float32, 1 or 3 channels, BGR) and
// *max_value (the integer code meaning 1.0, or 0 for float data). Returns 0 on success; otherwise
// 1 with a one-line reason in *error. Never throws.
extern "C" {
typedef int TurbidPluginDecodeFn(const char* path, const std::string* bytes, cv::Mat* image,
                                 int* max_value, std::string* error);
}

inline constexpr const char* kTurbidPluginDecodeSymbol = "turbid_plugin_decode_v1";
inline constexpr const char* kTurbidPluginFileName = "turbid_oiio.so";
