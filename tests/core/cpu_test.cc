// The one CPU-level query: detection is stable, the kernel level never exceeds it, and the cap
// (what tests use to run the portable loops) lowers and restores it.
#include "core/cpu.h"

#include <gtest/gtest.h>

#include <string>

namespace turbid {
namespace {

TEST(CpuLevel, DetectionIsStableAndOrdered) {
  const CpuLevel level = DetectedCpuLevel();
  EXPECT_EQ(DetectedCpuLevel(), level);
  EXPECT_TRUE(CpuHas(CpuLevel::kScalar));
  EXPECT_EQ(CpuHas(CpuLevel::kAvx2), level >= CpuLevel::kAvx2);
  EXPECT_EQ(CpuHas(CpuLevel::kAvx512), level == CpuLevel::kAvx512);
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
  EXPECT_EQ(CpuHas(CpuLevel::kAvx2), bool(__builtin_cpu_supports("avx2")));
  EXPECT_EQ(CpuHas(CpuLevel::kAvx2Fma),
            __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"));
#endif
}

TEST(CpuLevel, CapLowersTheKernelLevelAndRestores) {
  EXPECT_EQ(KernelCpuLevel(), DetectedCpuLevel());
  SetCpuLevelCap(CpuLevel::kScalar);
  EXPECT_EQ(KernelCpuLevel(), CpuLevel::kScalar);
  EXPECT_EQ(DetectedCpuLevel(), DetectedCpuLevel());  // detection is not capped
  SetCpuLevelCap(CpuLevel::kAvx2);
  EXPECT_LE(KernelCpuLevel(), CpuLevel::kAvx2);
  SetCpuLevelCap(CpuLevel::kAvx512);
  EXPECT_EQ(KernelCpuLevel(), DetectedCpuLevel());
}

TEST(CpuLevel, Names) {
  EXPECT_EQ(std::string(CpuLevelName(CpuLevel::kScalar)), "scalar");
  EXPECT_EQ(std::string(CpuLevelName(CpuLevel::kAvx2Fma)), "avx2+fma");
  EXPECT_EQ(std::string(CpuLevelName(CpuLevel::kAvx512)), "avx512");
}

}  // namespace
}  // namespace turbid
