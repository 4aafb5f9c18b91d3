// The pre-optimisation UIQM and UCIQE of commit 6722196 (metrics/uiqm.cc, metrics/uciqe.cc as
// they were before issue 18 item 2), kept verbatim apart from the names (Reference...) and the
// namespaces, as the reference the optimised code is compared with
// (no_reference_fast_paths_test.cc).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"
#include "tests/metrics/reference_pre_optimisation.h"

namespace turbid::reference {
namespace uiqm_old {

constexpr double kC1 = 0.0282;  // Panetta 2016 Eq. 13
constexpr double kC2 = 0.2953;
constexpr double kC3 = 3.5753;

// Planes R, G, B (in this order) as doubles, rows × cols each.
struct RgbPlanes {
  int rows = 0;
  int cols = 0;
  std::array<std::vector<double>, 3> plane;  // 0 = R, 1 = G, 2 = B
};

RgbPlanes ToRgbPlanes(const cv::Mat& image) {
  const cv::Mat eight = ToEightBit(image, "uiqm");
  RgbPlanes p;
  p.rows = eight.rows;
  p.cols = eight.cols;
  for (auto& v : p.plane) v.resize(static_cast<size_t>(p.rows) * p.cols);
  const int ch = eight.channels();
  for (int i = 0; i < p.rows; ++i) {
    const uint8_t* row = eight.ptr<uint8_t>(i);
    for (int j = 0; j < p.cols; ++j) {
      const size_t k = static_cast<size_t>(i) * p.cols + j;
      if (ch == 1) {
        p.plane[0][k] = p.plane[1][k] = p.plane[2][k] = row[j];  // gray replicated, UICM = 0
      } else {
        p.plane[0][k] = row[3 * j + 2];
        p.plane[1][k] = row[3 * j + 1];
        p.plane[2][k] = row[3 * j];
      }
    }
  }
  return p;
}

// Asymmetric α-trimmed mean of integer or half-integer values, indexed by 2·value + 510 (RG and
// YB span [-255, 255] in steps of 0.5). Partial sums of such values are exact in double, so
// summing by histogram gives the same value as the reference's sequential sum over sorted data.
// `compat`: the reference sums sorted[T_L+1 : K−T_R] (0-based, end exclusive), one element fewer
// than the weight 1/(K−T_L−T_R) assumes; corrected sums sorted[T_L : K−T_R].
double TrimmedMean(const std::vector<int64_t>& histogram, int64_t k, double alpha, bool compat) {
  const int64_t t_left = static_cast<int64_t>(std::ceil(alpha * static_cast<double>(k)));
  const int64_t t_right = static_cast<int64_t>(std::floor(alpha * static_cast<double>(k)));
  const double weight = 1.0 / static_cast<double>(k - t_left - t_right);
  const int64_t begin = compat ? t_left + 1 : t_left;  // sorted ranks [begin, end)
  const int64_t end = k - t_right;
  double sum = 0.0;
  int64_t rank = 0;
  for (size_t bin = 0; bin < histogram.size() && rank < end; ++bin) {
    const int64_t n = histogram[bin];
    if (n == 0) continue;
    const int64_t first = std::max(rank, begin);
    const int64_t last = std::min(rank + n, end);
    if (last > first) {
      const double value = (static_cast<double>(bin) - 510.0) / 2.0;
      sum += value * static_cast<double>(last - first);
    }
    rank += n;
  }
  return weight * sum;
}

double Uicm(const RgbPlanes& p, double alpha, bool compat) {
  const size_t k = p.plane[0].size();
  std::vector<int64_t> hist_rg(1021, 0), hist_yb(1021, 0);
  for (size_t i = 0; i < k; ++i) {
    const double r = p.plane[0][i], g = p.plane[1][i], b = p.plane[2][i];
    ++hist_rg[static_cast<size_t>(2.0 * (r - g) + 510.0)];
    ++hist_yb[static_cast<size_t>(2.0 * ((r + g) / 2.0 - b) + 510.0)];
  }
  const double mu_rg = TrimmedMean(hist_rg, static_cast<int64_t>(k), alpha, compat);
  const double mu_yb = TrimmedMean(hist_yb, static_cast<int64_t>(k), alpha, compat);
  // σ² = mean((x − μ)²) over all K pixels (not trimmed), as the reference.
  double s_rg = 0.0, s_yb = 0.0;
  for (size_t bin = 0; bin < hist_rg.size(); ++bin) {
    const double value = (static_cast<double>(bin) - 510.0) / 2.0;
    if (hist_rg[bin]) s_rg += static_cast<double>(hist_rg[bin]) * (value - mu_rg) * (value - mu_rg);
    if (hist_yb[bin]) s_yb += static_cast<double>(hist_yb[bin]) * (value - mu_yb) * (value - mu_yb);
  }
  s_rg /= static_cast<double>(k);
  s_yb /= static_cast<double>(k);
  const double l = std::sqrt(mu_rg * mu_rg + mu_yb * mu_yb);
  const double r = std::sqrt(s_rg + s_yb);
  return -0.0268 * l + 0.1586 * r;
}

// scipy.ndimage.sobel along both axes ('reflect' borders = edge pixel repeated), hypot, scaled
// so that the maximum is 255, times the channel: the reference's per-channel edge map.
std::vector<double> EdgeMap(const std::vector<double>& x, int rows, int cols) {
  // One-pixel mirrored border, then the 3×3 operator on the padded plane.
  const int pc = cols + 2;
  std::vector<double> pad(static_cast<size_t>(rows + 2) * pc);
  for (int i = -1; i <= rows; ++i) {
    const int si = std::clamp(i, 0, rows - 1);
    double* dst = &pad[static_cast<size_t>(i + 1) * pc];
    const double* src = &x[static_cast<size_t>(si) * cols];
    dst[0] = src[0];
    std::copy(src, src + cols, dst + 1);
    dst[cols + 1] = src[cols - 1];
  }
  std::vector<double> mag(x.size());
  double max_mag = 0.0;
  for (int i = 0; i < rows; ++i) {
    const double* up = &pad[static_cast<size_t>(i) * pc];
    const double* mid = up + pc;
    const double* down = mid + pc;
    double* out = &mag[static_cast<size_t>(i) * cols];
    for (int j = 0; j < cols; ++j) {
      const double d0 =
          (down[j] + 2 * down[j + 1] + down[j + 2]) - (up[j] + 2 * up[j + 1] + up[j + 2]);
      const double d1 = (up[j + 2] + 2 * mid[j + 2] + down[j + 2]) - (up[j] + 2 * mid[j] + down[j]);
      const double m = std::hypot(d0, d1);
      out[j] = m;
      max_mag = std::max(max_mag, m);
    }
  }
  // A flat channel has no edges: the reference divides by 0 and gets NaN; we keep the map at 0.
  const double scale = max_mag > 0.0 ? 255.0 / max_mag : 0.0;
  for (size_t k = 0; k < mag.size(); ++k) {
    mag[k] *= scale;
    mag[k] *= x[k];
  }
  return mag;
}

// EME on block×block tiles, k1 = floor(cols/block) across, k2 = floor(rows/block) down; the
// remainder is dropped. Tiles with min = 0 add 0. Tiles visited column-major as the reference.
double Eme(const std::vector<double>& x, int rows, int cols, int block) {
  const int k1 = cols / block;
  const int k2 = rows / block;
  double sum = 0.0;
  for (int l = 0; l < k1; ++l) {
    for (int k = 0; k < k2; ++k) {
      double lo = x[static_cast<size_t>(k * block) * cols + l * block], hi = lo;
      for (int i = k * block; i < (k + 1) * block; ++i) {
        for (int j = l * block; j < (l + 1) * block; ++j) {
          const double v = x[static_cast<size_t>(i) * cols + j];
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
      }
      if (lo == 0.0 || hi == 0.0) continue;
      sum += std::log(hi / lo);
    }
  }
  return (2.0 / (k1 * k2)) * sum;
}

// −1/(k1 k2) Σ r ln r, r = (max − min)/(max + min) over each block×block×3 tile.
double Uiconm(const RgbPlanes& p, int block) {
  const int k1 = p.cols / block;
  const int k2 = p.rows / block;
  double sum = 0.0;
  for (int l = 0; l < k1; ++l) {
    for (int k = 0; k < k2; ++k) {
      double lo = 255.0, hi = 0.0;
      for (const auto& plane : p.plane) {
        for (int i = k * block; i < (k + 1) * block; ++i) {
          for (int j = l * block; j < (l + 1) * block; ++j) {
            const double v = plane[static_cast<size_t>(i) * p.cols + j];
            lo = std::min(lo, v);
            hi = std::max(hi, v);
          }
        }
      }
      const double top = hi - lo;
      const double bottom = hi + lo;
      if (top == 0.0 || bottom == 0.0) continue;
      sum += (top / bottom) * std::log(top / bottom);
    }
  }
  return (-1.0 / (k1 * k2)) * sum;
}

}  // namespace uiqm_old

UiqmResult ReferenceUiqm(const UiqmOptions& options, const cv::Mat& image) {
  using namespace uiqm_old;
  ThrowIfInvalid(options, "uiqm");
  const RgbPlanes p = ToRgbPlanes(image);
  if (p.rows < options.block_size || p.cols < options.block_size) {
    throw Error("uiqm: image " + std::to_string(p.cols) + "x" + std::to_string(p.rows) +
                " is smaller than one " + std::to_string(options.block_size) + "-pixel block");
  }
  const bool compat = options.variant == UiqmVariant::kFunieGanCompat;
  UiqmResult r;
  r.variant = UiqmVariantName(options.variant);
  r.uicm = Uicm(p, options.alpha_trim, compat);
  // λ = 0.299, 0.587, 0.114 (Panetta 2016); the reference code has 0.144 for blue.
  const std::array<double, 3> lambda = {0.299, 0.587, compat ? 0.144 : 0.114};
  r.uism = 0.0;
  for (int c = 0; c < 3; ++c) {
    r.uism +=
        lambda[c] * Eme(EdgeMap(p.plane[c], p.rows, p.cols), p.rows, p.cols, options.block_size);
  }
  r.uiconm = Uiconm(p, options.block_size);
  r.uiqm = kC1 * r.uicm + kC2 * r.uism + kC3 * r.uiconm;
  return r;
}

namespace uciqe_old {

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

double NumpyMean(const std::vector<double>& v) {
  constexpr size_t kChunk = 8192;
  double total = 0.0;
  for (size_t i = 0; i < v.size(); i += kChunk) {
    total += NumpyPairwiseSum(v.data() + i, std::min(kChunk, v.size() - i));
  }
  return total / static_cast<double>(v.size());
}

}  // namespace uciqe_old

UciqeResult ReferenceUciqe(const UciqeOptions& options, const cv::Mat& image) {
  using namespace uciqe_old;
  ThrowIfInvalid(options, "uciqe");
  cv::Mat bgr = ToEightBit(image, "uciqe");
  if (bgr.channels() == 1) cv::cvtColor(bgr, bgr, cv::COLOR_GRAY2BGR);
  cv::Mat lab;
  cv::cvtColor(bgr, lab, cv::COLOR_BGR2Lab);  // OpenCV 8-bit Lab: L·255/100, a+128, b+128

  const size_t n = lab.total();
  std::array<int64_t, 256> l_hist{};
  std::vector<double> chroma(n), saturation(n);
  size_t k = 0;
  for (int i = 0; i < lab.rows; ++i) {
    const uint8_t* row = lab.ptr<uint8_t>(i);
    for (int j = 0; j < lab.cols; ++j, ++k) {
      const double l = row[3 * j] / 255.0;
      const double a = row[3 * j + 1] / 255.0;
      const double b = row[3 * j + 2] / 255.0;
      const double chr = std::sqrt(a * a + b * b);
      chroma[k] = chr;
      saturation[k] = chr / std::sqrt(chr * chr + l * l);
      ++l_hist[row[3 * j]];
    }
  }
  UciqeResult r;
  r.variant = UciqeVariantName(options.variant);
  r.mean_saturation = NumpyMean(saturation);
  const double mean_chr = NumpyMean(chroma);
  std::vector<double>& spread = saturation;  // reuse the buffer
  for (size_t i = 0; i < n; ++i) {
    const double q = mean_chr / chroma[i];
    spread[i] = std::abs(1.0 - q * q);
  }
  r.chroma_spread = std::sqrt(NumpyMean(spread));

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

}  // namespace turbid::reference
