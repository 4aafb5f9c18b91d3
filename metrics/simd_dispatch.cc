#include "metrics/simd_dispatch.h"

#include <algorithm>
#include <cmath>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

// The same loops compiled twice; the AVX2 + FMA copy is chosen at run time when the CPU has both
// (checked once). Results of the two copies differ in the last float bits (FMA contraction), so
// scores can differ by ~1e-7 between machines; on one machine they are deterministic.
namespace turbid::simd {

namespace base {
#include "metrics/simd_kernels.inc"
}  // namespace base

#if defined(__x86_64__) && defined(__GNUC__)
#define TURBID_HAVE_AVX2_COPY 1
#pragma GCC push_options
#pragma GCC target("avx2,fma")
namespace avx2 {
#include "metrics/simd_kernels.inc"

// The two hot loops by hand: 64 columns = 8 independent FMA chains, enough to hide the FMA
// latency (11 taps x 4-5 cycles) behind two FMAs per cycle.
template <typename RowAt>
inline void FilterColumns(RowAt row_at, const float* weights, int taps, float* out, int n) {
  int j = 0;
  for (; j + 64 <= n; j += 64) {
    __m256 acc[8];
    for (int l = 0; l < 8; ++l) acc[l] = _mm256_setzero_ps();
    for (int k = 0; k < taps; ++k) {
      const __m256 w = _mm256_broadcast_ss(weights + k);
      const float* r = row_at(k) + j;
      for (int l = 0; l < 8; ++l) acc[l] = _mm256_fmadd_ps(w, _mm256_loadu_ps(r + 8 * l), acc[l]);
    }
    for (int l = 0; l < 8; ++l) _mm256_storeu_ps(out + j + 8 * l, acc[l]);
  }
  for (; j + 8 <= n; j += 8) {
    __m256 acc = _mm256_setzero_ps();
    for (int k = 0; k < taps; ++k)
      acc = _mm256_fmadd_ps(_mm256_broadcast_ss(weights + k), _mm256_loadu_ps(row_at(k) + j), acc);
    _mm256_storeu_ps(out + j, acc);
  }
  for (; j < n; ++j) {
    float s = 0.0f;
    for (int k = 0; k < taps; ++k) s = std::fma(weights[k], row_at(k)[j], s);
    out[j] = s;
  }
}

void WeightedRowSumFast(const float* const* rows, const float* weights, int taps, float* out,
                        int n) {
  FilterColumns([rows](int k) { return rows[k]; }, weights, taps, out, n);
}

void Convolve1DFast(const float* in, const float* weights, int taps, float* out, int n) {
  FilterColumns([in](int k) { return in + k; }, weights, taps, out, n);
}
}  // namespace avx2
#pragma GCC pop_options
#endif

namespace {
bool UseAvx2() {
#ifdef TURBID_HAVE_AVX2_COPY
  static const bool yes = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return yes;
#else
  return false;
#endif
}
}  // namespace

#ifdef TURBID_HAVE_AVX2_COPY
#define TURBID_DISPATCH(call) return UseAvx2() ? avx2::call : base::call
#else
#define TURBID_DISPATCH(call) return base::call
#endif

void WeightedRowSum(const float* const* rows, const float* weights, int taps, float* out, int n) {
  #ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::WeightedRowSumFast(rows, weights, taps, out, n);
#endif
  base::WeightedRowSum(rows, weights, taps, out, n);
}

void Convolve1D(const float* in, const float* weights, int taps, float* out, int n) {
  #ifdef TURBID_HAVE_AVX2_COPY
  if (UseAvx2()) return avx2::Convolve1DFast(in, weights, taps, out, n);
#endif
  base::Convolve1D(in, weights, taps, out, n);
}

void Products(const float* x, const float* y, float* xx, float* yy, float* xy, int n) {
  TURBID_DISPATCH(Products(x, y, xx, yy, xy, n));
}

void SsimFormulaRow(const float* mx, const float* my, const float* mxx, const float* myy,
                    const float* mxy, int n, double offset, double c1, double c2, double* out) {
  TURBID_DISPATCH(SsimFormulaRow(mx, my, mxx, myy, mxy, n, offset, c1, c2, out));
}

double OrderedSum(const double* values, int n) { TURBID_DISPATCH(OrderedSum(values, n)); }

uint64_t SquaredDifferenceSumU8(const uint8_t* a, const uint8_t* b, size_t n) {
  TURBID_DISPATCH(SquaredDifferenceSumU8(a, b, n));
}

double SquaredDifferenceSumF32(const float* a, const float* b, size_t n) {
  TURBID_DISPATCH(SquaredDifferenceSumF32(a, b, n));
}

}  // namespace turbid::simd
