// Internal to enhancer/paper/: the row kernels of `full` and `simplified` (kernels.cc). The
// TURBID_ROW_KERNEL loops are the portable arithmetic; the *Avx2 / *Fma versions reproduce it lane
// by lane (the same bits) and exist only where TURBID_HAVE_*_AVX2 is defined (GCC on x86-64).
#pragma once

#include "core/row_kernel.h"

namespace turbid::paper_internal {

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define TURBID_HAVE_BOOST_AVX2 1
#define TURBID_HAVE_NOISE_AVX2 1
#define TURBID_HAVE_DEHAZE_AVX2 1
#endif

// Whether the CPU has FMA and AVX2 (AddWeightedRow, ExposureDetailRow and the AVX2 kernels'
// fused steps follow it, as OpenCV's dispatched kernels do).
bool CpuHasFma();

// dst = i_g beta + i_f alpha in double, rounded to float once (cv::addWeighted's arithmetic).
void AddWeightedRow(const float* i_g, const float* i_f, double beta, double alpha, float* dst,
                    int n);

#ifdef TURBID_HAVE_BOOST_AVX2
// AddWeightedRow then ClampUnitRow in registers; returns whether every boosted value was finite.
template <bool kFma>
__attribute__((target("avx2,fma"))) bool BoostClampRowAvx2(const float* i_g, const float* i_f,
                                                           double beta, double alpha, float* dst,
                                                           int n, float* next_dst,
                                                           float* stream_dst);
#endif

// ClampUnit on one row: NaN to 0 (cv::patchNaNs), then [0, 1].
void ClampUnitRow(float* __restrict v, int n);
// ClampUnitRow from `src` into `dst`.
void ClampUnitCopyRow(const float* __restrict src, float* __restrict dst, int n);

// `full`'s exposure and detail steps on one row: j = j * inv_level, then j + k (I - I_de).
void ExposureDetailRow(const float* image, const float* denoised, float inv_level, float k,
                       float* j, int n);

// |I * N| (Immerkaer's 3x3 mask) along one row, for the n values from i = ch on.
void LaplacianAbsRow(const float* __restrict a, const float* __restrict b,
                     const float* __restrict c, int ch, float* __restrict out, int n);
#ifdef TURBID_HAVE_NOISE_AVX2
// Eight rows' sums of |I * N| at once (rows[0..9]: the rows y0 - 1 .. y0 + 8); row[k] receives
// row y0 + k's sum.
__attribute__((target("avx2"))) void LaplacianAbsSums8(const float* const* rows, int ch, int n,
                                                       float* row);
// The same for sixteen rows (rows[0..17]) with AVX-512 (callers check KernelCpuLevel()).
__attribute__((target("avx512f,avx2,fma"), optimize("fp-contract=off"))) void LaplacianAbsSums16(
    const float* const* rows, int ch, int n, float* row);
#endif

#ifdef TURBID_HAVE_DEHAZE_AVX2
// What DehazeSpreadAvx2 does after eq. 6 (kernels.cc).
enum class AfterDehaze { kNone, kScale, kScaleDetail };
// Eq. 6 on an interleaved BGR row from one-channel t and E_L rows (w pixels), then `kAfter`; 16
// lanes where KernelCpuLevel() reaches avx512, else 8 (AVX2 and FMA: callers check CpuHasFma()).
template <AfterDehaze kAfter>
void DehazeSpreadAvx2(const float* in, const float* e, const double* scale, const float* t,
                      const float* image, float inv_level, float k_detail, float* d, int w);
#endif

// I_g + alpha (I_f - I_g), as addWeighted(I_g, 1 - alpha, I_f, alpha).
void DetailBoostRow(const float* __restrict i_f, const float* __restrict i_g, float alpha,
                    float one_minus_alpha, float* __restrict dst, int w);
// Clamped to [0, 1] (a loop of its own: GCC vectorises it alone, not after the arithmetic).
void ClampRow(float* __restrict v, int w);

}  // namespace turbid::paper_internal
