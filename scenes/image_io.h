// Image files <-> cv::Mat. In memory images are float32, linear, [0, 1], 1 or 3 channels (BGR order,
// as OpenCV). The sRGB transfer curve is applied only at this boundary and only when asked.
// Formats (detected from the file's first bytes, not its name): read PNG 8/16 (libpng), JPEG
// (libjpeg), EXR half/float (OpenEXR), TIFF 8/16/float (OpenImageIO, in a plugin loaded only when
// such a file is read; image_codecs.h), PFM (own reader: scale sign = endianness, rows
// bottom-to-top, inf kept), binary PGM/PPM 8/16 (own reader); write PNG 8/16, EXR float32 and PFM.
// Corrupt or truncated files raise Error("<path>: <problem>"). Policy: docs/formats.md.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace turbid {

enum class Transfer {
  kLinear,  // file values are linear already (depth, maps, our own outputs by default)
  kSrgb,    // file values are sRGB-encoded: decode to linear on read, encode on write
};

struct ReadImageOptions {
  Transfer transfer = Transfer::kLinear;  // how integer file values are interpreted
  bool keep_raw = false;  // true: return the file's values unscaled as float32 (depth, disparity)
  bool Check(std::string* why) const;
};

struct WriteImageOptions {
  int bit_depth = 8;  // 8 or 16 for PNG; ignored for EXR (always float32)
  Transfer transfer = Transfer::kLinear;
  bool overwrite = false;  // false: refuse to replace an existing file (CLI --force sets true)
  // PNG only. false: values in [0, 1] map to the full integer range. true: values are written as
  // integers directly (rounded, clipped to [0, 2^bit_depth - 1]; e.g. depth x 5000 for TUM PNGs).
  // NaN becomes 0 either way.
  bool raw = false;
  bool Check(std::string* why) const;
};

// Reads any supported file into float32. Integer files are scaled to [0, 1] unless keep_raw;
// float files (EXR, PFM, float TIFF) keep their values. Throws Error("<path>: <problem>").
cv::Mat ReadImage(const std::string& path, const ReadImageOptions& options = {});

// Writes atomically (temporary file in the same folder, then rename). Format from the extension:
// .png (8/16-bit, values clipped to [0, 1] and rounded), .exr (float32, NaN/inf kept) or .pfm
// (float32, little-endian, rows bottom-to-top). Throws Error.
void WriteImage(const std::string& path, const cv::Mat& image, const WriteImageOptions& options = {});

// The file formats ReadImage recognises from the first bytes; kUnknown otherwise.
enum class ImageFormat { kUnknown, kPng, kJpeg, kTiff, kExr, kPfm, kPnm };
ImageFormat DetectImageFormat(const std::string& path);  // throws Error when unreadable

// IEC 61966-2-1 sRGB transfer curve, elementwise on float32 images.
cv::Mat SrgbToLinear(const cv::Mat& srgb);
cv::Mat LinearToSrgb(const cv::Mat& linear);

}  // namespace turbid
