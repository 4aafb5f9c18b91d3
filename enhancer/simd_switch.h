// Tests only: a switch between the hand-written AVX2 row kernels of the guided filter and CLAHE
// and their portable versions (plain loops the compiler vectorises). Both give the same results
// bit for bit; on an AVX2 machine the portable ones would otherwise never run, so tests turn the
// hand-written ones off to check that. Default: on (where the CPU has AVX2). The enhancer's name
// for core/cpu.h's kernel level and its cap.
#pragma once

#include "core/cpu.h"

namespace turbid::enhancer_internal {

inline void SetHandWrittenAvx2(bool enabled) {
  SetCpuLevelCap(enabled ? CpuLevel::kAvx512 : CpuLevel::kScalar);
}
// True when the CPU has AVX2 and the switch is on (GCC builds: the kernels are GCC-only).
inline bool UseHandWrittenAvx2() {
#if defined(__GNUC__) && !defined(__clang__)
  return KernelCpuLevel() >= CpuLevel::kAvx2;
#else
  return false;
#endif
}

}  // namespace turbid::enhancer_internal
