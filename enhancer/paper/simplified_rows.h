// `simplified`'s colour output step in guided_segments' layout (issue 29 item 6, third round):
// the detail boost of the two filters' segment rows, clamped, written to the natural output row
// with the Rec. 709 luminance CLAHE bins, in one pass (no segment row of the boost, no second
// read of the output row).
#pragma once

namespace turbid::simplified_internal {

// i_f, i_g: segment rows of L columns of `lanes` lanes (8 or 16; guided_segments::Stream::
// RowSegments; lane k of column s channel c = pixel k L + s, channel c). Writes q = clamp(i_g +
// alpha (i_f - i_g), 0, 1) (NaN to 0) to the first `cols` pixels (3 floats each) of `dst`, with
// non-temporal stores where `stream`; when lum is not null, lum[p] (lanes L floats) = 0.0722 B +
// 0.7152 G + 0.2126 R of q, in that order without fused multiply-adds (clahe_luminance.cc's values;
// R and B swapped when rgb). Returns whether every boosted value before the clamp was finite.
struct BoostOutArgs {
  const float* i_f = nullptr;
  const float* i_g = nullptr;
  int L = 0;
  int lanes = 8;
  int cols = 0;
  float alpha = 0.0f;
  bool rgb = false;
  bool stream = false;
  float* dst = nullptr;
  float* lum = nullptr;
};
using BoostOutFn = bool (*)(const BoostOutArgs& a);

// Plain loops: q = i_g + alpha (i_f - i_g), a product and a sum.
bool BoostOutPortable(const BoostOutArgs& a);
// AVX2 + FMA: q = fma(alpha, i_f - i_g, i_g), 8 x 8 transposes (per group of 8 lanes); null where
// the build has none.
BoostOutFn BoostOutAvx2Fma();
// AVX-512: the 16-lane layout with 16 x 16 transposes (the 8-lane one: the AVX2 kernel); null
// where the build has none.
BoostOutFn BoostOutAvx512();
// The kernel this process uses (AVX-512 or AVX2 + FMA where core/cpu.h's KernelCpuLevel() allows).
BoostOutFn ChosenBoostOut();

}  // namespace turbid::simplified_internal
