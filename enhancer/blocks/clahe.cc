#include "enhancer/blocks/clahe.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "core/error.h"
#include "core/row_kernel.h"
#include "enhancer/blocks/clahe_luminance.h"
#include "enhancer/simd_switch.h"
#include "enhancer/simd_vec.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace turbid {
namespace {

using clahe_internal::LuminanceRatioRowInPlace;
using clahe_internal::LuminanceRow;

// MATLAB round: half away from zero.
double MatlabRound(double v) { return std::round(v); }

// MATLAB padarray 'symmetric' index for padded coordinate i (may be negative or >= n).
int SymmetricIndex(int i, int n) {
  const int period = 2 * n;
  int m = i % period;
  if (m < 0) m += period;
  return m < n ? m : period - 1 - m;
}

struct Padding {
  int tile_h = 0, tile_w = 0;  // tile size in the padded image (even)
  int pre_y = 0, pre_x = 0;    // rows / columns added before the image
  int padded_h = 0, padded_w = 0;
};

// adapthisteq's parseInputs: pad when the size is not divisible by the tile count or the tile
// size is odd (so tile centres fall between pixels), half before and half after.
int PadAmount(int n, int tiles, int* tile_dim) {
  int pad = 0;
  int dim = n / tiles;
  if (n % tiles != 0) {
    dim = n / tiles + 1;
    pad = dim * tiles - n;
  }
  if (dim % 2 != 0) pad += tiles, dim += 1;
  *tile_dim = dim;
  return pad;
}

Padding ComputePadding(const ClaheOptions& o, int rows, int cols) {
  Padding p;
  const int pad_y = PadAmount(rows, o.tiles_y, &p.tile_h);
  const int pad_x = PadAmount(cols, o.tiles_x, &p.tile_w);
  p.pre_y = pad_y / 2;
  p.pre_x = pad_x / 2;
  p.padded_h = rows + pad_y;
  p.padded_w = cols + pad_x;
  return p;
}

// Row kernels (TURBID_ROW_KERNEL): whole rows of contiguous values, so the loops vectorise.

// imhist bins on [0,1] data: round(v * (bins - 1)), v clamped. Returns false when the row holds a
// non-finite value (so the check costs no separate pass). The clamp sends NaN to 0, as the AVX2
// copy's max_ps does, so that the float-to-int conversion is defined for every input (UBSan).
template <typename Index>
bool BinRowScalar(const float* g, Index* o, int n, float scale) {
  bool ok = true;
  for (int x = 0; x < n; ++x) {
    ok = ok && std::isfinite(g[x]);
    const float c = std::min(std::max(0.0f, g[x]), 1.0f);
    o[x] = static_cast<Index>(static_cast<int>(c * scale + 0.5f));
  }
  return ok;
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// AVX2 version of BinRowScalar for 8-bit indices (GCC does not vectorise the clamp followed by the
// conversion under the default -ftrapping-math). Same operations in the same order: clamp,
// multiply, add 0.5, truncate; bit-identical to the scalar loop.
__attribute__((target("avx2"))) bool BinRowAvx2(const float* g, uint8_t* o, int n, float scale) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 vscale = _mm256_set1_ps(scale), half = _mm256_set1_ps(0.5f);
  const __m256i exp_mask = _mm256_set1_epi32(0x7f800000);
  __m256i bad = _mm256_setzero_si256();
  int x = 0;
  for (; x + 32 <= n; x += 32) {
    __m256i q[4];
    for (int k = 0; k < 4; ++k) {
      const __m256 v = _mm256_loadu_ps(g + x + 8 * k);
      const __m256i e = _mm256_and_si256(_mm256_castps_si256(v), exp_mask);
      bad = _mm256_or_si256(bad, _mm256_cmpeq_epi32(e, exp_mask));
      const __m256 c = _mm256_min_ps(_mm256_max_ps(v, zero), one);
      q[k] = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(c, vscale), half));
    }
    // Pack 32 int32 (each <= 255) to bytes; the packs work per 128-bit lane, so reorder after.
    const __m256i w01 = _mm256_packus_epi32(q[0], q[1]);
    const __m256i w23 = _mm256_packus_epi32(q[2], q[3]);
    const __m256i b = _mm256_packus_epi16(w01, w23);
    const __m256i ordered =
        _mm256_permutevar8x32_epi32(b, _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(o + x), ordered);
  }
  const bool ok = _mm256_testz_si256(bad, bad) != 0;
  return BinRowScalar(g + x, o + x, n - x, scale) && ok;
}

bool BinRow(const float* g, uint8_t* o, int n, float scale) {
  return enhancer_internal::UseHandWrittenAvx2() ? BinRowAvx2(g, o, n, scale)
                                                 : BinRowScalar(g, o, n, scale);
}
#else
bool BinRow(const float* g, uint8_t* o, int n, float scale) { return BinRowScalar(g, o, n, scale); }
#endif
bool BinRow(const float* g, uint16_t* o, int n, float scale) {
  return BinRowScalar(g, o, n, scale);
}

void ValidateGray(const cv::Mat& image) {
  if (image.empty()) throw Error("clahe: empty image");
  if (image.type() != CV_32FC1) throw Error("clahe: expected a float32 one-channel image");
}

// Bin index per pixel: CV_8U when bins <= 256, else CV_16U. Throws for non-finite values.
cv::Mat BinIndices(const cv::Mat& gray, int bins) {
  const bool narrow = bins <= 256;
  cv::Mat idx(gray.size(), narrow ? CV_8U : CV_16U);
  const float scale = static_cast<float>(bins - 1);
  bool ok = true;
  for (int y = 0; y < gray.rows; ++y) {
    const float* g = gray.ptr<float>(y);
    ok &= narrow ? BinRow(g, idx.ptr<uint8_t>(y), gray.cols, scale)
                 : BinRow(g, idx.ptr<uint16_t>(y), gray.cols, scale);
  }
  if (!ok) throw Error("clahe: image has non-finite values");
  return idx;
}

// Tile mappings (tiles_y * tiles_x rows of `bins` floats) from bin indices of the unpadded image.
// The target's quantile at cumulative fraction `frac` in [0, 1] (adapthisteq's makeMapping), with
// the per-tile constants computed once.
struct TargetQuantile {
  ClaheDistribution distribution;
  double alpha, hconst, rayleigh_vmax, exponential_vmax;
  TargetQuantile(ClaheDistribution d, double a)
      : distribution(d),
        alpha(a),
        hconst(2.0 * a * a),
        rayleigh_vmax(1.0 - std::exp(-1.0 / (2.0 * a * a))),
        exponential_vmax(1.0 - std::exp(-a)) {}
  double operator()(double frac) const {
    const double one_minus_eps = 1.0 - std::numeric_limits<double>::epsilon();
    switch (distribution) {
      case ClaheDistribution::kUniform:
        return std::min(frac, 1.0);
      case ClaheDistribution::kRayleigh: {
        double val = rayleigh_vmax * frac;
        if (val >= 1.0) val = one_minus_eps;
        return std::min(std::sqrt(-hconst * std::log(1.0 - val)), 1.0);
      }
      case ClaheDistribution::kExponential: {
        double val = exponential_vmax * frac;
        if (val >= 1.0) val = one_minus_eps;
        return std::min(-1.0 / alpha * std::log(1.0 - val), 1.0);
      }
    }
    return frac;
  }
};

// adapthisteq's clipHistogram, in place (see ClaheMapHistogram).
void ClipHistogram(const ClaheOptions& o, std::vector<int>& hist, int pixels);
// makeMapping: the clipped histogram's cumulative fractions shaped by `target`.
// `memo` (or null): pixels + 1 floats, -1 where not yet known, shared by the tiles of one image
// (one target): each cumulative count's quantile is computed once (a tile's sums take at most
// pixels + 1 values, and the tiles of small images share many).
std::vector<float> ShapeMapping(const TargetQuantile& target, const std::vector<int>& clipped,
                                int pixels, std::vector<float>* memo = nullptr) {
  std::vector<float> map(clipped.size());
  long long sum = 0;
  const double inv = 1.0 / pixels;
  for (size_t b = 0; b < clipped.size(); ++b) {
    sum += clipped[b];
    if (memo != nullptr && sum <= pixels) {  // the quantiles are >= 0 (-0 at most): -1 is unset
      float& q = (*memo)[static_cast<size_t>(sum)];
      if (q < -0.5f) q = static_cast<float>(target(sum * inv));
      map[b] = q;
    } else {
      map[b] = static_cast<float>(target(sum * inv));
    }
  }
  return map;
}

// keep_mean: the pixels' cumulative fractions on a grid of kMeanGrid steps (pixel counts per grid
// point), so the mapped mean for a candidate alpha costs kMeanGrid + 1 quantiles, not one per
// tile and bin. Quantising the fraction to 1/4096 moves the mean by < 1e-3.
constexpr int kMeanGrid = 4096;
double GridMean(const TargetQuantile& target, const std::vector<double>& weight, double total) {
  double acc = 0.0;
  for (int k = 0; k <= kMeanGrid; ++k) {
    if (weight[k] != 0.0) acc += weight[k] * target(static_cast<double>(k) / kMeanGrid);
  }
  return acc / total;
}

// The alpha (bisection on log alpha in [1e-3, 1e3]) whose mapped mean is `mean`: the truncated
// Rayleigh target grows stochastically with alpha, the truncated exponential shrinks.
double AlphaForMappedMean(ClaheDistribution d, const std::vector<double>& weight, double total,
                          double mean) {
  double lo = std::log(1e-3), hi = std::log(1e3);
  const bool rising = d == ClaheDistribution::kRayleigh;
  for (int i = 0; i < 48; ++i) {
    const double mid = 0.5 * (lo + hi);
    const double got = GridMean(TargetQuantile(d, std::exp(mid)), weight, total);
    if ((got < mean) == rising) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return std::exp(0.5 * (lo + hi));
}

// Each tile's histogram is counted into eight interleaved sub-histograms (consecutive pixels
// often share a bin; separate counters keep the increments of one counter eight pixels apart,
// so their store-to-load chains overlap), then summed into hist. sub: kTileSubHistograms * bins
// ints of scratch; row_src / col_src: the padded rows' and columns' source indices.
constexpr int kTileSubHistograms = 8;

template <typename Index>
void TileHistogram(const cv::Mat& idx, const Padding& p, const std::vector<int>& row_src,
                   const std::vector<int>& col_src, int tx, int ty, std::vector<int>& sub,
                   std::vector<int>& hist) {
  constexpr int kSub = kTileSubHistograms;
  constexpr int kAhead = 4;  // rows
  const int bins = static_cast<int>(hist.size());
  // One tile at a time: its kSub sub-histograms stay in L1 (the tile's rows are read from
  // the bin image, a few KiB each).
  std::fill(sub.begin(), sub.end(), 0);
  int* h[kSub];
  for (int j = 0; j < kSub; ++j) h[j] = sub.data() + static_cast<size_t>(j) * bins;
  const int x0 = tx * p.tile_w, x_end = x0 + p.tile_w;
  // Columns inside the image are a contiguous run; only padded columns need the table.
  const int in_lo = std::max(x0, p.pre_x), in_hi = std::min(x_end, p.pre_x + idx.cols);
  const int n = std::max(in_hi - in_lo, 0);
  const int y_end = (ty + 1) * p.tile_h;
  for (int y = ty * p.tile_h; y < y_end; ++y) {
    const Index* row = idx.ptr<Index>(row_src[y]);
    if (y + kAhead < y_end && n > 0) {  // the tile's rows are strided: fetch a few ahead
      const char* ahead =
          reinterpret_cast<const char*>(idx.ptr<Index>(row_src[y + kAhead]) + (in_lo - p.pre_x));
      for (int b = 0; b < n * static_cast<int>(sizeof(Index)); b += 64) {
        __builtin_prefetch(ahead + b, 0, 3);
      }
      __builtin_prefetch(ahead + n * sizeof(Index) - 1, 0, 3);
    }
    int x = x0;
    for (; x < in_lo; ++x) ++h[0][row[col_src[x]]];
    const Index* run = row + (in_lo - p.pre_x);
    int k = 0;
    if constexpr (sizeof(Index) == 1) {
      // Eight 8-bit indices per load, taken apart by shifts, each to its own sub-histogram
      // (which one a pixel goes to does not matter: they are summed).
      for (; k + 8 <= n; k += 8) {
        uint64_t v;
        std::memcpy(&v, run + k, sizeof(v));
        for (int j = 0; j < 8; ++j) ++h[j][(v >> (8 * j)) & 0xff];
      }
    }
    for (; k + 8 <= n; k += 8) {
      for (int j = 0; j < 8; ++j) ++h[j][run[k + j]];
    }
    for (; k < n; ++k) ++h[0][run[k]];
    for (x = std::max(in_hi, in_lo); x < x_end; ++x) ++h[0][row[col_src[x]]];
  }
  for (int b = 0; b < bins; ++b) {
    int c = 0;
    for (int j = 0; j < kSub; ++j) c += h[j][b];
    hist[b] = c;
  }
}

// sum_b counts[b] * (weights ? weights[b] : b) in double, in four partial sums (one running sum
// was kept in memory by the compiler, each bin waiting on the last one's store; issue 29 item 6
// lets the order of the sum change).
double WeightedSum(const int* counts, const float* weights, int bins) {
  double acc[4] = {0.0, 0.0, 0.0, 0.0};
  int b = 0;
  for (; b + 4 <= bins; b += 4) {
    for (int j = 0; j < 4; ++j) {
      const double w = weights != nullptr ? weights[b + j] : static_cast<double>(b + j);
      acc[j] += static_cast<double>(counts[b + j]) * w;
    }
  }
  for (; b < bins; ++b) {
    acc[0] += static_cast<double>(counts[b]) * (weights != nullptr ? weights[b] : b);
  }
  return (acc[0] + acc[1]) + (acc[2] + acc[3]);
}

// The tiles' mappings (one row of bins per tile, tiles in row order); keep_mean chooses alpha
// from all tiles' clipped histograms first.
template <typename Index>
cv::Mat MappingsT(const ClaheOptions& o, const cv::Mat& idx, const Padding& p, ClaheStats* stats) {
  cv::Mat maps(o.tiles_y * o.tiles_x, o.bins, CV_32F);
  std::vector<int> row_src(p.padded_h), col_src(p.padded_w);
  for (int y = 0; y < p.padded_h; ++y) row_src[y] = SymmetricIndex(y - p.pre_y, idx.rows);
  for (int x = 0; x < p.padded_w; ++x) col_src[x] = SymmetricIndex(x - p.pre_x, idx.cols);
  const int pixels = p.tile_h * p.tile_w;
  const int bins = o.bins;
  std::vector<int> sub(static_cast<size_t>(kTileSubHistograms) * bins);
  std::vector<int> hist(bins);
  // keep_mean: the clipped histograms wait for alpha; the pixel counts go onto the fraction grid.
  const bool match = o.keep_mean && o.distribution != ClaheDistribution::kUniform;
  std::vector<int> clipped;
  std::vector<double> weight(match ? kMeanGrid + 1 : 0);
  if (match) clipped.resize(static_cast<size_t>(o.tiles_y) * o.tiles_x * bins);
  const TargetQuantile fixed(o.distribution, o.alpha);
  // Quantiles by cumulative count, computed once each, where there are fewer counts than the
  // tiles' bins (small tiles: 80 x 60 pixels at 640 x 480 against 64 tiles of 256 bins).
  std::vector<float> memo;
  if (!match && static_cast<double>(pixels) < static_cast<double>(o.tiles_x) * o.tiles_y * bins) {
    memo.assign(static_cast<size_t>(pixels) + 1, -1.0f);
  }
  // The means of ClaheStats (and keep_mean's target) only where asked for (WeightedSum per tile).
  const bool want_means = match || stats != nullptr;
  double bin_sum = 0.0, mapped_sum = 0.0;
  for (int ty = 0; ty < o.tiles_y; ++ty) {
    for (int tx = 0; tx < o.tiles_x; ++tx) {
      TileHistogram<Index>(idx, p, row_src, col_src, tx, ty, sub, hist);
      if (want_means) bin_sum += WeightedSum(hist.data(), nullptr, bins);
      if (!match) {
        std::vector<int> counts;
        if (want_means) counts = hist;
        ClipHistogram(o, hist, pixels);
        const std::vector<float> m =
            ShapeMapping(fixed, hist, pixels, memo.empty() ? nullptr : &memo);
        if (want_means) mapped_sum += WeightedSum(counts.data(), m.data(), bins);
        std::copy(m.begin(), m.end(), maps.ptr<float>(ty * o.tiles_x + tx));
        continue;
      }
      int* c = clipped.data() + static_cast<size_t>(ty * o.tiles_x + tx) * bins;
      std::copy(hist.begin(), hist.end(), c);
      std::vector<int> tile(c, c + bins);
      ClipHistogram(o, tile, pixels);
      long long sum = 0;
      for (int b = 0; b < bins; ++b) {
        sum += tile[b];
        const int k = static_cast<int>(std::lround(static_cast<double>(sum) * kMeanGrid / pixels));
        weight[std::min(k, kMeanGrid)] += hist[b];
        c[b] = tile[b];
      }
    }
  }
  const double total = static_cast<double>(pixels) * o.tiles_x * o.tiles_y;
  ClaheStats st;
  st.input_mean = bin_sum / (static_cast<double>(bins - 1) * total);
  st.alpha = o.distribution == ClaheDistribution::kUniform ? 0.0 : o.alpha;
  if (match) {
    st.target_mean = std::max(st.input_mean, o.min_mean);
    st.alpha = AlphaForMappedMean(o.distribution, weight, total, st.target_mean);
    const TargetQuantile chosen(o.distribution, st.alpha);
    for (int t = 0; t < o.tiles_x * o.tiles_y; ++t) {
      const int* c = clipped.data() + static_cast<size_t>(t) * bins;
      const std::vector<float> m = ShapeMapping(chosen, std::vector<int>(c, c + bins), pixels);
      std::copy(m.begin(), m.end(), maps.ptr<float>(t));
    }
    st.mapped_mean = GridMean(chosen, weight, total);
  } else {
    st.mapped_mean = mapped_sum / total;
  }
  if (stats) *stats = st;
  return maps;
}

cv::Mat Mappings(const ClaheOptions& o, const cv::Mat& idx, const Padding& p,
                 ClaheStats* stats = nullptr) {
  return idx.depth() == CV_8U ? MappingsT<uint8_t>(o, idx, p, stats)
                              : MappingsT<uint16_t>(o, idx, p, stats);
}

// Per output coordinate: the two neighbouring tiles and the weight of the second (adapthisteq's
// makeClaheImage: bilinear between tile centres; the outer half tiles use the nearest tile).
struct Interp {
  std::vector<int> lo, hi;
  std::vector<float> w;
};
Interp Interpolation(int n, int pre, int tile, int tiles) {
  Interp in;
  in.lo.resize(n), in.hi.resize(n), in.w.resize(n);
  for (int i = 0; i < n; ++i) {
    const double t = (static_cast<double>(i + pre) - tile / 2) / tile;
    const int f = static_cast<int>(std::floor(t));
    if (f < 0) {
      in.lo[i] = in.hi[i] = 0, in.w[i] = 0.0f;
    } else if (f >= tiles - 1) {
      in.lo[i] = in.hi[i] = tiles - 1, in.w[i] = 0.0f;
    } else {
      in.lo[i] = f, in.hi[i] = f + 1, in.w[i] = static_cast<float>(t - f);
    }
  }
  return in;
}

// Row LUT: the mappings of tile row `up` blended towards tile row `dn` by wy, all tile columns
// (tiles * bins values), into `blend`; then, per tile column j and bin b, the pair
// (value of j, value of j+1 minus value of j) at pairs[2 (j bins + b)], so a pixel reads both
// halves of its horizontal interpolation with one 8-byte load. The last tile column's difference
// is taken against zeros (its pixels have weight 0 towards the right).
TURBID_ROW_KERNEL void BlendRows(const float* __restrict up, const float* __restrict dn, float wy,
                                 float* __restrict blend, int n) {
  for (int i = 0; i < n; ++i) blend[i] = up[i] + wy * (dn[i] - up[i]);
}

TURBID_ROW_KERNEL void PairRows(const float* __restrict blend, int n, int bins,
                                float* __restrict pairs) {
  for (int i = 0; i < n - bins; ++i) {
    pairs[2 * i] = blend[i];
    pairs[2 * i + 1] = blend[i + bins] - blend[i];
  }
  for (int i = std::max(n - bins, 0); i < n; ++i) {
    pairs[2 * i] = blend[i];
    pairs[2 * i + 1] = 0.0f - blend[i];
  }
}

// One output row from the pair LUT: for pixel x, left + wx * (right - left) with (left, right -
// left) at pairs[2 (lo[x] + b[x])] (wx is 0 where both neighbours are the same tile).
template <typename Index>
TURBID_ROW_KERNEL void InterpolateRow(const float* __restrict pairs, const Index* __restrict b,
                                      const int* __restrict lo, const float* __restrict wx,
                                      float* __restrict dst, int n) {
  for (int x = 0; x < n; ++x) {
    const float* p = pairs + 2 * (lo[x] + b[x]);
    // Blends of values in [0,1] stay there up to rounding; the clamp makes it exact.
    dst[x] = std::min(std::max(p[0] + wx[x] * p[1], 0.0f), 1.0f);
  }
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// AVX2 version of InterpolateRow for 8-bit indices: the eight (left, diff) pairs of 8 pixels are
// read with 8-byte loads (on this project's AMD Zen 3 machine these beat vgatherdpd by ~0.5 ms per
// 1360x1024 image; GCC builds the plain loop's loads from single floats and inserts) and
// de-interleaved with one shuffle each. Same operations in the same order (no FMA), so
// bit-identical to the portable loop.
__attribute__((target("avx2"))) void InterpolateRowAvx2(const float* pairs, const uint8_t* b,
                                                        const int* lo, const float* wx, float* dst,
                                                        int n) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const double* base = reinterpret_cast<const double*>(pairs);  // one pair per double
  int x = 0;
  for (; x + 8 <= n; x += 8) {
    const double* q[8];
    for (int k = 0; k < 8; ++k) q[k] = base + lo[x + k] + b[x + k];
    // Floats l0 d0 l1 d1 | l4 d4 l5 d5 and l2 d2 l3 d3 | l6 d6 l7 d7: the even-float shuffle of
    // the two (per 128-bit half) is l0..l7 in order, the odd-float one d0..d7.
    const __m256d p0145 =
        _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadh_pd(_mm_load_sd(q[0]), q[1])),
                             _mm_loadh_pd(_mm_load_sd(q[4]), q[5]), 1);
    const __m256d p2367 =
        _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadh_pd(_mm_load_sd(q[2]), q[3])),
                             _mm_loadh_pd(_mm_load_sd(q[6]), q[7]), 1);
    const __m256 a = _mm256_castpd_ps(p0145), c = _mm256_castpd_ps(p2367);
    const __m256 left = _mm256_shuffle_ps(a, c, _MM_SHUFFLE(2, 0, 2, 0));
    const __m256 diff = _mm256_shuffle_ps(a, c, _MM_SHUFFLE(3, 1, 3, 1));
    const __m256 v = _mm256_add_ps(left, _mm256_mul_ps(_mm256_loadu_ps(wx + x), diff));
    // Operand order as std::min / std::max take theirs (so -0 and NaN come out the same).
    _mm256_storeu_ps(dst + x, _mm256_min_ps(one, _mm256_max_ps(zero, v)));
  }
  InterpolateRow(pairs, b + x, lo + x, wx + x, dst + x, n - x);
}

// BlendRows then PairRows in one pass at 8 and 16 lanes (clahe_blend_pairs.inc, written once
// over the width; the same bits at both, and as the portable loops). Target attributes without
// FMA: the blend's product and sum stay two roundings.
#define TURBID_VEC_NO_CONTRACT
#define TURBID_VEC_BODY "enhancer/blocks/clahe_blend_pairs.inc"
#include "enhancer/simd_widths.inc"  // NOLINT(build/include): the body at 8 and 16 lanes
void BlendPairRowsAvx2(const float* up, const float* dn, float wy, int n, int bins, float* pairs) {
  if (KernelCpuLevel() >= CpuLevel::kAvx512) {
    vec16::BlendPairRows(up, dn, wy, n, bins, pairs);
  } else {
    vec8::BlendPairRows(up, dn, wy, n, bins, pairs);
  }
}
#define TURBID_HAVE_BLEND_PAIRS_AVX2 1

void Interpolate(const float* pairs, const uint8_t* b, const int* lo, const float* wx, float* dst,
                 int n) {
  if (enhancer_internal::UseHandWrittenAvx2()) {
    InterpolateRowAvx2(pairs, b, lo, wx, dst, n);
  } else {
    InterpolateRow(pairs, b, lo, wx, dst, n);
  }
}
#else
void Interpolate(const float* pairs, const uint8_t* b, const int* lo, const float* wx, float* dst,
                 int n) {
  InterpolateRow(pairs, b, lo, wx, dst, n);
}
#endif
void Interpolate(const float* pairs, const uint16_t* b, const int* lo, const float* wx, float* dst,
                 int n) {
  InterpolateRow(pairs, b, lo, wx, dst, n);
}

// The equalised rows: row(y) gives where row y goes (idx.cols floats), then done(y, dst) runs.
template <typename Index, typename RowFn, typename DoneFn>
void ClaheRowsT(const ClaheOptions& o, const cv::Mat& idx, const Padding& p, ClaheStats* stats,
                RowFn&& row, DoneFn&& done) {
  const cv::Mat maps = Mappings(o, idx, p, stats);
  const Interp iy = Interpolation(idx.rows, p.pre_y, p.tile_h, o.tiles_y);
  const Interp ix = Interpolation(idx.cols, p.pre_x, p.tile_w, o.tiles_x);
  const int bins = o.bins;
  const int row_len = o.tiles_x * bins;
  std::vector<int> lo(idx.cols);
  std::vector<float> wx(idx.cols);
  for (int x = 0; x < idx.cols; ++x) {
    lo[x] = ix.lo[x] * bins;
    wx[x] = ix.w[x];
  }
  // The pair LUT 64-byte aligned: the 16-lane blend's stores do not split cache lines.
  std::vector<float> blend(row_len), pairs_buffer(2 * static_cast<size_t>(row_len) + 16);
  float* const pairs =
      pairs_buffer.data() +
      (16 - reinterpret_cast<uintptr_t>(pairs_buffer.data()) / sizeof(float) % 16) % 16;
  const float* m = maps.ptr<float>(0);
  int lut_lo = -1, lut_hi = -1;
  float lut_w = -1.0f;
  for (int y = 0; y < idx.rows; ++y) {
    // Rows in the outer half tiles (and, per tile row, repeated weights) reuse the LUT.
    if (iy.lo[y] != lut_lo || iy.hi[y] != lut_hi || iy.w[y] != lut_w) {
      lut_lo = iy.lo[y], lut_hi = iy.hi[y], lut_w = iy.w[y];
      const float* up = m + static_cast<size_t>(lut_lo) * row_len;
      const float* dn = m + static_cast<size_t>(lut_hi) * row_len;
#ifdef TURBID_HAVE_BLEND_PAIRS_AVX2
      if (enhancer_internal::UseHandWrittenAvx2()) {
        BlendPairRowsAvx2(up, dn, lut_w, row_len, bins, pairs);
      } else
#endif
      {
        BlendRows(up, dn, lut_w, blend.data(), row_len);
        PairRows(blend.data(), row_len, bins, pairs);
      }
    }
    float* dst = row(y);
    Interpolate(pairs, idx.ptr<Index>(y), lo.data(), wx.data(), dst, idx.cols);
    done(y, dst);
  }
}

template <typename Index>
cv::Mat ClaheGrayT(const ClaheOptions& o, const cv::Mat& idx, const Padding& p, ClaheStats* stats) {
  cv::Mat out(idx.size(), CV_32F);
  ClaheRowsT<Index>(
      o, idx, p, stats, [&out](int y) { return out.ptr<float>(y); }, [](int, const float*) {});
  return out;
}

// Colour CLAHE from the luminance bins, in place over `image` (the values the luminance came
// from): each row's equalised luminance, then the ratio.
template <typename Index>
void ClaheColorInPlaceT(const ClaheOptions& o, const cv::Mat& idx, cv::Mat& image,
                        ClaheStats* stats, const std::function<void(float*, int)>& after_row) {
  const Padding p = ComputePadding(o, idx.rows, idx.cols);
  std::vector<float> eq(idx.cols), lum(idx.cols);
  ClaheRowsT<Index>(
      o, idx, p, stats, [&eq](int) { return eq.data(); },
      [&](int y, const float* e) {
        const float* next = y + 1 < image.rows ? image.ptr<float>(y + 1) : nullptr;
        LuminanceRatioRowInPlace(image.ptr<float>(y), e, idx.cols, lum.data(), next, o.rgb);
        if (after_row) after_row(image.ptr<float>(y), y);
      });
}

cv::Mat ClaheFromIndices(const ClaheOptions& o, const cv::Mat& idx, ClaheStats* stats) {
  const Padding p = ComputePadding(o, idx.rows, idx.cols);
  return idx.depth() == CV_8U ? ClaheGrayT<uint8_t>(o, idx, p, stats)
                              : ClaheGrayT<uint16_t>(o, idx, p, stats);
}

cv::Mat ClaheGray(const ClaheOptions& o, const cv::Mat& gray, ClaheStats* stats) {
  return ClaheFromIndices(o, BinIndices(gray, o.bins), stats);
}

}  // namespace

namespace {
void ClipHistogram(const ClaheOptions& o, std::vector<int>& hist, int pixels) {
  const int bins = static_cast<int>(hist.size());
  // adapthisteq: clip limit from the normalised value.
  const int min_clip = static_cast<int>(std::ceil(static_cast<double>(pixels) / bins));
  const int clip = min_clip + static_cast<int>(MatlabRound(o.clip_limit * (pixels - min_clip)));
  // clipHistogram: clip, give every bin an even share of the excess, then hand out the rest one
  // count at a time with a stride that grows as fewer remain.
  long long excess = 0;
  for (int v : hist) excess += std::max(v - clip, 0);
  const int avg_incr = static_cast<int>(excess / bins);
  const int upper = clip - avg_incr;
  for (int& v : hist) {
    if (v > clip) {
      v = clip;
    } else if (v > upper) {
      excess -= clip - v;
      v = clip;
    } else {
      excess -= avg_incr;
      v += avg_incr;
    }
  }
  int k = 0;
  while (excess > 0) {
    const int step = std::max(static_cast<int>(bins / excess), 1);
    bool placed = false;
    for (int m = k; m < bins; m += step) {
      if (hist[m] < clip) {
        ++hist[m];
        --excess;
        placed = true;
        if (excess == 0) break;
      }
    }
    k = k + 1 < bins ? k + 1 : 0;
    // Every bin at the limit (only when clip * bins < pixels, which min_clip rules out) would
    // loop forever in adapthisteq; stop instead.
    if (!placed && k == 0) {
      bool any = false;
      for (int v : hist) any = any || v < clip;
      if (!any) break;
    }
  }
}
}  // namespace

std::vector<float> ClaheMapHistogram(const ClaheOptions& o, std::vector<int> hist, int pixels) {
  ClipHistogram(o, hist, pixels);
  // makeMapping: cumulative histogram shaped to the target on the full range [0, 1].
  return ShapeMapping(TargetQuantile(o.distribution, o.alpha), hist, pixels);
}

cv::Mat ClaheNewBins(const ClaheOptions& options, cv::Size size) {
  ThrowIfInvalid(options, "clahe");
  if (size.width <= 0 || size.height <= 0) throw Error("clahe: empty image");
  return cv::Mat(size, options.bins <= 256 ? CV_8U : CV_16U);
}

void ClaheBinRow(const ClaheOptions& options, const float* row, cv::Mat& bins, int y) {
  const float scale = static_cast<float>(options.bins - 1);
  const bool ok = bins.depth() == CV_8U ? BinRow(row, bins.ptr<uint8_t>(y), bins.cols, scale)
                                        : BinRow(row, bins.ptr<uint16_t>(y), bins.cols, scale);
  if (!ok) throw Error("clahe: image has non-finite values");
}

void ClaheBinColorRow(const ClaheOptions& options, const float* bgr, float* lum, cv::Mat& bins,
                      int y) {
  LuminanceRow(bgr, lum, bins.cols, options.rgb);
  ClaheBinRow(options, lum, bins, y);
}

void ClaheColorFromBins(const ClaheOptions& options, const cv::Mat& bins, cv::Mat& image,
                        ClaheStats* stats, const std::function<void(float*, int)>& after_row) {
  ThrowIfInvalid(options, "clahe");
  const int want = options.bins <= 256 ? CV_8UC1 : CV_16UC1;
  if (bins.empty() || bins.type() != want) {
    throw Error("clahe: bin image must come from ClaheNewBins with the same options");
  }
  if (image.type() != CV_32FC3 || image.size() != bins.size()) {
    throw Error("clahe: colour image must be float32 BGR of the bins' size");
  }
  if (bins.depth() == CV_8U) {
    ClaheColorInPlaceT<uint8_t>(options, bins, image, stats, after_row);
  } else {
    ClaheColorInPlaceT<uint16_t>(options, bins, image, stats, after_row);
  }
}

cv::Mat ClaheFromBins(const ClaheOptions& options, const cv::Mat& bins, ClaheStats* stats) {
  ThrowIfInvalid(options, "clahe");
  const int want = options.bins <= 256 ? CV_8UC1 : CV_16UC1;
  if (bins.empty() || bins.type() != want) {
    throw Error("clahe: bin image must come from ClaheNewBins with the same options");
  }
  return ClaheFromIndices(options, bins, stats);
}

cv::Mat ClaheTileMappings(const ClaheOptions& options, const cv::Mat& gray) {
  ThrowIfInvalid(options, "clahe");
  ValidateGray(gray);  // BinIndices throws for non-finite values
  const Padding p = ComputePadding(options, gray.rows, gray.cols);
  return Mappings(options, BinIndices(gray, options.bins), p);
}

cv::Mat Clahe(const ClaheOptions& options, const cv::Mat& image, ClaheStats* stats) {
  ThrowIfInvalid(options, "clahe");
  if (image.empty()) throw Error("clahe: empty image");
  if (image.depth() != CV_32F || (image.channels() != 1 && image.channels() != 3)) {
    throw Error("clahe: expected a float32 image with 1 or 3 channels");
  }
  if (image.channels() == 1) {
    ValidateGray(image);
    return ClaheGray(options, image, stats);
  }
  // Colour: equalise Rec. 709 luminance, scale the channels by the luminance ratio (hue kept).
  cv::Mat lum(image.size(), CV_32F);
  const int b = options.rgb ? 2 : 0, r = options.rgb ? 0 : 2;
  for (int y = 0; y < image.rows; ++y) {
    const cv::Vec3f* s = image.ptr<cv::Vec3f>(y);
    float* l = lum.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      l[x] = 0.0722f * s[x][b] + 0.7152f * s[x][1] + 0.2126f * s[x][r];
    }
  }
  // A non-finite channel makes the luminance non-finite (positive weights summing to 1, so finite
  // values never overflow): ClaheGray's binning throws the same error a separate pass would.
  const cv::Mat eq = ClaheGray(options, lum, stats);
  cv::Mat out(image.size(), CV_32FC3);
  for (int y = 0; y < image.rows; ++y) {
    const cv::Vec3f* s = image.ptr<cv::Vec3f>(y);
    const float* l = lum.ptr<float>(y);
    const float* e = eq.ptr<float>(y);
    cv::Vec3f* d = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.cols; ++x) {
      if (l[x] <= 1e-6f) {
        d[x] = cv::Vec3f(e[x], e[x], e[x]);
        continue;
      }
      const float g = e[x] / l[x];
      for (int c = 0; c < 3; ++c) d[x][c] = std::min(std::max(s[x][c] * g, 0.0f), 1.0f);
    }
  }
  return out;
}

}  // namespace turbid
