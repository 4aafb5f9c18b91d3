// The AVX2 copies of the visible-edge kernels (Weber window sums, packed pairs and blocks, packed
// contrasts, IFSTTAR strong rows, separated pairs), defined in simd_edges_avx2.cc and dispatched by
// simd_dispatch.cc. Internal to metrics/: call the simd:: entry points in simd_dispatch.h. Declared
// with the same target attributes as their definitions (x86-64 GCC/Clang only).
#pragma once

#include "metrics/simd_dispatch.h"

#if defined(__x86_64__) && defined(__GNUC__)
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,fma")
#endif
namespace turbid::simd::avx2 {

void WeberWindowSumsFast(const double* table, int table_stride, const uint8_t* value,
                         const uint8_t* tests, int stride, int size, int s_min, int s_max,
                         double* sums_v, double* sums_h, double* counts_v, double* counts_h);
void AddPackedPairsFast(const uint8_t* value, const uint8_t* tests, int stride, int rows, int cols,
                        bool paper, int clip_lo, int clip_hi, double* acc);
void AddPackedBlocksFast(const uint8_t* value, const uint8_t* tests, int stride, bool paper,
                         const PackedBlock* blocks, int n_blocks);
PackedMaximum PackedContrastsFast(const double* const* parts, int n_parts, int s_min, int s_max,
                                  double tie_width, double* contrast);
PackedMaximum PackedContrastsWithStripFast(const double* const* parts, int n_parts, double* strip,
                                           const double* const* adds, int n_add, int strip_lo,
                                           int strip_hi, int s_min, int s_max, double tie_width,
                                           double* contrast);
void IfsttarStrongRowFast(const uint8_t* tests, const uint8_t* row, const uint8_t* up, int n, int k,
                          int k_ratio, uint8_t* strong);
void SeparatedPairRowsFast(const uint8_t* tests, int stride, int s0, unsigned* rows);
// The portable loop of simd_kernels.inc, compiled for AVX2 in simd_dispatch.cc (short rows).
void IfsttarStrongRow(const uint8_t* tests, const uint8_t* row, const uint8_t* up, int n, int k,
                      int k_ratio, uint8_t* strong);

}  // namespace turbid::simd::avx2
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif
