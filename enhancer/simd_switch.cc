#include "enhancer/simd_switch.h"

#include <atomic>

namespace turbid::enhancer_internal {
namespace {

std::atomic<bool> g_enabled{true};

bool CpuHasAvx2() {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

}  // namespace

void SetHandWrittenAvx2(bool enabled) { g_enabled.store(enabled, std::memory_order_relaxed); }

bool UseHandWrittenAvx2() {
  static const bool cpu = CpuHasAvx2();
  return cpu && g_enabled.load(std::memory_order_relaxed);
}

}  // namespace turbid::enhancer_internal
