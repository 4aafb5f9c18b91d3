#include "core/cpu.h"

#include <algorithm>
#include <atomic>

namespace turbid {
namespace {

CpuLevel Detect() {
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
  if (!__builtin_cpu_supports("avx2")) return CpuLevel::kScalar;
  if (!__builtin_cpu_supports("fma")) return CpuLevel::kAvx2;
  return __builtin_cpu_supports("avx512f") ? CpuLevel::kAvx512 : CpuLevel::kAvx2Fma;
#else
  return CpuLevel::kScalar;
#endif
}

std::atomic<int> g_cap{static_cast<int>(CpuLevel::kAvx512)};

}  // namespace

CpuLevel DetectedCpuLevel() {
  static const CpuLevel level = Detect();
  return level;
}

CpuLevel KernelCpuLevel() {
  return static_cast<CpuLevel>(
      std::min(static_cast<int>(DetectedCpuLevel()), g_cap.load(std::memory_order_relaxed)));
}

void SetCpuLevelCap(CpuLevel cap) { g_cap.store(static_cast<int>(cap), std::memory_order_relaxed); }

const char* CpuLevelName(CpuLevel level) {
  switch (level) {
    case CpuLevel::kScalar:
      return "scalar";
    case CpuLevel::kAvx2:
      return "avx2";
    case CpuLevel::kAvx2Fma:
      return "avx2+fma";
    case CpuLevel::kAvx512:
      return "avx512";
  }
  return "scalar";
}

}  // namespace turbid
