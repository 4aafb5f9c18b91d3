// Internals of colour CLAHE (clahe.cc, clahe_luminance.cc); not part of the API.
#pragma once

namespace turbid::clahe_internal {

// Rec. 709 luminance of an interleaved B, G, R row of w pixels (rgb: R, G, B).
void LuminanceRow(const float* px, float* lum, int w, bool rgb);

// One row of colour CLAHE, in place over `row` (cols interleaved pixels): its luminance (into lum,
// cols floats), then each channel times eq / luminance clamped to [0, 1] (gray at eq where the
// luminance is ~0). next: the next row (prefetched by the AVX2 path) or null.
void LuminanceRatioRowInPlace(float* row, const float* eq, int cols, float* lum, const float* next,
                              bool rgb);

}  // namespace turbid::clahe_internal
