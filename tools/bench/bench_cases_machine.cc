// `turbid bench` rows that measure the machine rather than turbid: memory bandwidth (a STREAM-like
// copy and triad over arrays far larger than the caches) and peak single-precision arithmetic
// (independent FMA chains at the widest SIMD width the CPU has). docs/performance.md divides each
// kernel's bytes and flops by these to say how close it is to the machine's limit.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <immintrin.h>
#include <memory>
#include <string>
#include <vector>

#include "core/cpu.h"
#include "tools/bench/bench_cases.h"

namespace turbid::bench {
namespace {

constexpr size_t kFloats = size_t{16} << 20;  // 64 MiB per array: beyond any cache here
constexpr size_t kCacheFloats = size_t{1} << 19;  // 2 MiB per array: 6 MiB, inside a 32 MiB L3
constexpr int kChains = 12;                   // independent accumulators (FMA latency x ports)
constexpr int64_t kFmaIterations = 1 << 22;

struct Arrays {
  std::vector<float> a, b, c;
  explicit Arrays(size_t n) : a(n, 1.0f), b(n, 2.0f), c(n, 0.5f) {}
};

void Triad(Arrays& x) {
  float* __restrict a = x.a.data();
  const float* __restrict b = x.b.data();
  const float* __restrict c = x.c.data();
  const size_t n = x.a.size();
  for (size_t i = 0; i < n; ++i) a[i] = b[i] + 1.5f * c[i];
  benchmark::DoNotOptimize(a);
}

void Copy(Arrays& x) {
  std::memcpy(x.a.data(), x.b.data(), x.a.size() * sizeof(float));
  benchmark::DoNotOptimize(x.a.data());
}

// The last-level cache's size in bytes (sysfs), 0 when unknown.
long LastLevelCacheBytes() {
  long best = 0;
  for (int index = 0; index < 8; ++index) {
    std::ifstream in("/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(index) + "/size");
    std::string text;
    if (!(in >> text) || text.empty()) continue;
    long value = std::atol(text.c_str());
    if (text.back() == 'K') value <<= 10;
    if (text.back() == 'M') value <<= 20;
    best = std::max(best, value);
  }
  return best;
}

__attribute__((target("avx2,fma"))) float Fma256() {
  __m256 acc[kChains];
  for (int k = 0; k < kChains; ++k) acc[k] = _mm256_set1_ps(0.001f * static_cast<float>(k));
  const __m256 m = _mm256_set1_ps(0.999999f), s = _mm256_set1_ps(1e-7f);
  for (int64_t i = 0; i < kFmaIterations; ++i)
    for (int k = 0; k < kChains; ++k) acc[k] = _mm256_fmadd_ps(acc[k], m, s);
  __m256 sum = acc[0];
  for (int k = 1; k < kChains; ++k) sum = _mm256_add_ps(sum, acc[k]);
  float out[8];
  _mm256_storeu_ps(out, sum);
  return out[0];
}

__attribute__((target("avx512f"))) float Fma512() {
  __m512 acc[kChains];
  for (int k = 0; k < kChains; ++k) acc[k] = _mm512_set1_ps(0.001f * static_cast<float>(k));
  const __m512 m = _mm512_set1_ps(0.999999f), s = _mm512_set1_ps(1e-7f);
  for (int64_t i = 0; i < kFmaIterations; ++i)
    for (int k = 0; k < kChains; ++k) acc[k] = _mm512_fmadd_ps(acc[k], m, s);
  __m512 sum = acc[0];
  for (int k = 1; k < kChains; ++k) sum = _mm512_add_ps(sum, acc[k]);
  float out[16];
  _mm512_storeu_ps(out, sum);
  return out[0];
}

// Best of `runs` calls, in seconds.
double BestSeconds(const std::function<void()>& fn, int runs) {
  double best = 1e30;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

}  // namespace

void AddMachineCases(std::vector<BenchCase>& cases, const InputsFn& /*in*/) {
  // Allocated on first use only (three 64 MiB arrays), shared by the two bandwidth rows.
  auto arrays = std::make_shared<std::unique_ptr<Arrays>>();
  auto get = [arrays]() -> Arrays& {
    if (!*arrays) *arrays = std::make_unique<Arrays>(kFloats);
    return **arrays;
  };
  auto small = std::make_shared<std::unique_ptr<Arrays>>();
  auto get_small = [small]() -> Arrays& {
    if (!*small) *small = std::make_unique<Arrays>(kCacheFloats);
    return **small;
  };
  {
    BenchCase c;
    c.name = "machine/memory/triad";
    c.ours = [get] { Triad(get()); };
    c.agreement = [get] {
      const double s = BestSeconds([get] { Triad(get()); }, 5);
      const double moved = 3.0 * kFloats * sizeof(float);  // 2 loads + 1 store per element
      return Format("%.1f GB/s", moved / s / 1e9) + " (a = b + s c, 3 x 64 MiB; " +
             Format("%.1f GB/s", (moved + kFloats * sizeof(float)) / s / 1e9) +
             " counting the store's read for ownership), best of 5";
    };
    c.goal = {0.0, 0.0, "the machine's memory bandwidth (docs/performance.md, roofline)"};
    cases.push_back(c);
  }
  {
    BenchCase c;
    c.name = "machine/memory/copy";
    c.ours = [get] { Copy(get()); };
    c.agreement = [get] {
      const double s = BestSeconds([get] { Copy(get()); }, 5);
      return Format("%.1f GB/s", 2.0 * kFloats * sizeof(float) / s / 1e9) +
             " (memcpy 64 MiB: read + write), best of 5";
    };
    c.goal = {0.0, 0.0, "the machine's memory bandwidth (docs/performance.md, roofline)"};
    cases.push_back(c);
  }
  {
    // The bench's inputs (1.4-17 MB per call) stay in a 32 MiB last-level cache between
    // iterations: their bound is the cache's bandwidth, not memory's.
    BenchCase c;
    c.name = "machine/cache/triad";
    c.ours = [get_small] { Triad(get_small()); };
    c.agreement = [get_small] {
      const double s = BestSeconds([get_small] { Triad(get_small()); }, 50);
      const double moved = 3.0 * kCacheFloats * sizeof(float);
      return Format("%.1f GB/s", moved / s / 1e9) + " (a = b + s c, 3 x 2 MiB; last-level cache " +
             std::to_string(LastLevelCacheBytes() >> 20) + " MiB), best of 50";
    };
    c.goal = {0.0, 0.0, "the last-level cache's bandwidth (docs/performance.md, roofline)"};
    cases.push_back(c);
  }
  const bool avx512 = CpuHas(CpuLevel::kAvx512);
  if (CpuHas(CpuLevel::kAvx2Fma)) {
    for (int width : {256, 512}) {
      if (width == 512 && !avx512) continue;
      BenchCase c;
      c.name = "machine/fma/f32x" + std::to_string(width / 32);
      const auto run = [width] {
        benchmark::DoNotOptimize(width == 512 ? Fma512() : Fma256());
      };
      c.ours = run;
      c.agreement = [run, width] {
        const double s = BestSeconds(run, 3);
        const double flops = 2.0 * (width / 32) * kChains * static_cast<double>(kFmaIterations);
        return Format("%.1f GFLOP/s", flops / s / 1e9) + " single precision, one core (" +
               std::to_string(kChains) + " independent FMA chains), best of 3";
      };
      c.goal = {0.0, 0.0, "the machine's peak arithmetic (docs/performance.md, roofline)"};
      cases.push_back(c);
    }
  }
}

}  // namespace turbid::bench
