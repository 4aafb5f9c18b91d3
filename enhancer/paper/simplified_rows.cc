// `simplified`'s colour output step, portable loops and the choice of kernel (simplified_rows.h).
#include "enhancer/paper/simplified_rows.h"

#include <algorithm>
#include <cmath>

#include "core/cpu.h"

namespace turbid::simplified_internal {

bool BoostOutPortable(const BoostOutArgs& a) {
  constexpr int kB = 0, kG = 1, kR = 2;
  const int b = a.rgb ? kR : kB, r = a.rgb ? kB : kR;
  bool finite = true;
  for (int k = 0; k < a.lanes; ++k) {
    for (int s = 0; s < a.L; ++s) {
      const int p = k * a.L + s;  // the pixel of lane k, column s
      float q[3];
      for (int c = 0; c < 3; ++c) {
        const size_t at = (static_cast<size_t>(s) * 3 + c) * a.lanes + k;
        const float v = a.i_g[at] + a.alpha * (a.i_f[at] - a.i_g[at]);
        finite = finite && std::isfinite(v);
        const float x = v != v ? 0.0f : v;
        q[c] = std::max(std::min(x, 1.0f), 0.0f);
      }
      if (a.lum != nullptr) a.lum[p] = 0.0722f * q[b] + 0.7152f * q[kG] + 0.2126f * q[r];
      if (p < a.cols) std::copy(q, q + 3, a.dst + static_cast<size_t>(p) * 3);
    }
  }
  return finite;
}

BoostOutFn ChosenBoostOut() {
  const CpuLevel level = KernelCpuLevel();
  const BoostOutFn avx512 = level >= CpuLevel::kAvx512 ? BoostOutAvx512() : nullptr;
  if (avx512 != nullptr) return avx512;
  const BoostOutFn avx2 = level >= CpuLevel::kAvx2Fma ? BoostOutAvx2Fma() : nullptr;
  return avx2 != nullptr ? avx2 : BoostOutPortable;
}

}  // namespace turbid::simplified_internal
