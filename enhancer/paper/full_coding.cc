// `full`'s CLAHE domain (clahe_domain, docs/methods.md "The CLAHE domain"): the camera's transfer
// curve applied before the equalisation and inverted after it, row by row, and where the curve
// comes from.
#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

#include "core/cpu.h"
#include "core/row_kernel.h"
#include "enhancer/paper/full_internal.h"
#include "enhancer/paper/kernels.h"
#include "enhancer/simd_switch.h"
#include "enhancer/simd_vec.h"

namespace turbid::paper_internal {
namespace {

// IEC 61966-2-1 in double (the same curve as scenes/image_io.h's LinearToSrgb / SrgbToLinear).
constexpr double kEncodeKnee = 0.0031308, kDecodeKnee = 0.04045;
double SrgbEncode(double v) {
  return v <= kEncodeKnee ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}
double SrgbDecode(double c) {
  return c <= kDecodeKnee ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// A curve on [0, 1] tabulated at n + 1 equally spaced points and read by linear interpolation
// (the portable path). Error bound h^2 / 8 max|f''| (h = 1/n): the encoding's largest curvature
// is just above its linear segment (|f''| ~ 2400 at v = 0.0031), 7e-8 with n = 65536; the
// decoding's |f''| <= 3.1, 2.3e-8 with n = 4096. Both below the float rounding of the exact curve
// at 1 (6e-8).
struct Table {
  Table(int size, double (*f)(double)) : n(size), y(size + 1) {
    for (int i = 0; i <= n; ++i) y[i] = static_cast<float>(f(static_cast<double>(i) / n));
  }
  int n;
  std::vector<float> y;
};

// out[i] <- the table at in[i] clamped to [0, 1] (NaN -> 0, as ClampUnit); in == out allowed. A
// plain loop for the compiler (AVX2 gathers in its clone).
TURBID_ROW_KERNEL void LookUpRow(const float* in, float* out, int count, const float* __restrict y,
                                 int n) {
  const float scale = static_cast<float>(n);
  for (int i = 0; i < count; ++i) {
    const float c = std::min(in[i] > 0.0f ? in[i] : 0.0f, 1.0f);
    const float x = c * scale;
    const int k = std::min(static_cast<int>(x), n - 1);
    const float f = x - static_cast<float>(k);
    out[i] = y[k] + f * (y[k + 1] - y[k]);
  }
}

const Table& EncodeTable() {
  static const Table table(65536, SrgbEncode);
  return table;
}
const Table& DecodeTable() {
  static const Table table(4096, SrgbDecode);
  return table;
}

#ifdef TURBID_HAVE_DEHAZE_AVX2
// x^p for x in [2^-15, 1] without tables in memory (the AVX2 path): x = m 2^e with m in [1, 2),
// x^p = m^p 2^(p e); m^p is a polynomial in t = 2 m - 3 (Chebyshev interpolation at kDegree + 1
// nodes, computed here in double), 2^(p e) one of 16 floats picked by a lane permute. Degrees:
// 6 for the encoding (p = 1/2.4: interpolation error 2.4e-7 relative, ~6e-7 in the code after
// 1.055 x^p - 0.055 near the knee), 5 for the decoding (p = 2.4: 6.8e-7); issue 29 item 6 allows
// 1e-5 relative. The encoding feeds CLAHE's 256 bins, so it keeps the higher degree (fewer bin
// flips). Tested against the double-precision curve (full_color_kernels_test.cc).
constexpr int kEncodeDegree = 6, kDecodeDegree = 5;
template <int kDegree>
struct PowPoly {
  explicit PowPoly(double p) {
    constexpr int n = kDegree + 1;
    double cheb[n] = {};
    for (int k = 0; k < n; ++k) {
      const double t = std::cos(M_PI * (k + 0.5) / n), f = std::pow((t + 3.0) / 2.0, p);
      for (int j = 0; j < n; ++j) cheb[j] += 2.0 / n * f * std::cos(j * M_PI * (k + 0.5) / n);
    }
    cheb[0] /= 2.0;
    // Monomial coefficients of sum_j cheb[j] T_j(t), with T_j built by T_{j+1} = 2 t T_j - T_{j-1}.
    double mono[n] = {}, prev[n] = {}, cur[n] = {}, next[n];
    prev[0] = 1.0;  // T_0
    cur[1] = 1.0;   // T_1
    mono[0] = cheb[0];
    for (int j = 1; j < n; ++j) {
      for (int i = 0; i < n; ++i) mono[i] += cheb[j] * cur[i];
      for (int i = 0; i < n; ++i) next[i] = (i > 0 ? 2.0 * cur[i - 1] : 0.0) - prev[i];
      std::copy(cur, cur + n, prev);
      std::copy(next, next + n, cur);
    }
    for (int i = 0; i < n; ++i) c[i] = static_cast<float>(mono[i]);
    for (int e = 0; e < 16; ++e) scale[e] = static_cast<float>(std::exp2(-p * e));
  }
  float c[kDegree + 1];
  float scale[16];  // 2^(p e) for e = 0, -1, ..., -15
};

using EncodePowPoly = PowPoly<kEncodeDegree>;
using DecodePowPoly = PowPoly<kDecodeDegree>;
const EncodePowPoly& EncodePoly() {
  static const EncodePowPoly poly(1.0 / 2.4);
  return poly;
}
const DecodePowPoly& DecodePoly() {
  static const DecodePowPoly poly(2.4);
  return poly;
}

// The curve rows at 8 and 16 lanes (full_coding_curve.inc, written once over the width).
#define TURBID_VEC_BODY "enhancer/paper/full_coding_curve.inc"
#include "enhancer/simd_widths.inc"  // NOLINT(build/include): the body at 8 and 16 lanes

bool UseCurveAvx2() {
  static const bool fma = CpuHasFma();
  return fma && enhancer_internal::UseHandWrittenAvx2();
}
#endif

// The sRGB curve (encode or decode) of a row, clamped to [0, 1] first; in == out allowed.
void SrgbCurveRow(const float* in, float* out, int n, bool encode) {
#ifdef TURBID_HAVE_DEHAZE_AVX2
  if (UseCurveAvx2()) {
    if (KernelCpuLevel() >= CpuLevel::kAvx512) {
      encode ? vec16::CurveRow(EncodePoly(), in, out, n)
             : vec16::CurveRow(DecodePoly(), in, out, n);
    } else {
      encode ? vec8::CurveRow(EncodePoly(), in, out, n) : vec8::CurveRow(DecodePoly(), in, out, n);
    }
    return;
  }
#endif
  const Table& table = encode ? EncodeTable() : DecodeTable();
  LookUpRow(in, out, n, table.y.data(), table.n);
}

}  // namespace

void ResolveClaheEncoding(const FullOptions& o, const RenderRecord* sidecar, FullResult* r) {
  if (o.clahe_domain == ClaheDomain::kLinear) {
    r->clahe_encoding = CameraEncoding::kLinear;
    r->clahe_encoding_source = "clahe_domain linear";
  } else if (sidecar != nullptr && sidecar->options) {
    r->clahe_encoding = sidecar->options->camera.encoding;
    r->clahe_encoding_source = "the sidecar's camera";
  } else {
    r->clahe_encoding = CameraEncoding::kSrgb;
    r->clahe_encoding_source = "no sidecar camera: sRGB assumed";
  }
}

void ClaheEncodeRow(const float* in, float* out, int n, CameraEncoding encoding) {
  if (encoding == CameraEncoding::kSrgb) {
    SrgbCurveRow(in, out, n, true);
  } else {
    for (int i = 0; i < n; ++i) out[i] = std::min(in[i] > 0.0f ? in[i] : 0.0f, 1.0f);
  }
}

void ClaheDecodeRow(float* row, int n, CameraEncoding encoding) {
  if (encoding == CameraEncoding::kSrgb) SrgbCurveRow(row, row, n, false);
}

void ClaheDecodeImage(cv::Mat& image, CameraEncoding encoding) {
  if (encoding != CameraEncoding::kSrgb) return;
  CV_Assert(image.depth() == CV_32F);
  const int per_row = image.cols * image.channels();
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y)
      SrgbCurveRow(image.ptr<float>(y), image.ptr<float>(y), per_row, false);
  });
}

double ClaheEncodeValue(double v, CameraEncoding encoding) {
  v = std::clamp(v, 0.0, 1.0);
  return encoding == CameraEncoding::kSrgb ? SrgbEncode(v) : v;
}

}  // namespace turbid::paper_internal
