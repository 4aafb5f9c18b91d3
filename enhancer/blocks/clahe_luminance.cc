// Colour CLAHE's luminance steps: Rec. 709 luminance of interleaved rows and the channels
// scaled by the equalised luminance's ratio (portable loops and their 8- and 16-lane twins,
// bit-identical).
#include "enhancer/blocks/clahe_luminance.h"

#include <algorithm>

#include "core/cpu.h"
#include "core/row_kernel.h"
#include "enhancer/simd_switch.h"
#include "enhancer/simd_vec.h"

namespace turbid::clahe_internal {
namespace {

// Rec. 709 luminance of an interleaved B, G, R row (kRgb: R, G, B; the same sum in the same
// order either way, so the same values).
template <bool kRgb>
TURBID_ROW_KERNEL void LuminanceRowT(const float* __restrict px, float* __restrict lum, int w) {
  constexpr int b = kRgb ? 2 : 0, r = kRgb ? 0 : 2;
  for (int x = 0; x < w; ++x) {
    lum[x] = 0.0722f * px[3 * x + b] + 0.7152f * px[3 * x + 1] + 0.2126f * px[3 * x + r];
  }
}

// The channels scaled by the luminance ratio (hue kept), in place over `bgr` (each value read
// and then written at the same index; one pointer, so the loop vectorises without an aliasing
// check). Where the luminance is ~0, gray at the equalised value. Branch-free (the ratio is
// formed everywhere and dropped where l is ~0).
TURBID_ROW_KERNEL void LuminanceRatioRow(float* __restrict bgr, const float* __restrict lum,
                                         const float* __restrict eq, int w) {
  for (int x = 0; x < w; ++x) {
    const float l = lum[x], e = eq[x];
    const float g = e / l;
    const bool dark = l <= 1e-6f;
    for (int c = 0; c < 3; ++c) {
      const float v = std::min(std::max(bgr[3 * x + c] * g, 0.0f), 1.0f);
      bgr[3 * x + c] = dark ? e : v;
    }
  }
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// The vector twins (GCC does not vectorise the stride-3 channel reads) at 8 lanes (AVX2) and 16
// (AVX-512), written once in clahe_luminance_rows.inc; no contraction (fp-contract=off), so the
// portable loops' products and sums.
#define TURBID_VEC_NO_CONTRACT
#define TURBID_VEC_BODY "enhancer/blocks/clahe_luminance_rows.inc"
#include "enhancer/simd_widths.inc"  // NOLINT(build/include): the body at 8 and 16 lanes
#define TURBID_HAVE_LUMINANCE_AVX2 1

// The vector rows at the kernel level's width (avx2 at least: UseHandWrittenAvx2()).
template <bool kRgb>
void LuminanceRowVec(const float* px, float* lum, int w) {
  if (KernelCpuLevel() >= CpuLevel::kAvx512) {
    vec16::LuminanceRowV<kRgb>(px, lum, w);
  } else {
    vec8::LuminanceRowV<kRgb>(px, lum, w);
  }
}
template <bool kRgb>
void LuminanceRatioRowVec(float* bgr, const float* eq, int w, float* lum_tail, const float* next) {
  if (KernelCpuLevel() >= CpuLevel::kAvx512) {
    vec16::LuminanceRatioRowV<kRgb>(bgr, eq, w, lum_tail, next);
  } else {
    vec8::LuminanceRatioRowV<kRgb>(bgr, eq, w, lum_tail, next);
  }
}
#endif

}  // namespace

void LuminanceRow(const float* px, float* lum, int w, bool rgb) {
#ifdef TURBID_HAVE_LUMINANCE_AVX2
  if (enhancer_internal::UseHandWrittenAvx2() && KernelCpuLevel() >= CpuLevel::kAvx2Fma) {
    rgb ? LuminanceRowVec<true>(px, lum, w) : LuminanceRowVec<false>(px, lum, w);
    return;
  }
#endif
  if (rgb) {
    LuminanceRowT<true>(px, lum, w);
  } else {
    LuminanceRowT<false>(px, lum, w);
  }
}

void LuminanceRatioRowInPlace(float* row, const float* e, int cols, float* lum, const float* next,
                              bool rgb) {
#ifdef TURBID_HAVE_LUMINANCE_AVX2
  if (enhancer_internal::UseHandWrittenAvx2() && KernelCpuLevel() >= CpuLevel::kAvx2Fma) {
    rgb ? LuminanceRatioRowVec<true>(row, e, cols, lum, next)
        : LuminanceRatioRowVec<false>(row, e, cols, lum, next);
    return;
  }
#endif
  LuminanceRow(row, lum, cols, rgb);
  LuminanceRatioRow(row, lum, e, cols);
}

}  // namespace turbid::clahe_internal
