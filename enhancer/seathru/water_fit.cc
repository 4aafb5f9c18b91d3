// Sea-thru's water estimate (enhancer/seathru/water_fit.h; choices: docs/cli/water.md).
#include "enhancer/seathru/water_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace turbid {
namespace {

constexpr double kBetaMax = 5.0;  // the paper's bound on β^B and β' (1/m)
constexpr int kBetaGrid = 51;     // 0, 0.1, ..., 5

bool ValidRange(float r) { return std::isfinite(r) && r > 0.0f; }

struct Pixel {
  float sum;  // R + G + B
  float r;
  float rgb[3];
};

// The smallest and largest valid range over all frames.
void RangeBounds(const std::vector<WaterFitFrame>& frames, double* lo, double* hi,
                 long long* count) {
  *lo = std::numeric_limits<double>::infinity();
  *hi = 0.0;
  *count = 0;
  for (const WaterFitFrame& f : frames) {
    for (int y = 0; y < f.range_m.rows; ++y) {
      const float* r = f.range_m.ptr<float>(y);
      for (int x = 0; x < f.range_m.cols; ++x) {
        if (!ValidRange(r[x])) continue;
        *lo = std::min(*lo, static_cast<double>(r[x]));
        *hi = std::max(*hi, static_cast<double>(r[x]));
        ++*count;
      }
    }
  }
}

void CheckFrames(const std::vector<WaterFitFrame>& frames) {
  if (frames.empty()) throw Error("water fit", "no frames");
  for (const WaterFitFrame& f : frames) {
    const std::string name = f.name.empty() ? "water fit" : f.name;
    if (f.image.type() != CV_32FC3)
      throw Error(name, "water fit needs a 3-channel float image (linear B, G, R)");
    if (f.range_m.type() != CV_32FC1 || f.range_m.size() != f.image.size())
      throw Error(name, "water fit needs a range map of the image's size");
  }
}

// min over [0,1]^2 of q(B, J) = -2 B suy - 2 J svy + B^2 suu + 2 B J suv + J^2 svv (+ syy).
double SolveBox(double suu, double suv, double svv, double suy, double svy, double* b, double* j) {
  auto q = [&](double bb, double jj) {
    return -2 * bb * suy - 2 * jj * svy + bb * bb * suu + 2 * bb * jj * suv + jj * jj * svv;
  };
  auto clamp01 = [](double v) { return std::clamp(v, 0.0, 1.0); };
  double best = std::numeric_limits<double>::infinity();
  auto consider = [&](double bb, double jj) {
    const double v = q(bb, jj);
    if (v < best) {
      best = v;
      *b = bb;
      *j = jj;
    }
  };
  const double det = suu * svv - suv * suv;
  if (det > 1e-12 * std::max(1e-30, suu * svv)) {
    const double bb = (suy * svv - svy * suv) / det, jj = (svy * suu - suy * suv) / det;
    if (bb >= 0 && bb <= 1 && jj >= 0 && jj <= 1) consider(bb, jj);
  }
  for (double bb : {0.0, 1.0}) consider(bb, svv > 0 ? clamp01((svy - bb * suv) / svv) : 0.0);
  for (double jj : {0.0, 1.0}) consider(suu > 0 ? clamp01((suy - jj * suv) / suu) : 0.0, jj);
  return best;
}

// Levenberg-Marquardt on (B∞, β^B, J', β') from a starting point, within the paper's bounds.
void PolishBackscatter(const std::vector<Pixel>& dark, int c, double p[4]) {
  const double lo[4] = {0, 0, 0, 0}, hi[4] = {1, kBetaMax, 1, kBetaMax};
  auto sse = [&](const double* q) {
    double s = 0;
    for (const Pixel& d : dark) {
      const double f = q[0] * (1 - std::exp(-q[1] * d.r)) + q[2] * std::exp(-q[3] * d.r);
      s += (d.rgb[c] - f) * (d.rgb[c] - f);
    }
    return s;
  };
  double current = sse(p), lambda = 1e-3;
  for (int iteration = 0; iteration < 30; ++iteration) {
    cv::Matx44d jtj = cv::Matx44d::zeros();
    cv::Vec4d jte(0, 0, 0, 0);
    for (const Pixel& d : dark) {
      const double eb = std::exp(-p[1] * d.r), ep = std::exp(-p[3] * d.r);
      const cv::Vec4d g(1 - eb, p[0] * d.r * eb, ep, -p[2] * d.r * ep);
      const double e = d.rgb[c] - (p[0] * (1 - eb) + p[2] * ep);
      for (int i = 0; i < 4; ++i) {
        jte[i] += g[i] * e;
        for (int k = 0; k < 4; ++k) jtj(i, k) += g[i] * g[k];
      }
    }
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      cv::Matx44d a = jtj;
      for (int i = 0; i < 4; ++i) a(i, i) += lambda * (jtj(i, i) + 1e-12);
      cv::Vec4d step;
      if (!cv::solve(a, jte, step, cv::DECOMP_CHOLESKY)) break;
      double q[4];
      for (int i = 0; i < 4; ++i) q[i] = std::clamp(p[i] + step[i], lo[i], hi[i]);
      const double next = sse(q);
      if (next < current) {
        improved = current - next > 1e-12 * current;
        std::copy(q, q + 4, p);
        current = next;
        lambda = std::max(lambda / 10, 1e-9);
        if (!improved) return;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) return;
  }
}

double Median(std::vector<double>& v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

bool WaterFitOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (range_bins < 2 || range_bins > 1000) return fail("range_bins must be in [2, 1000]");
  if (!(dark_percent > 0 && dark_percent <= 100)) return fail("dark_percent must be in (0, 100]");
  if (illuminant_layers < 2 || illuminant_layers > 256)
    return fail("illuminant_layers must be in [2, 256]");
  if (!(illuminant_extent > 0 && illuminant_extent <= 1))
    return fail("illuminant_extent must be in (0, 1]");
  if (attenuation_bins < 3 || attenuation_bins > 1000)
    return fail("attenuation_bins must be in [3, 1000]");
  return true;
}

const Fields<WaterFitOptions>& WaterFitFields() {
  using O = WaterFitOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Integer("range_bins", &O::range_bins,
                   "backscatter: range bins, evenly spaced over [min, max] (paper: 10)", 2, 1000)
          .Number("dark_percent", &O::dark_percent,
                  "backscatter: darkest percent of each bin by R+G+B (paper: 1)",
                  NumberRange::AboveUpTo(0, 100))
          .Integer("illuminant_layers", &O::illuminant_layers,
                   "illuminant: range layers of the local space average colour", 2, 256)
          .Number("illuminant_extent", &O::illuminant_extent,
                  "illuminant: box half-width, fraction of the longer image side",
                  NumberRange::AboveUpTo(0, 1))
          .Integer("attenuation_bins", &O::attenuation_bins,
                   "beta^D: range bins of the illuminant's logarithm", 3, 1000)
          .Boolean("fit_illuminant_scale", &O::fit_illuminant_scale,
                   "beta^D: fit the illuminant's scale k_c (false: the paper's f = 2)");
  return fields;
}

double BackscatterFit::Evaluate(int c, double r) const {
  return b_inf[c] * (1 - std::exp(-beta_b[c] * r)) + j_prime[c] * std::exp(-beta_prime[c] * r);
}

double AttenuationFit::Beta(int c, double r) const {
  return a[c] * std::exp(b[c] * r) + this->c[c] * std::exp(d[c] * r);
}

namespace {

// The valid pixels of every frame, by range bin: (R + G + B, r, (R, G, B)).
std::vector<std::vector<Pixel>> PixelsByRangeBin(const std::vector<WaterFitFrame>& frames,
                                                 double lo, double width, int bins) {
  std::vector<std::vector<Pixel>> per_bin(static_cast<size_t>(bins));
  for (const WaterFitFrame& f : frames) {
    for (int y = 0; y < f.image.rows; ++y) {
      const float* r = f.range_m.ptr<float>(y);
      const cv::Vec3f* p = f.image.ptr<cv::Vec3f>(y);
      for (int x = 0; x < f.image.cols; ++x) {
        if (!ValidRange(r[x])) continue;
        const int b = std::min(bins - 1, static_cast<int>((r[x] - lo) / width));
        per_bin[static_cast<size_t>(b)].push_back(
            {p[x][0] + p[x][1] + p[x][2], r[x], {p[x][2], p[x][1], p[x][0]}});
      }
    }
  }
  return per_bin;
}

// The darkest dark_percent % of each bin (by R + G + B); fills the bins' ranges and medians.
std::vector<Pixel> DarkestPixels(std::vector<std::vector<Pixel>>& per_bin, double lo, double width,
                                 double dark_percent, BackscatterFit* fit) {
  std::vector<Pixel> dark;
  for (size_t b = 0; b < per_bin.size(); ++b) {
    std::vector<Pixel>& v = per_bin[b];
    if (v.empty()) continue;
    const size_t keep =
        std::max<size_t>(1, static_cast<size_t>(std::ceil(v.size() * dark_percent / 100.0)));
    std::nth_element(v.begin(), v.begin() + static_cast<long>(keep - 1), v.end(),
                     [](const Pixel& a, const Pixel& b) { return a.sum < b.sum; });
    fit->bin_range_m.push_back(lo + (static_cast<double>(b) + 0.5) * width);
    Rgb3 median{};
    for (int c = 0; c < 3; ++c) {
      std::vector<double> values;
      for (size_t i = 0; i < keep; ++i) values.push_back(v[i].rgb[c]);
      median[c] = Median(values);
    }
    fit->bin_dark_median.push_back(median);
    dark.insert(dark.end(), v.begin(), v.begin() + static_cast<long>(keep));
  }
  return dark;
}

// Variable projection: for each (β^B, β') on a grid, B∞ and J' are a box-constrained linear
// least-squares problem. The grid's exponentials and their channel-independent sums, once.
struct ProjectionGrid {
  std::vector<std::vector<double>> e;  // e[k][i] = exp(-β_k r_i)
  std::vector<double> suu, svv;
  std::vector<std::vector<double>> suv;

  explicit ProjectionGrid(const std::vector<Pixel>& dark)
      : e(kBetaGrid, std::vector<double>(dark.size())),
        suu(kBetaGrid),
        svv(kBetaGrid),
        suv(kBetaGrid, std::vector<double>(kBetaGrid)) {
    const size_t n = dark.size();
    for (int k = 0; k < kBetaGrid; ++k)
      for (size_t i = 0; i < n; ++i) e[k][i] = std::exp(-Beta(k) * dark[i].r);
    for (int j = 0; j < kBetaGrid; ++j) {
      for (size_t i = 0; i < n; ++i) {
        suu[j] += (1 - e[j][i]) * (1 - e[j][i]);
        svv[j] += e[j][i] * e[j][i];
      }
      for (int k = 0; k < kBetaGrid; ++k) {
        double s = 0;
        for (size_t i = 0; i < n; ++i) s += (1 - e[j][i]) * e[k][i];
        suv[j][k] = s;
      }
    }
  }
  static double Beta(int k) { return kBetaMax * k / (kBetaGrid - 1); }

  // The best grid point for channel c: p = {B∞, β^B, J', β'}.
  void Best(const std::vector<Pixel>& dark, int c, double p[4]) const {
    std::vector<double> suy(kBetaGrid), svy(kBetaGrid);
    for (int k = 0; k < kBetaGrid; ++k)
      for (size_t i = 0; i < dark.size(); ++i) {
        suy[k] += (1 - e[k][i]) * dark[i].rgb[c];
        svy[k] += e[k][i] * dark[i].rgb[c];
      }
    double best = std::numeric_limits<double>::infinity();
    for (int j = 0; j < kBetaGrid; ++j)
      for (int k = 0; k < kBetaGrid; ++k) {
        double bb, jj;
        const double q = SolveBox(suu[j], suv[j][k], svv[k], suy[j], svy[k], &bb, &jj);
        if (q < best) {
          best = q;
          p[0] = bb;
          p[1] = Beta(j);
          p[2] = jj;
          p[3] = Beta(k);
        }
      }
  }
};

}  // namespace

BackscatterFit FitBackscatter(const std::vector<WaterFitFrame>& frames,
                              const WaterFitOptions& options) {
  CheckFrames(frames);
  double lo, hi;
  long long count;
  RangeBounds(frames, &lo, &hi, &count);
  if (count == 0) throw Error("water fit", "no pixel with a valid range");
  const int bins = options.range_bins;
  const double width = std::max(hi - lo, 1e-9) / bins;
  std::vector<std::vector<Pixel>> per_bin = PixelsByRangeBin(frames, lo, width, bins);
  BackscatterFit fit;
  const std::vector<Pixel> dark = DarkestPixels(per_bin, lo, width, options.dark_percent, &fit);
  if (fit.bin_range_m.size() < 2)
    throw Error("water fit", "the valid ranges fill fewer than 2 range bins (" +
                                 std::to_string(lo) + ".." + std::to_string(hi) + " m)");
  // The best grid point starts Levenberg-Marquardt.
  const ProjectionGrid grid(dark);
  const size_t n = dark.size();
  for (int c = 0; c < 3; ++c) {
    double p[4] = {0, 0, 0, 0};
    grid.Best(dark, c, p);
    PolishBackscatter(dark, c, p);
    fit.b_inf[c] = p[0];
    fit.beta_b[c] = p[1];
    fit.j_prime[c] = p[2];
    fit.beta_prime[c] = p[3];
    double s = 0;
    for (const Pixel& d : dark) s += std::pow(d.rgb[c] - fit.Evaluate(c, d.r), 2);
    fit.rms[c] = std::sqrt(s / static_cast<double>(n));
  }
  for (double r : fit.bin_range_m)
    fit.bin_fitted.push_back({fit.Evaluate(0, r), fit.Evaluate(1, r), fit.Evaluate(2, r)});
  const size_t stride = std::max<size_t>(1, n / 20000);  // the plot's points
  for (size_t i = 0; i < n; i += stride)
    fit.dark.push_back({dark[i].r, dark[i].rgb[0], dark[i].rgb[1], dark[i].rgb[2]});
  return fit;
}

cv::Mat DirectSignal(const WaterFitFrame& frame, const BackscatterFit& backscatter) {
  cv::Mat out(frame.image.size(), CV_32FC3, cv::Scalar::all(0));
  for (int y = 0; y < out.rows; ++y) {
    const float* r = frame.range_m.ptr<float>(y);
    const cv::Vec3f* in = frame.image.ptr<cv::Vec3f>(y);
    cv::Vec3f* d = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < out.cols; ++x) {
      if (!ValidRange(r[x])) continue;
      for (int c = 0; c < 3; ++c)  // image B, G, R; fit R, G, B
        d[x][c] = std::max(0.0f, in[x][c] - static_cast<float>(backscatter.Evaluate(2 - c, r[x])));
    }
  }
  return out;
}

cv::Mat LocalAverageColour(const cv::Mat& direct, const cv::Mat& range_m,
                           const WaterFitOptions& options) {
  CV_Assert(direct.type() == CV_32FC3 && range_m.type() == CV_32FC1 &&
            direct.size() == range_m.size());
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (int y = 0; y < range_m.rows; ++y)
    for (int x = 0; x < range_m.cols; ++x) {
      const float r = range_m.at<float>(y, x);
      if (ValidRange(r)) lo = std::min<double>(lo, r), hi = std::max<double>(hi, r);
    }
  cv::Mat out(direct.size(), CV_32FC3, cv::Scalar::all(0));
  if (!(hi > 0)) return out;
  const int layers = options.illuminant_layers;
  const double step = std::max(hi - lo, 1e-6) / (layers - 1);
  const int half = std::max(1, static_cast<int>(std::lround(options.illuminant_extent *
                                                            std::max(direct.cols, direct.rows))));
  const cv::Size box(2 * half + 1, 2 * half + 1);
  cv::Mat num(direct.size(), CV_32FC3, cv::Scalar::all(0)),
      den(direct.size(), CV_32FC1, cv::Scalar(0));
  cv::Mat weight(direct.size(), CV_32FC1), weighted(direct.size(), CV_32FC3), w_blur, d_blur;
  for (int k = 0; k < layers; ++k) {
    const double centre = lo + k * step;
    bool any = false;
    for (int y = 0; y < range_m.rows; ++y) {
      const float* r = range_m.ptr<float>(y);
      const cv::Vec3f* d = direct.ptr<cv::Vec3f>(y);
      float* w = weight.ptr<float>(y);
      cv::Vec3f* wd = weighted.ptr<cv::Vec3f>(y);
      for (int x = 0; x < range_m.cols; ++x) {
        w[x] = ValidRange(r[x])
                   ? static_cast<float>(std::max(0.0, 1 - std::abs(r[x] - centre) / step))
                   : 0.0f;
        wd[x] = d[x] * w[x];
        any = any || w[x] > 0;
      }
    }
    if (!any) continue;
    cv::boxFilter(weight, w_blur, CV_32F, box, {-1, -1}, true, cv::BORDER_CONSTANT);
    cv::boxFilter(weighted, d_blur, CV_32F, box, {-1, -1}, true, cv::BORDER_CONSTANT);
    for (int y = 0; y < range_m.rows; ++y) {
      const float* w = weight.ptr<float>(y);
      const float* wb = w_blur.ptr<float>(y);
      const cv::Vec3f* db = d_blur.ptr<cv::Vec3f>(y);
      float* dn = den.ptr<float>(y);
      cv::Vec3f* nm = num.ptr<cv::Vec3f>(y);
      for (int x = 0; x < range_m.cols; ++x) {
        if (w[x] <= 0) continue;
        dn[x] += w[x] * wb[x];
        nm[x] += w[x] * db[x];
      }
    }
  }
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      const float d = den.at<float>(y, x);
      if (d > 1e-6f) out.at<cv::Vec3f>(y, x) = num.at<cv::Vec3f>(y, x) / d;
    }
  return out;
}

}  // namespace turbid
