// The CPU's vector level: the one place that asks the processor what it supports. Hand-written
// kernels (metrics' AVX2/AVX-512 copies, the enhancer's AVX2 rows, the renderer's range and the
// built-in scenes' textures) dispatch on it. Detected once per process; x86-64 with GCC or Clang
// only (kScalar elsewhere).
#pragma once

namespace turbid {

// Ordered: each level includes the ones below it. kAvx512 also requires AVX2 and FMA.
enum class CpuLevel { kScalar = 0, kAvx2 = 1, kAvx2Fma = 2, kAvx512 = 3 };

// What the processor supports (cached after the first call; thread-safe).
CpuLevel DetectedCpuLevel();
inline bool CpuHas(CpuLevel level) { return DetectedCpuLevel() >= level; }

// The level hand-written kernels may use: min(DetectedCpuLevel(), the cap). Tests lower the cap to
// run the portable loops on a machine that has the vector units (SetCpuLevelCap(kScalar)) and
// restore it afterwards (SetCpuLevelCap(kAvx512)); the default cap is kAvx512. Each module's
// kernels give the same results at every level, bit for bit, and their tests check that.
CpuLevel KernelCpuLevel();
void SetCpuLevelCap(CpuLevel cap);

// "scalar", "avx2", "avx2+fma", "avx512" (bench reports, diagnostics).
const char* CpuLevelName(CpuLevel level);

}  // namespace turbid
