// The camera's output encoding: how a linear value in [0, 1] becomes an integer code (8 or 16 bit).
// `linear` codes the value itself (round(v L), L = 2^bits - 1); `srgb` codes the IEC 61966-2-1
// sRGB transfer curve of it, as cameras and the datasets people train on (UIEB, EUVP) do. Float
// outputs (EXR, PFM) are not quantised and stay linear whatever the encoding.
//
// QuantiseEncoded* keep images linear in memory: each value is replaced by the linear value of its
// integer code (the decoded code). Writing such an image with WriteImage and the matching Transfer
// stores exactly those codes, and reading it back with that Transfer returns the same values, so
// every command that writes an integer image routes it through here (docs/model.md, "Camera").
// The sRGB codes are exact: the code of v is the number of decision thresholds
// decode((k + 1/2) / L), k = 0 .. L - 1, computed in double, that v reaches.
#pragma once

#include <opencv2/core.hpp>
#include <cstdint>
#include <string>

#include "scenes/image_io.h"

namespace turbid {

enum class CameraEncoding { kLinear, kSrgb };

// "linear" / "srgb".
std::string CameraEncodingName(CameraEncoding encoding);
// Parses "linear" / "srgb"; throws Error("<what>: ...") otherwise.
CameraEncoding CameraEncodingFromName(const std::string& name, const std::string& what);
// The image_io transfer that stores an encoding's codes.
Transfer TransferFor(CameraEncoding encoding);

// In place on n values: clip to [0, 1], quantise to the code of `encoding` at `bits` (8 or 16) and
// decode back to linear. NaN becomes 0.
void QuantiseEncodedRow(float* values, int n, CameraEncoding encoding, int bits);
// The same for an interleaved 3-channel row (n values), written back with the first and third
// channels exchanged (B, G, R -> R, G, B) in the same pass: the values of QuantiseEncodedRow,
// reordered.
void QuantiseEncodedRowSwapRB(float* values, int n, CameraEncoding encoding, int bits);
// The same on a float32 image (any channel count); returns a new image.
cv::Mat QuantiseEncoded(const cv::Mat& linear, CameraEncoding encoding, int bits);
// The integer codes themselves (0 .. 2^bits - 1, held as float32, same channels): what a file
// written with this encoding and bit depth stores, i.e. the raw values `turbid score` reads back.
// Same clipping and thresholds as QuantiseEncoded (NaN becomes 0).
cv::Mat EncodeCodes(const cv::Mat& linear, CameraEncoding encoding, int bits);
// The 8-bit codes of n values as bytes: the codes QuantiseEncodedRow(..., 8) decodes (same
// clipping and thresholds; NaN becomes 0), i.e. the bytes of the 8-bit file.
void EncodeCodesRow8(const float* in, int n, CameraEncoding encoding, uint8_t* out);

}  // namespace turbid
