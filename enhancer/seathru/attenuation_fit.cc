// β^D_c(r) from the illuminant's decay with range, and FitWater (enhancer/seathru/water_fit.h).
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "enhancer/seathru/water_fit.h"

namespace turbid {
namespace {

// Exponents tried for b and d (1/m): β^D(r) = a e^{b r} + c e^{d r}, b >= d, within Sea-thru's
// bounds [-10, 0].
const double kExponents[] = {0, -0.05, -0.1, -0.2, -0.35, -0.5, -0.75, -1, -1.5, -2, -3, -5, -10};

struct Bin {
  double r;
  double log_e;
};

// Least squares of L ≈ s − a·u − c·v (u = e^{b r} r, v = e^{d r} r) with a, c in [0, 10] and s free
// (or fixed at s_fixed when `fixed`). Returns the sum of squares; writes s, a, c.
double SolveLinear(const std::vector<Bin>& bins, double b, double d, bool fixed, double s_fixed,
                   double* s, double* a, double* c) {
  const bool one_term = b == d;
  double best = std::numeric_limits<double>::infinity();
  // Active sets: which of a, c are free (the rest held at 0).
  for (int mask = 3; mask >= 0; --mask) {
    const bool free_a = mask & 1, free_c = (mask & 2) && !one_term;
    if ((mask & 2) && one_term) continue;
    std::vector<int> cols;  // 0 = s, 1 = a, 2 = c
    if (!fixed) cols.push_back(0);
    if (free_a) cols.push_back(1);
    if (free_c) cols.push_back(2);
    double x[3] = {fixed ? s_fixed : 0.0, 0.0, 0.0};
    if (!cols.empty()) {
      const int m = static_cast<int>(cols.size());
      cv::Mat ata = cv::Mat::zeros(m, m, CV_64F), aty = cv::Mat::zeros(m, 1, CV_64F);
      for (const Bin& bin : bins) {
        const double col[3] = {1.0, -std::exp(b * bin.r) * bin.r, -std::exp(d * bin.r) * bin.r};
        const double y = bin.log_e - (fixed ? s_fixed : 0.0);
        for (int i = 0; i < m; ++i) {
          aty.at<double>(i) += col[cols[i]] * y;
          for (int k = 0; k < m; ++k) ata.at<double>(i, k) += col[cols[i]] * col[cols[k]];
        }
      }
      cv::Mat sol;
      if (!cv::solve(ata, aty, sol, cv::DECOMP_SVD)) continue;
      for (int i = 0; i < m; ++i) x[cols[i]] = sol.at<double>(i);
      if ((free_a && (x[1] < 0 || x[1] > 10)) || (free_c && (x[2] < 0 || x[2] > 10))) continue;
    }
    double sse = 0;
    for (const Bin& bin : bins) {
      const double f =
          x[0] - x[1] * std::exp(b * bin.r) * bin.r - x[2] * std::exp(d * bin.r) * bin.r;
      sse += (bin.log_e - f) * (bin.log_e - f);
    }
    if (sse < best) {
      best = sse;
      *s = x[0];
      *a = x[1];
      *c = x[2];
    }
  }
  return best;
}

// The frame the illuminant is computed on. The illuminant is a wide average (illuminant_extent of
// the longer side): it is computed on every s-th pixel of every s-th row, s = ceil(longer side /
// 512), which leaves its box as wide and its range layers as they are, at 1/s^2 of the work
// (decimation, no averaging of ranges).
WaterFitFrame DecimatedFrame(const WaterFitFrame& full) {
  const int s = std::max(1, (std::max(full.image.cols, full.image.rows) + 511) / 512);
  WaterFitFrame f = full;
  if (s == 1) return f;
  const int w = (full.image.cols + s - 1) / s, h = (full.image.rows + s - 1) / s;
  f.image = cv::Mat(h, w, CV_32FC3);
  f.range_m = cv::Mat(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.image.at<cv::Vec3f>(y, x) = full.image.at<cv::Vec3f>(y * s, x * s);
      f.range_m.at<float>(y, x) = full.range_m.at<float>(y * s, x * s);
    }
  return f;
}

// Counts the frame's valid pixels and widens the fit's range span.
void CountValidRanges(const cv::Mat& range_m, WaterFit* fit) {
  for (int y = 0; y < range_m.rows; ++y) {
    const float* r = range_m.ptr<float>(y);
    for (int x = 0; x < range_m.cols; ++x) {
      if (!(std::isfinite(r[x]) && r[x] > 0)) continue;
      ++fit->valid_pixels;
      fit->min_range_m = std::min<double>(fit->min_range_m, r[x]);
      fit->max_range_m = std::max<double>(fit->max_range_m, r[x]);
    }
  }
}

// (r, ln Ê (R, G, B)) for every valid, lit pixel of `f`: Ê is the direct signal's local average
// colour (the illuminant up to the scale f).
void AddIlluminantSamples(const WaterFitFrame& f, const WaterFit& fit,
                          const WaterFitOptions& options,
                          std::vector<std::array<float, 4>>* samples) {
  const cv::Mat average = LocalAverageColour(DirectSignal(f, fit.backscatter), f.range_m, options);
  const double scale = options.fit_illuminant_scale ? 1.0 : 2.0;  // the paper's f
  for (int y = 0; y < f.range_m.rows; ++y) {
    const float* r = f.range_m.ptr<float>(y);
    const cv::Vec3f* a = average.ptr<cv::Vec3f>(y);
    for (int x = 0; x < f.range_m.cols; ++x) {
      if (!(std::isfinite(r[x]) && r[x] > 0)) continue;
      if (a[x][0] <= 1e-6f || a[x][1] <= 1e-6f || a[x][2] <= 1e-6f) continue;
      samples->push_back({r[x], static_cast<float>(std::log(scale * a[x][2])),
                          static_cast<float>(std::log(scale * a[x][1])),
                          static_cast<float>(std::log(scale * a[x][0]))});
    }
  }
}

// Range bins of the illuminant's logarithm: each bin's median (r, ln Ê (R, G, B)), every bin
// weighted alike; bins with too few samples are left out. Fills the bins' ranges and counts.
std::vector<std::array<double, 4>> BinMedians(std::vector<std::array<float, 4>>& samples,
                                              const WaterFit& fit, int nb, AttenuationFit* att) {
  const double lo = fit.min_range_m, width = std::max(fit.max_range_m - lo, 1e-9) / nb;
  std::vector<std::vector<std::array<float, 4>>> per_bin(static_cast<size_t>(nb));
  for (const auto& s : samples)
    per_bin[static_cast<size_t>(std::min(nb - 1, static_cast<int>((s[0] - lo) / width)))].push_back(
        s);
  const size_t min_count = std::max<size_t>(20, samples.size() / (50 * static_cast<size_t>(nb)));
  std::vector<std::array<double, 4>> medians;
  for (auto& v : per_bin) {
    if (v.size() < min_count) continue;
    std::array<double, 4> m{};
    for (int k = 0; k < 4; ++k) {
      auto mid = v.begin() + static_cast<long>(v.size() / 2);
      std::nth_element(v.begin(), mid, v.end(),
                       [k](const auto& p, const auto& q) { return p[k] < q[k]; });
      m[k] = (*mid)[k];
    }
    medians.push_back(m);
    att->bin_range_m.push_back(m[0]);
    att->bin_count.push_back(static_cast<int>(v.size()));
  }
  return medians;
}

// The illuminant's scale from a single exponential (ln Ê = s − β0 r, a straight line over the
// bins): fitted together with the two-term β^D(r), ln k is nearly degenerate with a e^{b r} r and
// small range-dependent changes of the average reflectance move it anywhere.
double StraightLineScale(const std::vector<Bin>& bins) {
  double sr = 0, sl = 0, srr = 0, srl = 0;
  for (const Bin& bin : bins) {
    sr += bin.r;
    sl += bin.log_e;
    srr += bin.r * bin.r;
    srl += bin.r * bin.log_e;
  }
  const double m = static_cast<double>(bins.size()), det = m * srr - sr * sr;
  return det > 1e-12 ? (sl * srr - sr * srl) / det : sl / m;
}

// β^D(r) of channel c: the two-term exponential with the least squared error over the
// exponent grid.
void FitChannel(const std::vector<std::array<double, 4>>& medians, int c,
                const WaterFitOptions& options, AttenuationFit* att) {
  std::vector<Bin> bins;
  for (const auto& m : medians) bins.push_back({m[0], m[1 + c]});
  const double s_fixed = options.fit_illuminant_scale ? StraightLineScale(bins) : 0.0;
  double best = std::numeric_limits<double>::infinity();
  for (double b : kExponents)
    for (double d : kExponents) {
      if (d > b) continue;
      double s = 0, a = 0, cc = 0;
      const double sse = SolveLinear(bins, b, d, true, s_fixed, &s, &a, &cc);
      if (sse < best - 1e-15) {
        best = sse;
        att->log_scale[c] = s;
        att->a[c] = a;
        att->b[c] = b;
        att->c[c] = cc;
        att->d[c] = d;
      }
    }
  att->rms[c] = std::sqrt(best / static_cast<double>(bins.size()));
}

}  // namespace

WaterFit FitWater(const std::vector<WaterFitFrame>& frames, const WaterFitOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw Error("water fit", why);
  WaterFit fit;
  fit.backscatter = FitBackscatter(frames, options);
  fit.frames = static_cast<int>(frames.size());
  fit.min_range_m = std::numeric_limits<double>::infinity();
  std::vector<std::array<float, 4>> samples;  // r, ln Ê (R, G, B)
  for (const WaterFitFrame& full : frames) {
    CountValidRanges(full.range_m, &fit);
    AddIlluminantSamples(DecimatedFrame(full), fit, options, &samples);
  }
  AttenuationFit& att = fit.attenuation;
  const std::vector<std::array<double, 4>> medians =
      BinMedians(samples, fit, options.attenuation_bins, &att);
  if (medians.size() < 3)
    throw Error("water fit",
                "the illuminant is known in fewer than 3 range bins: too few lit "
                "pixels or too narrow a range to fit beta^D");
  for (int c = 0; c < 3; ++c) FitChannel(medians, c, options, &att);
  for (const auto& m : medians) {
    Rgb3 beta{}, fitted{};
    for (int c = 0; c < 3; ++c) {
      beta[c] = (att.log_scale[c] - m[1 + c]) / m[0];
      fitted[c] = att.Beta(c, m[0]);
    }
    att.bin_beta.push_back(beta);
    att.bin_fitted.push_back(fitted);
  }
  return fit;
}

}  // namespace turbid
