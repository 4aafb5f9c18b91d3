// `full`'s CLAHE domain (clahe_domain, docs/methods.md "The CLAHE domain"): the camera's transfer
// curve applied before the equalisation and inverted after it, row by row, and where the curve
// comes from.
#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

#include "core/row_kernel.h"
#include "enhancer/paper/full_internal.h"

namespace turbid::paper_internal {
namespace {

// IEC 61966-2-1 in double (the same curve as scenes/image_io.h's LinearToSrgb / SrgbToLinear).
double SrgbEncode(double v) {
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}
double SrgbDecode(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// A curve on [0, 1] tabulated at n + 1 equally spaced points and read by linear interpolation.
// Error bound h^2 / 8 max|f''| (h = 1/n): the encoding's largest curvature is just above its
// linear segment (|f''| ~ 2400 at v = 0.0031), 7e-8 with n = 65536; the decoding's |f''| <= 3.1,
// 2.3e-8 with n = 4096. Both below the float rounding of the exact curve at 1 (6e-8).
struct Table {
  Table(int size, double (*f)(double)) : n(size), y(size + 1) {
    for (int i = 0; i <= n; ++i) y[i] = static_cast<float>(f(static_cast<double>(i) / n));
  }
  int n;
  std::vector<float> y;
};

// v[i] <- the table at v[i] clamped to [0, 1] (NaN -> 0, as ClampUnit), in place. A plain loop
// for the compiler (AVX2 gathers in its clone).
TURBID_ROW_KERNEL void LookUpRow(float* __restrict v, int count, const float* __restrict y,
                                 int n) {
  const float scale = static_cast<float>(n);
  for (int i = 0; i < count; ++i) {
    const float c = std::min(v[i] > 0.0f ? v[i] : 0.0f, 1.0f);
    const float x = c * scale;
    const int k = std::min(static_cast<int>(x), n - 1);
    const float f = x - static_cast<float>(k);
    v[i] = y[k] + f * (y[k + 1] - y[k]);
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
  if (in != out) std::copy(in, in + n, out);
  if (encoding == CameraEncoding::kSrgb) {
    const Table& table = EncodeTable();
    LookUpRow(out, n, table.y.data(), table.n);
  } else {
    for (int i = 0; i < n; ++i) out[i] = std::min(out[i] > 0.0f ? out[i] : 0.0f, 1.0f);
  }
}

void ClaheDecodeImage(cv::Mat& image, CameraEncoding encoding) {
  if (encoding != CameraEncoding::kSrgb) return;
  CV_Assert(image.depth() == CV_32F);
  const int per_row = image.cols * image.channels();
  const Table& table = DecodeTable();
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y)
      LookUpRow(image.ptr<float>(y), per_row, table.y.data(), table.n);
  });
}

double ClaheEncodeValue(double v, CameraEncoding encoding) {
  v = std::clamp(v, 0.0, 1.0);
  return encoding == CameraEncoding::kSrgb ? SrgbEncode(v) : v;
}

}  // namespace turbid::paper_internal
