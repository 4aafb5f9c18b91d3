// The file codecs behind image_io.h, each through its own light library: PNG (libpng), JPEG
// (libjpeg-turbo), EXR (OpenEXR). They decode exactly what OpenCV's imdecode(IMREAD_UNCHANGED)
// (PNG, JPEG) and OpenImageIO (EXR) decoded before, and the PNG encoder writes the bytes
// cv::imwrite wrote (same libpng calls and settings); tests/scenes/image_codecs_test.cc compares
// both. TIFF and the rare variants these decoders leave out are read by the OpenImageIO plugin
// (scenes/plugin/), a shared library opened only when such a file is read: a program that never
// reads one never loads OpenImageIO (docs/architecture.md, "Linking").
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace turbid::codecs {

// Every decoder returns float32 with 1 or 3 channels (BGR) and sets *max_value to the integer
// code that means 1.0 (255, 65535) or 0 for float data; it returns an empty Mat when the file is a
// variant it leaves to the plugin, and throws Error("<path>: <problem>") for corrupt data.
cv::Mat DecodePng(const std::string& path, const std::string& bytes, int* max_value);
cv::Mat DecodeJpeg(const std::string& path, const std::string& bytes, int* max_value);
cv::Mat DecodeExr(const std::string& path, const std::string& bytes, int* max_value);

// Decodes through the OpenImageIO plugin (loaded on first use): TIFF and EXR through OpenImageIO
// (OpenCV for LogLuv TIFFs), PNG/JPEG variants through OpenCV. Throws Error, also when the plugin
// cannot be loaded.
cv::Mat DecodeWithPlugin(const std::string& path, const std::string& bytes, int* max_value);

// Encodes `encoded` (CV_8U or CV_16U, 1 or 3 channels, BGR) as PNG bytes with the settings
// cv::imwrite uses by default (SUB filter, zlib level 1, Z_RLE). Errors name `path`. Encoding to
// memory lets the caller write the file with checked writes (a full disk is one clear error).
std::string EncodePng(const std::string& path, const cv::Mat& encoded);

}  // namespace turbid::codecs
