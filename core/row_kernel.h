// TURBID_ROW_KERNEL marks a function that processes whole rows of contiguous values, written as
// plain loops for the compiler to vectorise. On x86-64 GCC builds it compiles an AVX2 clone besides
// the baseline one and picks it at load time (the project is compiled for baseline x86-64, so the
// binaries run anywhere). The AVX2 target does not enable FMA, so both clones round identically.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define TURBID_ROW_KERNEL __attribute__((target_clones("avx2", "default")))
#else
#define TURBID_ROW_KERNEL
#endif
