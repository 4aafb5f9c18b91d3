// Row kernels of the metrics, compiled twice (x86-64 baseline and AVX2 + FMA) and picked at
// run time from the CPU (simd_dispatch.cc), so one binary runs everywhere and is fast where it can
// be. Every reduction here adds in a fixed order, so results do not depend on threads.
#pragma once

#include <cstddef>
#include <cstdint>

namespace turbid::simd {

// Two consecutive output rows of a vertical pass with symmetric weights (weights[k] ==
// weights[taps - 1 - k]): rows holds taps + 1 consecutive input rows; out0[j] = sum_k weights[k] *
// rows[k][j] and out1[j] = sum_k weights[k] * rows[k + 1][j], j < n. Pairs of taps are added before
// the multiply, and the shared rows are read once for both outputs.
void SymmetricColumnPair(const float* const* rows, const float* weights, int taps, float* out0,
                         float* out1, int n);

// The same for four consecutive output rows (rows holds taps + 3 input rows; out[t][j] = sum_k
// weights[k] * rows[k + t][j]): each input row is read from memory once for all four outputs.
void SymmetricColumnQuad(const float* const* rows, const float* weights, int taps,
                         float* const* out, int n);

// The horizontal symmetric pass of the five SSIM moments fused with the SSIM formula: moments[m]
// points at column 0 of a row that holds radius = taps / 2 readable values on each side (the
// reflected border); the moments are, in order, E[x - o], E[y - o] and the centred second moments
// E[(x - o)^2], E[(y - o)^2], E[(x - o)(y - o)] after the vertical pass. Writes the SSIM of columns
// [0, n) to out (Wang 2004 Eq. 13).
void SsimHorizontalFormula(const float* const* moments, const float* weights, int taps, int n,
                           double offset, double c1, double c2, double* out);

// One channel of two interleaved 8-bit rows (element j at x[j * step], y[j * step]), centred and
// multiplied in one pass: cx = x - offset, cy = y - offset, xx = cx^2, yy = cy^2, xy = cx * cy
// (exact in float for 8-bit values and offset 127.5).
void CentredMomentsU8(const uint8_t* x, const uint8_t* y, int step, float offset, float* cx,
                      float* cy, float* xx, float* yy, float* xy, int n);

// xx = x * x, yy = y * y, xy = x * y.
void Products(const float* x, const float* y, float* xx, float* yy, float* xy, int n);

// Sum of n doubles in a fixed 4-lane order (vectorisable, deterministic).
double OrderedSum(const double* values, int n);

// Sum of squared differences of n values, exact for 8-bit inputs (integer arithmetic).
uint64_t SquaredDifferenceSumU8(const uint8_t* a, const uint8_t* b, size_t n);
// The same in double for float / 16-bit values, in a fixed 4-lane order.
double SquaredDifferenceSumF32(const float* a, const float* b, size_t n);

}  // namespace turbid::simd
