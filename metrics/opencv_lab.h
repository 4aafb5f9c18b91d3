// OpenCV 4.6's 8-bit BGR → L*a*b* (cv::cvtColor(src, dst, cv::COLOR_BGR2Lab) on CV_8U), bit for
// bit, without going through cv::cvtColor: UCIQE (metrics/uciqe.cc) reproduces a reference that
// uses exactly this conversion, and converting chunk by chunk lets it read each pixel while it is
// in cache.
//
// The conversion is OpenCV's integer path (imgproc/src/color_lab.cpp, RGB2Lab_b): an sRGB gamma
// table to 255·8 levels, the sRGB→XYZ matrix divided by the D65 white point in 12-bit fixed point,
// a table of the CIE f(t) (cube root above (6/29)³, linear below) in 15-bit fixed point indexed by
// the rounded X, Y, Z, then L = 296·f(Y), a = 500·(f(X) − f(Y)) + 128, b = 200·(f(Y) − f(Z)) + 128
// in fixed point, rounded and clamped to 8 bits. The tables are computed with OpenCV's own
// software floating point (cv::softfloat / cv::softdouble: the same correctly rounded arithmetic,
// pow and cbrt that OpenCV uses), so they equal OpenCV's. tests/metrics/opencv_lab_test.cc checks
// every one of the 2^24 colours against cv::cvtColor, through both kernels.
#pragma once

#include <cstddef>
#include <cstdint>

namespace turbid {

// n pixels of `channels` bytes (3: B, G, R; 1: gray, converted as if B = G = R) → 3·n bytes
// L, a, b. Picks the vectorised kernel where the CPU has it (simd::ActiveSimdLevel()).
void BgrToLab8(const uint8_t* src, int channels, size_t n, uint8_t* lab);

}  // namespace turbid
