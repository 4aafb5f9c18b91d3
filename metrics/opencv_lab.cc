#include "metrics/opencv_lab.h"

#include <algorithm>
#include <array>
#include <climits>  // opencv2/core/softfloat.hpp uses UCHAR_MAX without including it
#include <opencv2/core/softfloat.hpp>

#include "metrics/simd_dispatch.h"

namespace turbid {
namespace {

using cv::softdouble;
using cv::softfloat;

// sRGB → XYZ (rows X, Y, Z; columns R, G, B) and the D65 white point, the values OpenCV uses.
constexpr double kSrgbToXyz[9] = {0.412453, 0.357580, 0.180423, 0.212671, 0.715160,
                                  0.072169, 0.019334, 0.119193, 0.950227};
constexpr double kD65[3] = {0.950456, 1.0, 1.088754};

// The sRGB transfer function (IEC 61966-2-1) as OpenCV evaluates it: in softdouble with the
// constants written as ratios of integers, the result rounded to float.
softfloat SrgbToLinear(softfloat x) {
  const softdouble xd = x;
  const softdouble threshold = softdouble(809) / softdouble(20000);  // 0.04045
  const softdouble low_scale = softdouble(323) / softdouble(25);     // 12.92
  const softdouble power = softdouble(12) / softdouble(5);           // 2.4
  const softdouble shift = softdouble(11) / softdouble(200);         // 0.055
  if (xd <= threshold) return xd / low_scale;
  return cv::pow((xd + shift) / (softdouble::one() + shift), power);
}

// CIE f(t): cube root above (6/29)³, 841/108 · t + 16/116 below (float, fused multiply-add).
softfloat CieF(softfloat t) {
  const softfloat threshold = softfloat(216) / softfloat(24389);
  if (t < threshold)
    return cv::mulAdd(t, softfloat(841) / softfloat(108), softfloat(16) / softfloat(116));
  return cv::cbrt(t);
}

simd::Lab8Tables MakeTables() {
  simd::Lab8Tables t{};
  constexpr int kGammaShift = 3;  // gamma-corrected values carry 3 extra bits: 0..255·8
  const softfloat gamma_scale(255 * (1 << kGammaShift));
  for (int v = 0; v < 256; ++v)
    t.gamma[v] = ::cvRound(gamma_scale * SrgbToLinear(softfloat(v) / softfloat(255)));
  // BGR order: the R column goes to the third source byte.
  const softdouble fixed(1 << 12);
  for (int row = 0; row < 3; ++row) {
    const softdouble white(kD65[row]);
    for (int col = 0; col < 3; ++col)
      t.matrix[row * 3 + (2 - col)] =
          ::cvRound(fixed * softdouble(kSrgbToXyz[row * 3 + col]) / white);
  }
  for (int c = 0; c < 3; ++c)
    for (int v = 0; v < 256; ++v)
      for (int row = 0; row < 3; ++row)
        t.xyz[c][v][row] = t.gamma[v] * t.matrix[row * 3 + c] + (c == 0 ? 1 << 11 : 0);
  const softfloat step = softfloat::one() / gamma_scale;
  const softfloat fixed2(1 << 15);
  for (int i = 0; i < 3072; ++i) t.cbrt[i] = ::cvRound(fixed2 * CieF(step * softfloat(i)));
  return t;
}

const simd::Lab8Tables& Tables() {
  static const simd::Lab8Tables tables = MakeTables();
  return tables;
}

// Gray pixels (B = G = R) have 256 possible results: a table made by the colour kernel.
const std::array<uint8_t, 3 * 256>& GrayTable() {
  static const std::array<uint8_t, 3 * 256> table = [] {
    std::array<uint8_t, 3 * 256> bgr{}, lab{};
    for (int v = 0; v < 256; ++v) std::fill_n(bgr.begin() + 3 * v, 3, static_cast<uint8_t>(v));
    simd::BgrToLab8(bgr.data(), 256, Tables(), lab.data());
    return lab;
  }();
  return table;
}

}  // namespace

void BgrToLab8(const uint8_t* src, int channels, size_t n, uint8_t* lab) {
  if (channels == 1) {
    const uint8_t* table = GrayTable().data();
    for (size_t k = 0; k < n; ++k) std::copy_n(table + 3 * src[k], 3, lab + 3 * k);
    return;
  }
  constexpr size_t kBlock = size_t{1} << 30;  // the kernels count pixels in int
  for (size_t k = 0; k < n; k += kBlock) {
    const int count = static_cast<int>(std::min(kBlock, n - k));
    simd::BgrToLab8(src + 3 * k, count, Tables(), lab + 3 * k);
  }
}

}  // namespace turbid
