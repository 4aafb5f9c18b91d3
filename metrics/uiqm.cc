// UIQM as computed by FUnIE-GAN's uqim_utils.py (see uiqm.h). Arithmetic is double; the
// reference runs its NumPy code on float32 arrays, which moves UIQM by ≤ 1.1e-8 (reference README);
// on the same inputs in float64 the reference and this file agree to rounding (tests: 1e-12).
//
// Everything is computed from the 8-bit values in one pass per block row, on integers where the
// reference's doubles hold integers: UICM's histograms, UIConM's block extremes (both exactly the
// reference's values), and for UISM the Sobel squared magnitude m² = d0² + d1² (an integer). The
// EME of the edge map e = (√m² · 255/max√m²) · x only needs each block's max/min ratio, which
// is √(m²x²)max / √(m²x²)min: the extremes of the exact integer m²x² pick the same pixels, and
// the scale cancels, so log(max/min) = ½ log(q_max/q_min) differs from the reference's only by
// rounding (≤ 1e-15 relative; tests/metrics/no_reference_fast_paths_test.cc compares with the
// pre-optimisation code at 1e-13).
#include "metrics/uiqm.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "metrics/visible_edges.h"
#include "core/error.h"

namespace turbid {
namespace {

constexpr double kC1 = 0.0282;  // Panetta 2016 Eq. 13
constexpr double kC2 = 0.2953;
constexpr double kC3 = 3.5753;

// The 8-bit image as three R, G, B planes with a one-pixel border repeated from the edge
// (scipy.ndimage 'reflect' = edge pixel repeated, what the reference's Sobel uses).
struct RgbPlanes8 {
  int rows = 0;
  int cols = 0;
  int stride = 0;                             // cols + 2
  std::array<std::vector<uint8_t>, 3> plane;  // 0 = R, 1 = G, 2 = B; (rows + 2) × stride
  const uint8_t* Row(int c, int i) const {    // image row i (−1 .. rows), column 0
    return plane[c].data() + static_cast<size_t>(i + 1) * stride + 1;
  }
};

RgbPlanes8 ToPlanes(const cv::Mat& image) {
  const cv::Mat eight = ToEightBit(image, "uiqm");
  RgbPlanes8 p;
  p.rows = eight.rows;
  p.cols = eight.cols;
  p.stride = p.cols + 2;
  for (auto& v : p.plane) v.resize(static_cast<size_t>(p.rows + 2) * p.stride);
  const int ch = eight.channels();
  for (int i = 0; i < p.rows; ++i) {
    const uint8_t* src = eight.ptr<uint8_t>(i);
    std::array<uint8_t*, 3> dst;
    for (int c = 0; c < 3; ++c)
      dst[c] = p.plane[c].data() + static_cast<size_t>(i + 1) * p.stride + 1;
    if (ch == 1) {  // gray replicated, UICM = 0
      for (int c = 0; c < 3; ++c) std::copy(src, src + p.cols, dst[c]);
    } else {
      for (int j = 0; j < p.cols; ++j) {
        dst[0][j] = src[3 * j + 2];
        dst[1][j] = src[3 * j + 1];
        dst[2][j] = src[3 * j];
      }
    }
    for (int c = 0; c < 3; ++c) {
      dst[c][-1] = dst[c][0];
      dst[c][p.cols] = dst[c][p.cols - 1];
    }
  }
  for (int c = 0; c < 3; ++c) {
    uint8_t* data = p.plane[c].data();
    std::copy(data + p.stride, data + 2 * p.stride, data);
    std::copy(data + static_cast<size_t>(p.rows) * p.stride,
              data + static_cast<size_t>(p.rows + 1) * p.stride,
              data + static_cast<size_t>(p.rows + 1) * p.stride);
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

double Uicm(const RgbPlanes8& p, double alpha, bool compat) {
  const size_t k = static_cast<size_t>(p.rows) * p.cols;
  // Bins 2·(R − G) + 510 and 2·((R + G)/2 − B) + 510 = R + G − 2B + 510, as integers.
  std::vector<int64_t> hist_rg(1021, 0), hist_yb(1021, 0);
  std::vector<uint32_t> count_rg(1021, 0), count_yb(1021, 0);
  for (int i = 0; i < p.rows; ++i) {
    const uint8_t* r = p.Row(0, i);
    const uint8_t* g = p.Row(1, i);
    const uint8_t* b = p.Row(2, i);
    for (int j = 0; j < p.cols; ++j) {
      ++count_rg[2 * (r[j] - g[j]) + 510];
      ++count_yb[r[j] + g[j] - 2 * b[j] + 510];
    }
  }
  for (size_t bin = 0; bin < hist_rg.size(); ++bin) {
    hist_rg[bin] = count_rg[bin];
    hist_yb[bin] = count_yb[bin];
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

// One row of q = m² · x² (m² the squared Sobel magnitude of scipy.ndimage.sobel along both axes,
// x the channel value), exact in double (< 2^37).
void EdgeEnergyRow(const RgbPlanes8& p, int c, int i, double* q) {
  const uint8_t* up = p.Row(c, i - 1);
  const uint8_t* mid = p.Row(c, i);
  const uint8_t* down = p.Row(c, i + 1);
  for (int j = 0; j < p.cols; ++j) {
    const int d0 = (down[j - 1] + 2 * down[j] + down[j + 1]) - (up[j - 1] + 2 * up[j] + up[j + 1]);
    const int d1 =
        (up[j + 1] + 2 * mid[j + 1] + down[j + 1]) - (up[j - 1] + 2 * mid[j - 1] + down[j - 1]);
    const int m2 = d0 * d0 + d1 * d1;  // <= 2 · 1020²
    const int x2 = mid[j] * mid[j];
    q[j] = static_cast<double>(m2) * static_cast<double>(x2);  // exact: < 2^37
  }
}

// UISM's EME of one channel and UIConM, from block×block tiles (k1 = floor(cols/block) across,
// k2 = floor(rows/block) down; the remainder is dropped). The per-tile terms are kept and summed
// column-major, the reference's order.
struct BlockTerms {
  std::array<double, 3> eme{};  // per channel, R, G, B
  double uiconm = 0.0;
};

BlockTerms BlockMeasures(const RgbPlanes8& p, int block) {
  const int k1 = p.cols / block;
  const int k2 = p.rows / block;
  std::array<std::vector<double>, 3> eme_terms;
  for (auto& t : eme_terms) t.assign(static_cast<size_t>(k1) * k2, 0.0);
  std::vector<double> contrast_terms(static_cast<size_t>(k1) * k2, 0.0);
  std::vector<double> q(p.cols);
  std::vector<double> q_lo(k1), q_hi(k1);
  std::vector<uint8_t> v_lo(k1), v_hi(k1);
  for (int k = 0; k < k2; ++k) {
    // UIConM: extremes over the tile and the three channels (integers, exact).
    std::fill(v_lo.begin(), v_lo.end(), 255);
    std::fill(v_hi.begin(), v_hi.end(), 0);
    for (int c = 0; c < 3; ++c) {
      for (int i = k * block; i < (k + 1) * block; ++i) {
        const uint8_t* row = p.Row(c, i);
        for (int l = 0; l < k1; ++l) {
          const uint8_t* tile = row + l * block;
          uint8_t lo = v_lo[l], hi = v_hi[l];
          for (int j = 0; j < block; ++j) {
            lo = std::min(lo, tile[j]);
            hi = std::max(hi, tile[j]);
          }
          v_lo[l] = lo;
          v_hi[l] = hi;
        }
      }
    }
    for (int l = 0; l < k1; ++l) {
      const double top = static_cast<double>(v_hi[l]) - v_lo[l];
      const double bottom = static_cast<double>(v_hi[l]) + v_lo[l];
      if (top == 0.0 || bottom == 0.0) continue;
      contrast_terms[static_cast<size_t>(l) * k2 + k] = (top / bottom) * std::log(top / bottom);
    }
    // EME per channel: extremes of q over the tile.
    for (int c = 0; c < 3; ++c) {
      for (int i = k * block; i < (k + 1) * block; ++i) {
        EdgeEnergyRow(p, c, i, q.data());
        for (int l = 0; l < k1; ++l) {
          const double* tile = q.data() + l * block;
          double lo = i == k * block ? tile[0] : q_lo[l];
          double hi = i == k * block ? tile[0] : q_hi[l];
          for (int j = 0; j < block; ++j) {
            lo = std::min(lo, tile[j]);
            hi = std::max(hi, tile[j]);
          }
          q_lo[l] = lo;
          q_hi[l] = hi;
        }
      }
      for (int l = 0; l < k1; ++l) {
        if (q_lo[l] == 0.0) continue;  // min = 0 (or a flat channel): the tile adds 0
        eme_terms[c][static_cast<size_t>(l) * k2 + k] = 0.5 * std::log(q_hi[l] / q_lo[l]);
      }
    }
  }
  BlockTerms out;
  for (int c = 0; c < 3; ++c) {
    double sum = 0.0;
    for (const double t : eme_terms[c]) sum += t;
    out.eme[c] = (2.0 / (k1 * k2)) * sum;
  }
  double sum = 0.0;
  for (const double t : contrast_terms) sum += t;
  out.uiconm = (-1.0 / (k1 * k2)) * sum;
  return out;
}

}  // namespace

std::string UiqmVariantName(UiqmVariant variant) {
  return variant == UiqmVariant::kCorrected ? "corrected" : "funiegan-compat";
}

UiqmVariant ParseUiqmVariant(const std::string& name) {
  if (name == "funiegan-compat") return UiqmVariant::kFunieGanCompat;
  if (name == "corrected") return UiqmVariant::kCorrected;
  throw Error("uiqm: unknown variant '" + name + "' (expected funiegan-compat or corrected)");
}

bool UiqmOptions::Check(std::string* why) const {
  if (variant != UiqmVariant::kFunieGanCompat && variant != UiqmVariant::kCorrected) {
    if (why) *why = "variant: unknown value";
    return false;
  }
  if (block_size < 2) {
    if (why) *why = "block_size must be >= 2";
    return false;
  }
  if (!(alpha_trim >= 0.0 && alpha_trim < 0.5)) {
    if (why) *why = "alpha_trim must be in [0, 0.5)";
    return false;
  }
  return true;
}

nlohmann::json UiqmResult::ToJson() const {
  return {{"variant", variant}, {"uiqm", uiqm}, {"uicm", uicm}, {"uism", uism}, {"uiconm", uiconm}};
}

UiqmResult Uiqm(const UiqmOptions& options, const cv::Mat& image) {
  ThrowIfInvalid(options, "uiqm");
  const RgbPlanes8 p = ToPlanes(image);
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
  const BlockTerms blocks = BlockMeasures(p, options.block_size);
  r.uism = 0.0;
  for (int c = 0; c < 3; ++c) r.uism += lambda[c] * blocks.eme[c];
  r.uiconm = blocks.uiconm;
  r.uiqm = kC1 * r.uicm + kC2 * r.uism + kC3 * r.uiconm;
  return r;
}

}  // namespace turbid
