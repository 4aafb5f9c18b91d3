#include "metrics/simd_dispatch.h"

#include <algorithm>

// target_clones needs ifunc support (glibc on x86-64); elsewhere the plain build is used.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define TURBID_SIMD_CLONES __attribute__((target_clones("arch=haswell", "default")))
#else
#define TURBID_SIMD_CLONES
#endif

namespace turbid::simd {

TURBID_SIMD_CLONES
void WeightedRowSum(const float* const* rows, const float* weights, int taps, float* out, int n) {
  // Blocks of 64 columns keep the partial sums in registers across the taps.
  constexpr int kBlock = 64;
  for (int j0 = 0; j0 < n; j0 += kBlock) {
    const int len = std::min(kBlock, n - j0);
    float acc[kBlock];
    const float w0 = weights[0];
    const float* r0 = rows[0] + j0;
    for (int j = 0; j < len; ++j) acc[j] = w0 * r0[j];
    for (int k = 1; k < taps; ++k) {
      const float w = weights[k];
      const float* r = rows[k] + j0;
      for (int j = 0; j < len; ++j) acc[j] += w * r[j];
    }
    for (int j = 0; j < len; ++j) out[j0 + j] = acc[j];
  }
}

TURBID_SIMD_CLONES
void Convolve1D(const float* in, const float* weights, int taps, float* out, int n) {
  constexpr int kBlock = 64;
  for (int j0 = 0; j0 < n; j0 += kBlock) {
    const int len = std::min(kBlock, n - j0);
    float acc[kBlock];
    const float* base = in + j0;
    const float w0 = weights[0];
    for (int j = 0; j < len; ++j) acc[j] = w0 * base[j];
    for (int k = 1; k < taps; ++k) {
      const float w = weights[k];
      const float* r = base + k;
      for (int j = 0; j < len; ++j) acc[j] += w * r[j];
    }
    for (int j = 0; j < len; ++j) out[j0 + j] = acc[j];
  }
}

TURBID_SIMD_CLONES
void Products(const float* x, const float* y, float* xx, float* yy, float* xy, int n) {
  for (int j = 0; j < n; ++j) {
    xx[j] = x[j] * x[j];
    yy[j] = y[j] * y[j];
    xy[j] = x[j] * y[j];
  }
}

TURBID_SIMD_CLONES
void SsimFormulaRow(const float* mx, const float* my, const float* mxx, const float* myy,
                    const float* mxy, int n, double offset, double c1, double c2, double* out) {
  for (int j = 0; j < n; ++j) {
    const double dx = mx[j];
    const double dy = my[j];
    const double ux = dx + offset;
    const double uy = dy + offset;
    const double vx = static_cast<double>(mxx[j]) - dx * dx;
    const double vy = static_cast<double>(myy[j]) - dy * dy;
    const double vxy = static_cast<double>(mxy[j]) - dx * dy;
    const double num = (2.0 * ux * uy + c1) * (2.0 * vxy + c2);
    const double den = (ux * ux + uy * uy + c1) * (vx + vy + c2);
    out[j] = num / den;
  }
}

TURBID_SIMD_CLONES
double OrderedSum(const double* values, int n) {
  double lane[4] = {0.0, 0.0, 0.0, 0.0};
  int j = 0;
  for (; j + 4 <= n; j += 4)
    for (int l = 0; l < 4; ++l) lane[l] += values[j + l];
  double sum = (lane[0] + lane[1]) + (lane[2] + lane[3]);
  for (; j < n; ++j) sum += values[j];
  return sum;
}

TURBID_SIMD_CLONES
uint64_t SquaredDifferenceSumU8(const uint8_t* a, const uint8_t* b, size_t n) {
  // 65536 * 255^2 < 2^32: a 32-bit partial sum per chunk cannot overflow.
  constexpr size_t kChunk = 65536;
  uint64_t total = 0;
  for (size_t start = 0; start < n; start += kChunk) {
    const size_t end = std::min(n, start + kChunk);
    uint32_t partial = 0;
    for (size_t i = start; i < end; ++i) {
      const int32_t d = static_cast<int32_t>(a[i]) - static_cast<int32_t>(b[i]);
      partial += static_cast<uint32_t>(d * d);
    }
    total += partial;
  }
  return total;
}

TURBID_SIMD_CLONES
double SquaredDifferenceSumF32(const float* a, const float* b, size_t n) {
  double lane[4] = {0.0, 0.0, 0.0, 0.0};
  size_t i = 0;
  for (; i + 4 <= n; i += 4)
    for (int l = 0; l < 4; ++l) {
      const double d = static_cast<double>(a[i + l]) - static_cast<double>(b[i + l]);
      lane[l] += d * d;
    }
  double sum = (lane[0] + lane[1]) + (lane[2] + lane[3]);
  for (; i < n; ++i) {
    const double d = static_cast<double>(a[i]) - static_cast<double>(b[i]);
    sum += d * d;
  }
  return sum;
}

}  // namespace turbid::simd
