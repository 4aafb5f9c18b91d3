// Internal: a vectorisable float exp for the per-pixel kernels (transmission, light attenuation).
// Not part of the public API. Cody-Waite range reduction x = n ln2 + r, |r| <= ln2/2, and the
// Taylor polynomial of exp(r) to r^7 (relative error < 2e-7, below float's resolution for the
// [0, 1] values it produces). Branch-free so that loops calling it vectorise.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace turbid::internal {

// exp(x) for x in [-87, 0]; larger arguments are clamped to 0, smaller to -87 (exp ~ 1.6e-38).
inline float ExpNonPositive(float x) {
  x = std::min(std::max(x, -87.0f), 0.0f);  // min/max, not branches: keeps loops vectorisable
  const int n = static_cast<int>(x * 1.44269504089f - 0.5f);  // round(x / ln2) for x <= 0
  const float nf = static_cast<float>(n);
  const float r = (x - nf * 0.693145751953125f) - nf * 1.428606765330187e-06f;
  const float p =
      1.0f +
      r * (1.0f +
           r * (0.5f + r * (1.6666667e-1f +
                            r * (4.1666668e-2f +
                                 r * (8.3333338e-3f + r * (1.3888889e-3f + r * 1.9841270e-4f))))));
  const uint32_t bits = static_cast<uint32_t>(n + 127) << 23;  // 2^n, n in [-126, 0]
  float scale;
  std::memcpy(&scale, &bits, 4);
  return p * scale;
}

}  // namespace turbid::internal
