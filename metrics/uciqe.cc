// UCIQE as computed by JOU-UIP/UCIQE UCIQE.py (see uciqe.h).
//
// The per-pixel values are the reference's (same expressions, chroma from a table over the 8-bit
// (a, b) pairs filled with the same expression) and the means keep NumPy's summation order, but
// they are summed chunk by chunk as they are computed (NumPy adds chunks of 8192 elements), so no
// full-size array of them is allocated. The 8-bit Lab image is cv::cvtColor's, made by our exact
// replica of it (metrics/opencv_lab.h) chunk by chunk, so each pixel is converted, histogrammed
// and turned into chroma and saturation while it is in cache.
#include "metrics/uciqe.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "metrics/opencv_lab.h"
#include "metrics/simd_dispatch.h"
#include "metrics/visible_edges.h"
#include "core/error.h"

namespace turbid {
namespace {

constexpr double kC1 = 0.4680;  // Yang & Sowmya 2015 Eq. 4
constexpr double kC2 = 0.2745;
constexpr double kC3 = 0.2576;
constexpr int kBins = 65536;  // np.histogram(L', 65536): L' is float64, so never the uint8 path

// Bin index numpy.histogram gives `v` for `bins` equal bins over [first, last] (NumPy 1.24's
// uniform-bin path: scaled index, then a correction against the linspace edges).
int64_t NumpyBin(double v, double first, double last, int bins) {
  const double norm = bins / (last - first);
  int64_t index = static_cast<int64_t>((v - first) * norm);
  if (index == bins) --index;
  const double step = (last - first) / bins;
  auto edge = [&](int64_t i) { return i == bins ? last : static_cast<double>(i) * step + first; };
  if (v < edge(index)) --index;
  if (index != bins - 1 && v >= edge(index + 1)) ++index;
  return index;
}

// NumPy's float64 add.reduce as np.mean uses it: the output starts at the identity 0 and each
// iterator chunk of up to 8192 elements (the ufunc buffer size) is added as a pairwise sum
// (8-way unrolled below 128 elements). Reproduced because on gray images chroma is constant and
// var_chr = √(mean|1 − (mean/chr)²|) is pure rounding noise (~3e-8) of this very sum.
double NumpyPairwiseSum(const double* a, size_t n) {
  if (n < 8) {
    double r = 0.0;
    for (size_t i = 0; i < n; ++i) r += a[i];
    return r;
  }
  if (n <= 128) {
    double r[8];
    for (int j = 0; j < 8; ++j) r[j] = a[j];
    size_t i = 8;
    for (; i < n - (n % 8); i += 8) {
      for (int j = 0; j < 8; ++j) r[j] += a[i + j];
    }
    double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
    for (; i < n; ++i) res += a[i];
    return res;
  }
  size_t half = n / 2;
  half -= half % 8;
  return NumpyPairwiseSum(a, half) + NumpyPairwiseSum(a + half, n - half);
}

// np.mean of n values produced chunk by chunk: fill(begin, count, out) writes values
// [begin, begin + count) to out; the chunks are NumPy's (see NumpyPairwiseSum).
template <typename Fill>
double NumpyMeanOf(size_t n, Fill fill) {
  constexpr size_t kChunk = 8192;
  std::array<double, kChunk> buffer;
  double total = 0.0;
  for (size_t i = 0; i < n; i += kChunk) {
    const size_t count = std::min(kChunk, n - i);
    fill(i, count, buffer.data());
    total += NumpyPairwiseSum(buffer.data(), count);
  }
  return total / static_cast<double>(n);
}

// √(a² + b²) of the reference for every 8-bit (a, b) pair, a = A / 255, b = B / 255.
const std::vector<double>& ChromaTable() {
  static const std::vector<double> table = [] {
    std::vector<double> t(256 * 256);
    for (int ia = 0; ia < 256; ++ia) {
      for (int ib = 0; ib < 256; ++ib) {
        const double a = ia / 255.0;
        const double b = ib / 255.0;
        t[ia * 256 + ib] = std::sqrt(a * a + b * b);
      }
    }
    return t;
  }();
  return table;
}

// Lab pixels (0, a, b) for every (a, b), in table order.
const std::vector<uint8_t>& AllAbPairs() {
  static const std::vector<uint8_t> pixels = [] {
    std::vector<uint8_t> p(3 * 256 * 256);
    for (int ab = 0; ab < 256 * 256; ++ab) {
      p[3 * ab + 1] = static_cast<uint8_t>(ab >> 8);
      p[3 * ab + 2] = static_cast<uint8_t>(ab);
    }
    return p;
  }();
  return pixels;
}

}  // namespace

std::string UciqeVariantName(UciqeVariant /*variant*/) { return "jou-uip-compat"; }

UciqeVariant ParseUciqeVariant(const std::string& name) {
  if (name == "jou-uip-compat") return UciqeVariant::kJouUipCompat;
  throw Error("uciqe: unknown variant '" + name + "' (expected jou-uip-compat)");
}

bool UciqeOptions::Check(std::string* why) const {
  if (variant != UciqeVariant::kJouUipCompat) {
    if (why) *why = "variant: unknown value";
    return false;
  }
  return true;
}

nlohmann::json UciqeResult::ToJson() const {
  return {{"variant", variant},
          {"uciqe", uciqe},
          {"chroma_spread", chroma_spread},
          {"luminance_contrast", luminance_contrast},
          {"mean_saturation", mean_saturation}};
}

UciqeResult Uciqe(const UciqeOptions& options, const cv::Mat& image) {
  ThrowIfInvalid(options, "uciqe");
  cv::Mat bgr = ToEightBit(image, "uciqe");
  if (!bgr.isContinuous()) bgr = bgr.clone();
  const size_t n = bgr.total();
  const int channels = bgr.channels();  // gray converts as B = G = R (cv::COLOR_GRAY2BGR)
  // OpenCV 8-bit Lab (L·255/100, a + 128, b + 128), made chunk by chunk by our replica of
  // cv::cvtColor(COLOR_BGR2Lab) (metrics/opencv_lab.h) and used while the chunk is in cache.
  cv::Mat lab_image(bgr.size(), CV_8UC3);
  uint8_t* lab = lab_image.ptr<uint8_t>(0);
  const uint8_t* src = bgr.ptr<uint8_t>(0);
  const double* chroma = ChromaTable().data();
  // Four interleaved partial histograms: neighbouring pixels often share L, and one table would
  // serialise their increments.
  std::array<std::array<int64_t, 256>, 4> partial{};
  // Saturation and chroma in one pass over the pixels, each mean in NumPy's order.
  constexpr size_t kChunk = 8192;  // NumPy's ufunc buffer (see NumpyPairwiseSum)
  std::vector<double> saturation_chunk(kChunk), chroma_chunk(kChunk);
  double saturation_total = 0.0, chroma_total = 0.0;
  for (size_t i = 0; i < n; i += kChunk) {
    const int count = static_cast<int>(std::min(kChunk, n - i));
    uint8_t* pixels = lab + 3 * i;
    BgrToLab8(src + channels * i, channels, count, pixels);
    int k4 = 0;
    for (; k4 + 4 <= count; k4 += 4) {
      for (int t = 0; t < 4; ++t) ++partial[t][pixels[3 * (k4 + t)]];
    }
    for (; k4 < count; ++k4) ++partial[0][pixels[3 * k4]];
    simd::UciqeSaturation(pixels, count, chroma, saturation_chunk.data(), chroma_chunk.data());
    saturation_total += NumpyPairwiseSum(saturation_chunk.data(), count);
    chroma_total += NumpyPairwiseSum(chroma_chunk.data(), count);
  }
  std::array<int64_t, 256> l_hist{};
  for (int level = 0; level < 256; ++level) {
    l_hist[level] = partial[0][level] + partial[1][level] + partial[2][level] + partial[3][level];
  }

  UciqeResult r;
  r.variant = UciqeVariantName(options.variant);
  r.mean_saturation = saturation_total / static_cast<double>(n);
  const double mean_chr = chroma_total / static_cast<double>(n);
  // |1 − (mean/chr)²| depends on (a, b) only: one division per pair instead of one per pixel.
  std::vector<double> spread(256 * 256);
  simd::UciqeSpread(AllAbPairs().data(), 256 * 256, chroma, mean_chr, spread.data());
  r.chroma_spread = std::sqrt(NumpyMeanOf(n, [&](size_t begin, size_t count, double* out) {
    const uint8_t* p = lab + 3 * begin;
    for (size_t k = 0; k < count; ++k, p += 3) out[k] = spread[p[1] * 256 + p[2]];
  }));

  // con_l: first bins where the cdf of a 65536-bin histogram over [min L', max L'] exceeds 1 % and
  // reaches 99 %, transcribed from MATLAB's stretchlim with its 1-based "−1" kept.
  int lo_level = 0, hi_level = 255;
  while (l_hist[lo_level] == 0) ++lo_level;
  while (l_hist[hi_level] == 0) --hi_level;
  double first = lo_level / 255.0, last = hi_level / 255.0;
  if (first == last) {  // numpy widens a degenerate range by ±0.5
    first -= 0.5;
    last += 0.5;
  }
  int64_t cumulative = 0;
  int64_t i_low = -1, i_high = -1;
  for (int level = lo_level; level <= hi_level; ++level) {
    if (l_hist[level] == 0) continue;
    cumulative += l_hist[level];
    const double cdf = static_cast<double>(cumulative) / static_cast<double>(n);
    const int64_t bin = NumpyBin(level / 255.0, first, last, kBins);
    if (i_low < 0 && cdf > 0.01) i_low = bin;
    if (i_high < 0 && cdf >= 0.99) i_high = bin;
  }
  const double tol_low = static_cast<double>(i_low - 1) / (kBins - 1);
  const double tol_high = static_cast<double>(i_high - 1) / (kBins - 1);
  r.luminance_contrast = tol_high - tol_low;
  r.uciqe = kC1 * r.chroma_spread + kC2 * r.luminance_contrast + kC3 * r.mean_saturation;
  return r;
}

}  // namespace turbid
