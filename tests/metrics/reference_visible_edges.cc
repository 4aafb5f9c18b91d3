// The pre-optimisation visible-edge implementation of commit 6722196 (metrics/visible_edges.cc as
// it was before issue 18 item 2), kept verbatim apart from the names (Reference...) as the
// reference the optimised code must reproduce bit for bit (no_reference_fast_paths_test.cc).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/error.h"
#include "tests/metrics/reference_pre_optimisation.h"

namespace turbid::reference {
namespace {

constexpr int kWindow = 7;  // S in the code, the paper's 7×7 sub-windows
constexpr int kStep = 4;    // round(S/2): windows overlap by 3 pixels
constexpr int kMaxThreshold = 256;

// MATLAB padarray(..., 'symmetric') index: mirror including the edge pixel, periodic beyond.
int Reflect(int i, int n) {
  if (n == 1) return 0;
  const int period = 2 * n;
  int k = i % period;
  if (k < 0) k += period;
  return k < n ? k : period - 1 - k;
}

// MATLAB/Octave round: half away from zero.
double RoundHalfAway(double v) { return std::round(v); }
// Integer threshold interval [lo, hi] (empty when hi < lo) of the test  a <= s < b.
struct Interval {
  int lo;
  int hi;
};

Interval ThresholdInterval(double a, double b) {
  return {static_cast<int>(std::ceil(a)), static_cast<int>(std::ceil(b)) - 1};
}

// Gray image padded to the bottom/right by the window reach, plus the two pair-test interval maps,
// all in padded coordinates (the image occupies rows [0, rows) and cols [0, cols)).
struct PaddedMaps {
  int rows = 0;  // padded size
  int cols = 0;
  std::vector<double> value;
  std::vector<Interval> vertical;    // pair (p, left neighbour)
  std::vector<Interval> horizontal;  // pair (p, upper neighbour)
};

// The gray image mirrored by `pad` pixels on every side (MATLAB 'symmetric'), for fast access.
class MirroredGray {
 public:
  MirroredGray(const cv::Mat& gray, int pad)
      : pad_(pad),
        cols_(gray.cols + 2 * pad),
        data_(static_cast<size_t>(gray.rows + 2 * pad) * cols_) {
    for (int r = 0; r < gray.rows + 2 * pad; ++r) {
      const double* src = gray.ptr<double>(Reflect(r - pad, gray.rows));
      double* dst = &data_[static_cast<size_t>(r) * cols_];
      for (int c = 0; c < cols_; ++c) dst[c] = src[Reflect(c - pad, gray.cols)];
    }
  }
  double operator()(int i, int j) const {
    return data_[static_cast<size_t>(i + pad_) * cols_ + (j + pad_)];
  }

 private:
  int pad_;
  int cols_;
  std::vector<double> data_;
};

PaddedMaps BuildMaps(VisibleEdgeVariant variant, const cv::Mat& gray) {
  const int nl = gray.rows;
  const int nc = gray.cols;
  const MirroredGray at(gray, kWindow);
  PaddedMaps maps;
  maps.rows = nl + kWindow - 1;
  maps.cols = nc + kWindow - 1;
  const size_t n = static_cast<size_t>(maps.rows) * maps.cols;
  maps.value.resize(n);
  maps.vertical.resize(n);
  maps.horizontal.resize(n);
  for (int r = 0; r < maps.rows; ++r) {
    for (int c = 0; c < maps.cols; ++c) {
      maps.value[static_cast<size_t>(r) * maps.cols + c] = at(r, c);
    }
  }
  // Pair-test maps in image coordinates (0-based i, j; off-image samples mirrored). The code pads
  // these maps themselves (mirror of the map, not map of the mirror) before the window loop, and
  // the paper variant keeps that padding so that it differs from the code only in the pair test.
  std::vector<Interval> v_img(static_cast<size_t>(nl) * nc), h_img(v_img.size());
  for (int i = 0; i < nl; ++i) {
    for (int j = 0; j < nc; ++j) {
      double g_min, g_max, h_min, h_max;
      if (variant == VisibleEdgeVariant::kIfsttar) {
        // imerode/imdilate(padarray(I,[3 3]), se, 'full') cropped at 3+(1:n): min over
        // {(i−1,j−2),(i−1,j−1)} and max over {(i−1,j−1),(i−1,j)} for the vertical test
        // (se_g = [0 0 0;1 1 0;0 0 0]); min over {(i−2,j−1),(i−1,j−1)} and max over
        // {(i−1,j−1),(i,j−1)} for the horizontal one (se_h = [0 1 0;0 1 0;0 0 0]).
        g_min = std::min(at(i - 1, j - 2), at(i - 1, j - 1));
        g_max = std::max(at(i - 1, j - 1), at(i - 1, j));
        h_min = std::min(at(i - 2, j - 1), at(i - 1, j - 1));
        h_max = std::max(at(i - 1, j - 1), at(i, j - 1));
      } else {
        // The paper: a threshold separates a pair when it lies between the pair's two values.
        g_min = std::min(at(i, j), at(i, j - 1));
        g_max = std::max(at(i, j), at(i, j - 1));
        h_min = std::min(at(i, j), at(i - 1, j));
        h_max = std::max(at(i, j), at(i - 1, j));
      }
      v_img[static_cast<size_t>(i) * nc + j] = ThresholdInterval(g_min, g_max);
      h_img[static_cast<size_t>(i) * nc + j] = ThresholdInterval(h_min, h_max);
    }
  }
  for (int r = 0; r < maps.rows; ++r) {
    for (int c = 0; c < maps.cols; ++c) {
      const size_t src = static_cast<size_t>(Reflect(r, nl)) * nc + Reflect(c, nc);
      maps.vertical[static_cast<size_t>(r) * maps.cols + c] = v_img[src];
      maps.horizontal[static_cast<size_t>(r) * maps.cols + c] = h_img[src];
    }
  }
  return maps;
}

double Weber(double s, double v) { return std::abs(s - v) / std::max(s, v); }

// Sobel magnitude with MATLAB imfilter(..., 'symmetric') borders (exact on integer data).
std::vector<double> SobelMagnitude(const cv::Mat& gray) {
  const int nl = gray.rows;
  const int nc = gray.cols;
  const MirroredGray at(gray, 1);
  std::vector<double> mag(static_cast<size_t>(nl) * nc);
  for (int i = 0; i < nl; ++i) {
    for (int j = 0; j < nc; ++j) {
      const double gy = at(i - 1, j - 1) + 2 * at(i - 1, j) + at(i - 1, j + 1) - at(i + 1, j - 1) -
                        2 * at(i + 1, j) - at(i + 1, j + 1);
      const double gx = at(i - 1, j - 1) + 2 * at(i, j - 1) + at(i + 1, j - 1) - at(i - 1, j + 1) -
                        2 * at(i, j + 1) - at(i + 1, j + 1);
      mag[static_cast<size_t>(i) * nc + j] = std::sqrt(gx * gx + gy * gy);
    }
  }
  return mag;
}

void CheckGray255(const cv::Mat& gray255) {
  if (gray255.empty()) throw Error("visible edges: empty image");
  if (gray255.type() != CV_64FC1) throw Error("visible edges: gray input must be CV_64FC1 0..255");
  for (int i = 0; i < gray255.rows; ++i) {
    const double* row = gray255.ptr<double>(i);
    for (int j = 0; j < gray255.cols; ++j) {
      if (!std::isfinite(row[j])) throw Error("visible edges: non-finite gray value");
    }
  }
}

}  // namespace

cv::Mat ReferenceOctaveRgbToGray(const cv::Mat& bgr8) {
  if (bgr8.empty() || bgr8.type() != CV_8UC3) {
    throw Error("OctaveRgbToGray: expected a non-empty 8-bit 3-channel BGR image");
  }
  // Octave's rgb2gray: im2double, then [R G B]·[0.298936; 0.587043; 0.114021], ×255 and the
  // uint8 cast (round half away from zero, saturating).
  std::array<double, 256> unit{};
  for (int k = 0; k < 256; ++k) unit[k] = k / 255.0;
  cv::Mat gray(bgr8.size(), CV_8UC1);
  for (int i = 0; i < bgr8.rows; ++i) {
    const uint8_t* src = bgr8.ptr<uint8_t>(i);
    uint8_t* dst = gray.ptr<uint8_t>(i);
    for (int j = 0; j < bgr8.cols; ++j) {
      const double b = unit[src[3 * j]];
      const double g = unit[src[3 * j + 1]];
      const double r = unit[src[3 * j + 2]];
      const double y = (r * 0.298936 + g * 0.587043 + b * 0.114021) * 255.0;
      dst[j] = static_cast<uint8_t>(std::clamp(std::round(y), 0.0, 255.0));
    }
  }
  return gray;
}

cv::Mat ReferenceToGray255(const cv::Mat& image, const std::string& what) {
  cv::Mat eight = ToEightBit(image, what);
  cv::Mat gray8 = eight.channels() == 3 ? ReferenceOctaveRgbToGray(eight) : eight;
  cv::Mat gray;
  gray8.convertTo(gray, CV_64F);
  return gray;
}

cv::Mat ReferenceVisibleEdgeMask(const VisibleEdgeOptions& options, const cv::Mat& gray255) {
  ThrowIfInvalid(options, "visible edges");
  CheckGray255(gray255);
  const int nl = gray255.rows;
  const int nc = gray255.cols;
  const PaddedMaps maps = BuildMaps(options.variant, gray255);
  const double half_threshold = options.visibility_threshold / 2.0;

  cv::Mat mask = cv::Mat::zeros(nl, nc, CV_8UC1);
  std::array<double, kMaxThreshold + 1> sum_vertical{};
  std::array<double, kMaxThreshold + 1> sum_horizontal{};
  std::array<int, kMaxThreshold + 1> count{};

  for (int r0 = 0; r0 < nl; r0 += kStep) {
    for (int c0 = 0; c0 < nc; c0 += kStep) {
      double lo_value = std::numeric_limits<double>::infinity();
      double hi_value = -lo_value;
      for (int nn = 0; nn < kWindow; ++nn) {
        const double* row = &maps.value[static_cast<size_t>(r0 + nn) * maps.cols + c0];
        for (int mm = 0; mm < kWindow; ++mm) {
          lo_value = std::min(lo_value, row[mm]);
          hi_value = std::max(hi_value, row[mm]);
        }
      }
      // Thresholds clamped to [1, 256] as in the code (s = 0 would only add zero contrasts).
      const int s_min = static_cast<int>(std::clamp(RoundHalfAway(lo_value), 1.0, 256.0));
      const int s_max = static_cast<int>(std::clamp(RoundHalfAway(hi_value), 1.0, 256.0));
      std::fill(sum_vertical.begin() + s_min, sum_vertical.begin() + s_max + 1, 0.0);
      std::fill(sum_horizontal.begin() + s_min, sum_horizontal.begin() + s_max + 1, 0.0);
      std::fill(count.begin() + s_min, count.begin() + s_max + 1, 0);

      for (int nn = 1; nn < kWindow; ++nn) {
        const int r = r0 + nn;
        for (int mm = 1; mm < kWindow; ++mm) {
          const int c = c0 + mm;
          const size_t k = static_cast<size_t>(r) * maps.cols + c;
          const double p = maps.value[k];
          const Interval v = maps.vertical[k];
          const double left = maps.value[k - 1];
          for (int s = std::max(v.lo, s_min), last = std::min(v.hi, s_max); s <= last; ++s) {
            sum_vertical[s] += std::min(Weber(s, p), Weber(s, left));
            ++count[s];
          }
          const Interval h = maps.horizontal[k];
          const double up = maps.value[k - maps.cols];
          for (int s = std::max(h.lo, s_min), last = std::min(h.hi, s_max); s <= last; ++s) {
            sum_horizontal[s] += std::min(Weber(s, p), Weber(s, up));
            ++count[s];
          }
        }
      }

      // First argmax of C over s (C is 0 below s_min and where no pair is separated).
      double best = 0.0;
      int s0 = s_min;
      for (int s = s_min; s <= s_max; ++s) {
        if (count[s] == 0) continue;
        const double contrast = (1.0 / count[s]) * (sum_vertical[s] + sum_horizontal[s]);
        if (contrast > best) {
          best = contrast;
          s0 = s;
        }
      }
      // The code tests C(s0) > percentage/2: the paper's visibility 2·C(s0) > 5 %.
      if (!(best > half_threshold)) continue;

      auto mark = [&](int r, int c) {
        if (r < nl && c < nc) mask.at<uint8_t>(r, c) = 255;
      };
      for (int nn = 1; nn < kWindow; ++nn) {
        const int r = r0 + nn;
        for (int mm = 1; mm < kWindow; ++mm) {
          const int c = c0 + mm;
          const size_t k = static_cast<size_t>(r) * maps.cols + c;
          const Interval v = maps.vertical[k];
          if (v.lo <= s0 && s0 <= v.hi) {
            mark(r, c);
            mark(r, c - 1);
          }
          const Interval h = maps.horizontal[k];
          if (h.lo <= s0 && s0 <= h.hi) {
            mark(r, c);
            mark(r - 1, c);
          }
        }
      }
    }
  }
  return mask;
}

VisibleEdgeResult ReferenceVisibleEdges(const VisibleEdgeOptions& options, const cv::Mat& original,
                                        const cv::Mat& restored) {
  ThrowIfInvalid(options, "visible edges");
  if (original.size() != restored.size()) {
    throw Error("visible edges: original is " + std::to_string(original.cols) + "x" +
                std::to_string(original.rows) + " but restored is " +
                std::to_string(restored.cols) + "x" + std::to_string(restored.rows));
  }
  const cv::Mat gray_o = ReferenceToGray255(original, "visible edges: original");
  const cv::Mat gray_r = ReferenceToGray255(restored, "visible edges: restored");
  const cv::Mat mask_o = ReferenceVisibleEdgeMask(options, gray_o);
  const cv::Mat mask_r = ReferenceVisibleEdgeMask(options, gray_r);
  const int nl = gray_r.rows;
  const int nc = gray_r.cols;

  VisibleEdgeResult result;
  result.variant = VisibleEdgeVariantName(options.variant);
  result.pixels = static_cast<int64_t>(nl) * nc;
  result.visible_original = cv::countNonZero(mask_o);
  result.visible_restored = cv::countNonZero(mask_r);
  // IEEE semantics on purpose: n_o = 0 gives +inf (or NaN when n_r = 0 too), as the code does.
  result.e = static_cast<double>(result.visible_restored - result.visible_original) /
             static_cast<double>(result.visible_original);

  // r̄: log ratios summed in MATLAB's column-major order; non-finite terms (a zero gradient on
  // either side) are dropped from the sum but the mean still divides by n_r, as the code does.
  const std::vector<double> grad_o = SobelMagnitude(gray_o);
  const std::vector<double> grad_r = SobelMagnitude(gray_r);
  double log_sum = 0.0;
  for (int j = 0; j < nc; ++j) {
    for (int i = 0; i < nl; ++i) {
      if (mask_r.at<uint8_t>(i, j) == 0) continue;
      const size_t k = static_cast<size_t>(i) * nc + j;
      const double term = std::log(grad_r[k] / grad_o[k]);
      if (std::isfinite(term)) {
        log_sum += term;
        ++result.finite_log_ratios;
      }
    }
  }
  result.r_mean = result.visible_restored > 0
                      ? std::exp((1.0 / static_cast<double>(result.visible_restored)) * log_sum)
                      : std::numeric_limits<double>::quiet_NaN();

  for (int i = 0; i < nl; ++i) {
    const double* row = gray_r.ptr<double>(i);
    for (int j = 0; j < nc; ++j) {
      result.black_pixels += row[j] == 0.0;
      result.white_pixels += row[j] == 255.0;
    }
  }
  const double pixels = static_cast<double>(result.pixels);
  // The code counts `R == 256 | R == 0`: on 8-bit data only black pixels.
  const int64_t saturated = options.variant == VisibleEdgeVariant::kIfsttar
                                ? result.black_pixels
                                : result.black_pixels + result.white_pixels;
  result.sigma = static_cast<double>(saturated) / pixels;
  result.m = static_cast<double>(result.black_pixels) / pixels;
  return result;
}

}  // namespace turbid::reference
