// TURBID_WIDE_KERNEL: TURBID_ROW_KERNEL (core/row_kernel.h) plus an AVX-512 clone, for the
// render's per-pixel row kernels (sensor noise, light, transmission, blur taps, composition):
// 16 lanes instead of 8.
// GCC's avx512f target enables FMA, so the clone is compiled with fp-contract=off: every clone
// rounds each operation alike and gives the same bits (tested: the regression baselines and the
// thread-count identity tests run whichever clone the CPU picks).
#pragma once

#include "core/row_kernel.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define TURBID_WIDE_KERNEL \
  __attribute__((target_clones("avx512f", "avx2", "default"), optimize("fp-contract=off")))
#else
#define TURBID_WIDE_KERNEL TURBID_ROW_KERNEL
#endif
