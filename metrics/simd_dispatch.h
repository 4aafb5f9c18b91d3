// Row kernels of the metrics, compiled twice (x86-64 baseline and AVX2 + FMA) and picked at
// run time from the CPU (simd_dispatch.cc), so one binary runs everywhere and is fast where it can
// be. Every reduction here adds in a fixed order, so results do not depend on threads.
#pragma once

#include <cstddef>
#include <cstdint>

namespace turbid::simd {

// The widest instruction set the metric kernels use: the CPU's (checked once), capped by
// SetSimdLevelCap. Copies of one kernel for different levels give the same results bit for bit
// unless their comment says otherwise; the tests lower the cap to compare them.
enum class SimdLevel { kBaseline = 0, kAvx2 = 1, kAvx512 = 2 };
SimdLevel ActiveSimdLevel();
// For tests: not synchronised with kernels running on other threads.
void SetSimdLevelCap(SimdLevel cap);

// Two consecutive output rows of a vertical pass with symmetric weights (weights[k] ==
// weights[taps - 1 - k]): rows holds taps + 1 consecutive input rows; out0[j] = sum_k weights[k] *
// rows[k][j] and out1[j] = sum_k weights[k] * rows[k + 1][j], j < n. Pairs of taps are added before
// the multiply, and the shared rows are read once for both outputs.
void SymmetricColumnPair(const float* const* rows, const float* weights, int taps, float* out0,
                         float* out1, int n);

// The same for four consecutive output rows (rows holds taps + 3 input rows; out[t][j] = sum_k
// weights[k] * rows[k + t][j]): each input row is read from memory once for all four outputs.
void SymmetricColumnQuad(const float* const* rows, const float* weights, int taps,
                         float* const* out, int n);

// The horizontal symmetric pass of the four SSIM moments fused with the SSIM formula:
// moments[m] points at column 0 of a row that holds radius = taps / 2 readable values on each side
// (the reflected border); the moments are, in order, E[x - o], E[y - o], the centred E[(x - o)(y -
// o)] and E[(x - y)^2] after the vertical pass. Writes the SSIM of columns [0, n) to out (Wang 2004
// Eq. 13, written as in SsimFormulaRow of simd_kernels.inc).
void SsimHorizontalFormula(const float* const* moments, const float* weights, int taps, int n,
                           double offset, double c1, double c2, double* out);

// One channel of two interleaved 8-bit rows (element j at x[j * step], y[j * step]), centred and
// multiplied in one pass: cx = x - offset, cy = y - offset, xy = cx * cy, dd = (x - y)^2 (all
// exact in float for 8-bit values and offset 127.5).
void CentredMomentsU8(const uint8_t* x, const uint8_t* y, int step, float offset, float* cx,
                      float* cy, float* xy, float* dd, int n);

// Sum of n doubles in a fixed 4-lane order (vectorisable, deterministic).
double OrderedSum(const double* values, int n);

// Sum of squared differences of n values, exact for 8-bit inputs (integer arithmetic).
uint64_t SquaredDifferenceSumU8(const uint8_t* a, const uint8_t* b, size_t n);
// The same in double for float / 16-bit values, in a fixed 4-lane order.
double SquaredDifferenceSumF32(const float* a, const float* b, size_t n);

// The contrast sums of one visible-edge window (metrics/visible_edges.cc). `value` points at the
// window's pixel (1, 1) in a gray image of row stride `stride`; `tests` at the same pixel in an
// image of the same stride holding 4 bytes per pixel: the vertical pair test (p and its left
// neighbour) passes for thresholds [tests[0], tests[1]) and the horizontal one (p and its upper
// neighbour) for [tests[2], tests[3]). For the size × size pixels in row-major order, vertical
// before horizontal, every threshold s of a pair's interval clipped to [s_min, s_max] adds
// min(table[p * table_stride + s], table[q * table_stride + s]) to sums_v[s] (sums_h[s]) and 1 to
// counts_v[s] (counts_h[s]). Each sums[s] receives its terms in pixel order, so the result is bit
// for bit that of a scalar loop. The four arrays must be 32-byte aligned and zero on
// [s_min & ~3, s_max + 7]; table rows must be readable from (s_min & ~3) to s_max + 7.
void WeberWindowSums(const double* table, int table_stride, const uint8_t* value,
                     const uint8_t* tests, int stride, int size, int s_min, int s_max,
                     double* sums_v, double* sums_h, double* counts_v, double* counts_h);

// The terms of WeberWindowSums() summed in any order and computed another way, for an
// approximate C(s) that is cheap to get. For the pairs of the rows × cols pixels from `value` /
// `tests` (layout as in WeberWindowSums()), adds 128 + min(W(s, p), W(s, q)) at every threshold s
// of the pair's interval to acc[s], W(s, v) =
// |s − v| / max(s, v) computed as 1 − min(v/s, s/v). `paper`: every interval is [min(p, q),
// max(p, q)) (the paper variant), which allows a shorter formula. Thresholds in [clip_lo, clip_hi]
// always receive exactly their terms; others may receive some (unspecified), and any element of
// acc with index < 264 may be written. Summed over a window, floor(sum / 128) is the
// count of pairs exactly (each term is 128 plus a value in [0, 1] within a few roundings, a window
// has at most 72 < 128 pairs, and rounding is monotone) and sum − 128 · count their Weber sum to
// within 1e-10 (each term within 4 roundings of values <= 129, each of the <= 80 additions one
// rounding of a value below 2^14). 0 <= clip_lo <= clip_hi <= 256; acc 32-byte aligned.
constexpr int kPackedStride = 264;
void AddPackedPairs(const uint8_t* value, const uint8_t* tests, int stride, int rows, int cols,
                    bool paper, int clip_lo, int clip_hi, double* acc);
// Several AddPackedPairs() calls in one (a window's blocks): block b covers the pixels from
// value + (row · stride + col) (tests likewise); with zero_first, its acc is zeroed on (at least)
// [clip_lo & ~3, clip_hi + 8), before any block is added.
struct PackedBlock {
  int row, col, rows, cols;
  int clip_lo, clip_hi;
  bool zero_first;
  double* acc;
};
void AddPackedBlocks(const uint8_t* value, const uint8_t* tests, int stride, bool paper,
                     const PackedBlock* blocks, int n_blocks);

// The approximate C(s) of packed sums (see AddPackedPairs()) and where its maximum is: for s in
// [s_min, s_max], sum = Σ_m parts[m][s] (m < n_parts, added in order), count = floor(sum / 128)
// and contrast[s] = (sum − 128 · count) / count, or −1 when count is 0. Returns the largest
// contrast and, when it is >= 0, the number of thresholds in [s_min, s_max] whose contrast is >=
// that maximum − tie_width and the first of them. parts must be 32-byte aligned and hold finite
// values on [s_min & ~3, s_max | 3]; contrast is written on that range.
struct PackedMaximum {
  double best = -1.0;
  int near = 0;
  int first = 0;
};
PackedMaximum PackedContrasts(const double* const* parts, int n_parts, int s_min, int s_max,
                              double tie_width, double* contrast);
// PackedContrasts() of parts[0..n_parts) and a strip that is completed first: strip[s] +=
// Σ_m adds[m][s] (m < n_add, in order) on [strip_lo & ~3, strip_hi | 3], which must contain
// [s_min, s_max]; the strip is then the last part of each sum (1 <= n_parts <= 7). One pass where
// completing the strip and PackedContrasts() would take two.
PackedMaximum PackedContrastsWithStrip(const double* const* parts, int n_parts, double* strip,
                                       const double* const* adds, int n_add, int strip_lo,
                                       int strip_hi, int s_min, int s_max, double tie_width,
                                       double* contrast);

// The ifsttar variant's strong-pair flags of one row (metrics/visible_edges.cc, WeakPairTest::
// StrongInterval()): for c in [1, n), strong[c] = 1 when the vertical pair (row[c], row[c − 1]) over
// the thresholds [max(tests[4c], 1), tests[4c + 1] − 1] or the horizontal pair (row[c], up[c]) over
// [max(tests[4c + 2], 1), tests[4c + 3] − 1] may have a Weber term above τ, else 0. k and k_ratio
// (<= 256) are WeakPairTest's integer thresholds: 1 − √(lo/hi) may exceed τ only when lo · 256 <
// hi · k, 1 − lo/hi only when lo · 256 < hi · k_ratio. Integers: every copy gives the same flags.
void IfsttarStrongRow(const uint8_t* tests, const uint8_t* row, const uint8_t* up, int n, int k,
                      int k_ratio, uint8_t* strong);

// The pixels a visible window marks (metrics/visible_edges.cc, VisibleEdgeMask8): `tests` is the
// window's first pair pixel in the band's layout ({vertical first, vertical end, horizontal first,
// horizontal end} per pixel, `stride` pixels per row, 6 rows of 6 pixels, 32 bytes readable from
// each row's start). A pair is separated when first <= s0 < end; bit k of rows[nn] (nn < 7, k < 7)
// is set for column k of the window's row nn when a separated pair touches it (a vertical pair
// marks its pixel and the left one, a horizontal pair its pixel and the upper one). rows[] is
// OR-ed into. Integers: every copy gives the same bits.
void SeparatedPairRows(const uint8_t* tests, int stride, int s0, unsigned* rows);

// Octave's rgb2gray of n 8-bit BGR pixels (metrics/visible_edges.h, OctaveRgbToGray) in integer
// arithmetic: min((298936 R + 587043 G + 114021 B + 500000) / 1000000, 255). Equal to Octave's
// double formula for all 2^24 colours (no colour falls within rounding of a half; tested over all).
void OctaveGrayU8(const uint8_t* bgr, int n, uint8_t* gray);

// The tables of OpenCV's 8-bit BGR → Lab (metrics/opencv_lab.h).
struct Lab8Tables {
  int32_t gamma[256];  // sRGB gamma of v / 255, × 255·8, rounded (0..2040)
  int32_t matrix[9];   // X, Y, Z rows × B, G, R columns: sRGB→XYZ / D65 white × 4096, rounded
  int32_t cbrt[3072];  // CIE f(i / 2040) × 2^15, rounded; index = a rounded X, Y or Z (<= 2041)
  // gamma[v] · matrix column c for source byte c and value v: the {X, Y, Z, 0} terms. The B terms
  // include the 2^11 that rounds the sums: X = (xyz[0][b][0] + xyz[1][g][0] + xyz[2][r][0]) >> 12.
  alignas(16) int32_t xyz[3][256][4];
};

// n BGR pixels (3 bytes each) → 3·n bytes L, a, b with the tables (OpenCV's RGB2Lab_b
// arithmetic; integers, so every copy gives the same bytes).
void BgrToLab8(const uint8_t* bgr, int n, const Lab8Tables& tables, uint8_t* lab);

// UCIQE's saturation (metrics/uciqe.cc) of n 8-bit Lab pixels (L, a, b interleaved):
// saturation[k] = chr / √(chr² + l²) and chr[k] = chr, chr = chroma[a · 256 + b], l = L / 255,
// rounded as written (no FMA contraction), so every copy gives the reference's doubles.
void UciqeSaturation(const uint8_t* lab, int n, const double* chroma, double* saturation,
                     double* chr);
// UCIQE's chroma spread terms: out[k] = |1 − q²|, q = mean / chroma[a · 256 + b], as written.
void UciqeSpread(const uint8_t* lab, int n, const double* chroma, double mean, double* out);

}  // namespace turbid::simd
