// Visible-edge indicators (Hautière et al. 2008). Design notes:
//
// The published code loops, for every 7×7 window (step 4), over every threshold s in
// [round(min), round(max)] and every pixel pair of the window: ~3 ms per pixel in Octave. Both of
// its pair tests have the form lo(p) <= s < hi(p) with lo/hi independent of s, so each pair is
// active on one integer interval of thresholds. We precompute those intervals once per image and,
// per window, add each pair's Weber contrast only at the thresholds where it is active. Each C(s)
// then receives exactly the same terms, in the same order (pairs in the code's row-major window
// order, vertical and horizontal sums kept apart), as in the published loops, so C(s), its first
// argmax and the visibility decision are bit-identical; the cost is the summed interval length
// instead of range × 72 tests.
//
// Gray images with 8-bit values (all that VisibleEdges() produces) take a faster path with the
// same decisions: a window whose contrast cannot exceed the threshold at all is skipped (every
// Weber term is at most (max − min) / max of the window; in the paper variant also at most
// 1 − √(lo/hi) of its pair, see WeakPairTest); the others are decided by
// metrics/visible_edge_search.h from contrast sums added in any order (cheaper, and shared between
// the overlapping windows of neighbouring columns and bands), and only where that decision is
// within rounding of a tie or of the threshold by the ordered sums of the published code (a table
// of the same |s − v| / max(s, v) quotients, four thresholds per SIMD step, 1 / count from a table
// of the same quotients), so that s0 and every visibility decision are those of the code. Windows
// go in row bands whose pair maps stay in cache. Gradients are computed only at mask pixels.
// tests/metrics/no_reference_fast_paths_test.cc checks masks and values bit for bit against the
// pre-optimisation implementation.
#include "metrics/visible_edges.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "core/error.h"
#include "metrics/simd_dispatch.h"
#include "metrics/visible_edge_search.h"
#include "metrics/visible_edges_mask8.h"

namespace turbid {
namespace {

using visible_edges::kMaxThreshold;
using visible_edges::kStep;
using visible_edges::kWindow;
using visible_edges::MirroredGray8;
using visible_edges::Reflect;
using visible_edges::VisibleEdgeMask8;

// MATLAB/Octave round: half away from zero.
double RoundHalfAway(double v) { return std::round(v); }

void CheckAccepted(const cv::Mat& image, const std::string& what) {
  if (image.empty()) throw Error(what + ": empty image");
  if (image.dims != 2) throw Error(what + ": expected a 2-D image");
  if (image.depth() != CV_8U && image.depth() != CV_32F) {
    throw Error(what + ": unsupported pixel type (expected 8-bit or float32 in [0,1])");
  }
  if (image.channels() != 1 && image.channels() != 3) {
    throw Error(what + ": expected 1 or 3 channels, got " + std::to_string(image.channels()));
  }
}

nlohmann::json JsonNumber(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

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

// The CV_8UC1 copy of a CV_64FC1 gray image when every value is an integer in [0, 255].
bool AsGray8(const cv::Mat& gray255, cv::Mat* gray8) {
  gray8->create(gray255.size(), CV_8UC1);
  for (int i = 0; i < gray255.rows; ++i) {
    const double* src = gray255.ptr<double>(i);
    uint8_t* dst = gray8->ptr<uint8_t>(i);
    for (int j = 0; j < gray255.cols; ++j) {
      const double v = src[j];
      if (!(v >= 0.0 && v <= 255.0)) return false;
      const int k = static_cast<int>(v);
      if (k != v) return false;
      dst[j] = static_cast<uint8_t>(k);
    }
  }
  return true;
}

// Gray (CV_8UC1) of any accepted input, as ToGray255() but without the double image.
cv::Mat ToGray8(const cv::Mat& image, const std::string& what) {
  cv::Mat eight = ToEightBit(image, what);
  return eight.channels() == 3 ? OctaveRgbToGray(eight) : eight;
}

// Sobel squared magnitude gx² + gy² at (i, j) of the image mirrored by 1 pixel: MATLAB
// imfilter(I, [1 2 1; 0 0 0; −1 −2 −1] and its transpose, 'symmetric'); integers, so exact.
// `up`, `mid` and `down` are rows i − 1, i and i + 1 of that mirrored image.
inline int SobelSquared(const uint8_t* up, const uint8_t* mid, const uint8_t* down, int j) {
  const int gy = up[j - 1] + 2 * up[j] + up[j + 1] - down[j - 1] - 2 * down[j] - down[j + 1];
  const int gx =
      up[j - 1] + 2 * mid[j - 1] + down[j - 1] - up[j + 1] - 2 * mid[j + 1] - down[j + 1];
  return gx * gx + gy * gy;
}

}  // namespace

std::string VisibleEdgeVariantName(VisibleEdgeVariant variant) {
  return variant == VisibleEdgeVariant::kIfsttar ? "ifsttar" : "paper";
}

VisibleEdgeVariant ParseVisibleEdgeVariant(const std::string& name) {
  if (name == "paper") return VisibleEdgeVariant::kPaper;
  if (name == "ifsttar") return VisibleEdgeVariant::kIfsttar;
  throw Error("visible edges: unknown variant '" + name + "' (expected paper or ifsttar)");
}

bool VisibleEdgeOptions::Check(std::string* why) const {
  if (variant != VisibleEdgeVariant::kPaper && variant != VisibleEdgeVariant::kIfsttar) {
    if (why) *why = "variant: unknown value";
    return false;
  }
  if (!(visibility_threshold > 0.0 && visibility_threshold <= 1.0)) {
    if (why) *why = "visibility_threshold must be in (0, 1]";
    return false;
  }
  return true;
}

nlohmann::json VisibleEdgeResult::ToJson() const {
  return {{"variant", variant},
          {"e", JsonNumber(e)},
          {"r_mean", JsonNumber(r_mean)},
          {"sigma", JsonNumber(sigma)},
          {"sigma_percent", JsonNumber(100.0 * sigma)},
          {"m", JsonNumber(m)},
          {"visible_original", visible_original},
          {"visible_restored", visible_restored},
          {"finite_log_ratios", finite_log_ratios},
          {"black_pixels", black_pixels},
          {"white_pixels", white_pixels},
          {"pixels", pixels}};
}

namespace {

#if defined(__x86_64__) && defined(__GNUC__)
#define TURBID_EIGHT_BIT_AVX2 1
// AVX2 without FMA: 255 * v + 0.5 rounds twice, as in the scalar code.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif
// ToEightBit's formula for one row of n floats, eight at a time with the same double operations
// (widening, product, sum, floor, clamp: all exact or rounded as in the scalar code). Returns
// false, with dst partly written, if a value is not finite.
bool EightBitRowAvx2(const float* src, int n, uint8_t* dst) {
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 infinity = _mm256_set1_ps(std::numeric_limits<float>::infinity());
  const __m256d scale = _mm256_set1_pd(255.0), half = _mm256_set1_pd(0.5);
  const __m256d lo = _mm256_setzero_pd(), hi = _mm256_set1_pd(255.0);
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    const __m256 v = _mm256_loadu_ps(src + j);
    const __m256 finite = _mm256_cmp_ps(_mm256_and_ps(v, abs_mask), infinity, _CMP_LT_OQ);
    if (_mm256_movemask_ps(finite) != 0xff) return false;
    auto quantise = [&](__m128 four) {
      const __m256d scaled =
          _mm256_floor_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_cvtps_pd(four), scale), half));
      return _mm256_cvttpd_epi32(_mm256_max_pd(_mm256_min_pd(scaled, hi), lo));
    };
    const __m128i words =
        _mm_packs_epi32(quantise(_mm256_castps256_ps128(v)), quantise(_mm256_extractf128_ps(v, 1)));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(dst + j), _mm_packus_epi16(words, words));
  }
  for (; j < n; ++j) {
    if (!std::isfinite(src[j])) return false;
    const double scaled = std::floor(255.0 * static_cast<double>(src[j]) + 0.5);
    dst[j] = static_cast<uint8_t>(std::clamp(scaled, 0.0, 255.0));
  }
  return true;
}
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif  // TURBID_EIGHT_BIT_AVX2

}  // namespace

cv::Mat ToEightBit(const cv::Mat& image, const std::string& what) {
  CheckAccepted(image, what);
  if (image.depth() == CV_8U) return image;
  cv::Mat out(image.size(), CV_MAKETYPE(CV_8U, image.channels()));
  const int width = image.cols * image.channels();
#ifdef TURBID_EIGHT_BIT_AVX2
  const bool avx2 = simd::ActiveSimdLevel() >= simd::SimdLevel::kAvx2;
#endif
  for (int i = 0; i < image.rows; ++i) {
    const float* src = image.ptr<float>(i);
    uint8_t* dst = out.ptr<uint8_t>(i);
#ifdef TURBID_EIGHT_BIT_AVX2
    // A row with a non-finite value falls through to the scalar loop, which throws.
    if (avx2 && EightBitRowAvx2(src, width, dst)) continue;
#endif
    for (int j = 0; j < width; ++j) {
      const float v = src[j];
      if (!std::isfinite(v)) throw Error(what + ": non-finite pixel value");
      const double scaled = std::floor(255.0 * static_cast<double>(v) + 0.5);
      dst[j] = static_cast<uint8_t>(std::clamp(scaled, 0.0, 255.0));
    }
  }
  return out;
}

cv::Mat OctaveRgbToGray(const cv::Mat& bgr8) {
  if (bgr8.empty() || bgr8.type() != CV_8UC3) {
    throw Error("OctaveRgbToGray: expected a non-empty 8-bit 3-channel BGR image");
  }
  // Octave's rgb2gray: im2double, then [R G B]·[0.298936; 0.587043; 0.114021], ×255 and the
  // uint8 cast (round half away from zero, saturating). In exact arithmetic that is the integer
  // rounding of (298936 R + 587043 G + 114021 B) / 10^6; the doubles stay within 1e-13 of it and
  // no colour lies within 1e-6 of a half, so the integer formula gives the same value for every
  // colour (checked over all 2^24 in tests/metrics/no_reference_fast_paths_test.cc against the
  // double formula).
  cv::Mat gray(bgr8.size(), CV_8UC1);
  for (int i = 0; i < bgr8.rows; ++i)
    simd::OctaveGrayU8(bgr8.ptr<uint8_t>(i), bgr8.cols, gray.ptr<uint8_t>(i));
  return gray;
}

cv::Mat ToGray255(const cv::Mat& image, const std::string& what) {
  cv::Mat eight = ToEightBit(image, what);
  cv::Mat gray8 = eight.channels() == 3 ? OctaveRgbToGray(eight) : eight;
  cv::Mat gray;
  gray8.convertTo(gray, CV_64F);
  return gray;
}

namespace {

// Per-threshold sums of one window of the double path (indices [s_min, s_max] in use).
struct WindowSums {
  std::array<double, kMaxThreshold + 1> vertical{};
  std::array<double, kMaxThreshold + 1> horizontal{};
  std::array<int, kMaxThreshold + 1> count{};
};

// The window at (r0, c0) of the double path: its threshold s0 (first argmax of C over s), or -1
// when C(s0) does not exceed half_threshold.
int SearchWindow(const PaddedMaps& maps, int r0, int c0, double half_threshold, WindowSums* sums) {
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
  auto& sum_vertical = sums->vertical;
  auto& sum_horizontal = sums->horizontal;
  auto& count = sums->count;
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
  return best > half_threshold ? s0 : -1;
}

// Marks both pixels of every pair of the window at (r0, c0) that s0 separates.
void MarkWindow(const PaddedMaps& maps, int r0, int c0, int s0, cv::Mat* mask) {
  const int nl = mask->rows, nc = mask->cols;
  auto mark = [&](int r, int c) {
    if (r < nl && c < nc) mask->at<uint8_t>(r, c) = 255;
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

}  // namespace

cv::Mat VisibleEdgeMask(const VisibleEdgeOptions& options, const cv::Mat& gray255) {
  ThrowIfInvalid(options, "visible edges");
  CheckGray255(gray255);
  if (cv::Mat gray8; AsGray8(gray255, &gray8)) return VisibleEdgeMask8(options, gray8);
  const int nl = gray255.rows;
  const int nc = gray255.cols;
  const PaddedMaps maps = BuildMaps(options.variant, gray255);
  const double half_threshold = options.visibility_threshold / 2.0;

  cv::Mat mask = cv::Mat::zeros(nl, nc, CV_8UC1);
  WindowSums sums;
  for (int r0 = 0; r0 < nl; r0 += kStep) {
    for (int c0 = 0; c0 < nc; c0 += kStep) {
      const int s0 = SearchWindow(maps, r0, c0, half_threshold, &sums);
      if (s0 >= 0) MarkWindow(maps, r0, c0, s0, &mask);
    }
  }
  return mask;
}

VisibleEdgeResult VisibleEdges(const VisibleEdgeOptions& options, const cv::Mat& original,
                               const cv::Mat& restored) {
  ThrowIfInvalid(options, "visible edges");
  CheckAccepted(original, "visible edges: original");
  CheckAccepted(restored, "visible edges: restored");
  if (original.size() != restored.size()) {
    throw Error("visible edges: original is " + std::to_string(original.cols) + "x" +
                std::to_string(original.rows) + " but restored is " +
                std::to_string(restored.cols) + "x" + std::to_string(restored.rows));
  }
  return VisibleEdges(options, AnalyseVisibleEdgeOriginal(options, original), restored);
}

VisibleEdgeOriginal AnalyseVisibleEdgeOriginal(const VisibleEdgeOptions& options,
                                               const cv::Mat& original) {
  ThrowIfInvalid(options, "visible edges");
  CheckAccepted(original, "visible edges: original");
  VisibleEdgeOriginal analysis;
  analysis.options = options;
  analysis.gray8 = ToGray8(original, "visible edges: original");
  analysis.mask = VisibleEdgeMask8(options, analysis.gray8);
  analysis.visible = cv::countNonZero(analysis.mask);
  return analysis;
}

namespace {

bool SameBytes(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  const size_t row_bytes = static_cast<size_t>(a.cols) * a.elemSize();
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a.ptr(y), b.ptr(y), row_bytes) != 0) return false;
  return true;
}

// r̄'s sum: log ratios summed in MATLAB's column-major order; non-finite terms (a zero gradient on
// either side) are dropped from the sum (and not counted in *finite) but the mean still divides by
// n_r, as the code does. The terms are computed in row order at the mask pixels only and bucketed
// by column (row order kept within a column), then summed bucket after bucket: column-major order.
double LogRatioSum(const cv::Mat& mask_r, const cv::Mat& gray_o, const cv::Mat& gray_r,
                   int64_t* finite) {
  const int nl = gray_r.rows;
  const int nc = gray_r.cols;
  const MirroredGray8 at_o(gray_o, 1), at_r(gray_r, 1);
  std::vector<int> column_start(nc + 1, 0);
  for (int i = 0; i < nl; ++i) {
    const uint8_t* m = mask_r.ptr<uint8_t>(i);
    for (int j = 0; j < nc; ++j) column_start[j + 1] += m[j] != 0;
  }
  for (int j = 0; j < nc; ++j) column_start[j + 1] += column_start[j];
  std::vector<double> terms(static_cast<size_t>(column_start[nc]));
  std::vector<int> next(column_start.begin(), column_start.end() - 1);
  for (int i = 0; i < nl; ++i) {
    const uint8_t* m = mask_r.ptr<uint8_t>(i);
    const uint8_t *r0 = at_r.Row(i - 1), *r1 = at_r.Row(i), *r2 = at_r.Row(i + 1);
    const uint8_t *o0 = at_o.Row(i - 1), *o1 = at_o.Row(i), *o2 = at_o.Row(i + 1);
    auto add_term = [&](int j) {
      const double grad_r = std::sqrt(static_cast<double>(SobelSquared(r0, r1, r2, j)));
      const double grad_o = std::sqrt(static_cast<double>(SobelSquared(o0, o1, o2, j)));
      terms[next[j]++] = std::log(grad_r / grad_o);
    };
    // Mask pixels in row order, 8 mask bytes at a time (most words are all zero).
    int j0 = 0;
    for (; j0 + 8 <= nc; j0 += 8) {
      uint64_t word;
      std::memcpy(&word, m + j0, 8);
      while (word != 0) {
        const int k = std::countr_zero(word) / 8;
        add_term(j0 + k);
        word &= ~(uint64_t{0xFF} << (8 * k));
      }
    }
    for (int j = j0; j < nc; ++j)
      if (m[j] != 0) add_term(j);
  }
  double log_sum = 0.0;
  for (const double term : terms) {
    if (std::isfinite(term)) {
      log_sum += term;
      ++*finite;
    }
  }
  return log_sum;
}

// Black (0) and white (255) pixels of an 8-bit gray image. Counted in locals (a store through a
// pointer per pixel would keep the loop from vectorising).
void CountSaturated(const cv::Mat& gray_r, int64_t* black_out, int64_t* white_out) {
  const int nl = gray_r.rows;
  const int nc = gray_r.cols;
  int64_t black = 0, white = 0;
  for (int i = 0; i < nl; ++i) {
    const uint8_t* row = gray_r.ptr<uint8_t>(i);
    int32_t row_black = 0, row_white = 0;
    for (int j = 0; j < nc; ++j) {
      row_black += row[j] == 0;
      row_white += row[j] == 255;
    }
    black += row_black;
    white += row_white;
  }
  *black_out = black;
  *white_out = white;
}

}  // namespace

VisibleEdgeResult VisibleEdges(const VisibleEdgeOptions& options,
                               const VisibleEdgeOriginal& original, const cv::Mat& restored) {
  ThrowIfInvalid(options, "visible edges");
  if (original.options.variant != options.variant ||
      original.options.visibility_threshold != options.visibility_threshold ||
      original.gray8.empty())
    throw Error("visible edges: the original was analysed with other options");
  CheckAccepted(restored, "visible edges: restored");
  const cv::Mat& gray_o = original.gray8;
  if (gray_o.size() != restored.size()) {
    throw Error("visible edges: original is " + std::to_string(gray_o.cols) + "x" +
                std::to_string(gray_o.rows) + " but restored is " + std::to_string(restored.cols) +
                "x" + std::to_string(restored.rows));
  }
  const cv::Mat gray_r = ToGray8(restored, "visible edges: restored");
  const cv::Mat mask_r =
      SameBytes(gray_r, gray_o) ? original.mask : VisibleEdgeMask8(options, gray_r);
  const int nl = gray_r.rows;
  const int nc = gray_r.cols;

  VisibleEdgeResult result;
  result.variant = VisibleEdgeVariantName(options.variant);
  result.pixels = static_cast<int64_t>(nl) * nc;
  result.visible_original = original.visible;
  result.visible_restored = cv::countNonZero(mask_r);
  // IEEE semantics on purpose: n_o = 0 gives +inf (or NaN when n_r = 0 too), as the code does.
  result.e = static_cast<double>(result.visible_restored - result.visible_original) /
             static_cast<double>(result.visible_original);

  const double log_sum = LogRatioSum(mask_r, gray_o, gray_r, &result.finite_log_ratios);
  result.r_mean = result.visible_restored > 0
                      ? std::exp((1.0 / static_cast<double>(result.visible_restored)) * log_sum)
                      : std::numeric_limits<double>::quiet_NaN();

  int64_t black = 0, white = 0;
  CountSaturated(gray_r, &black, &white);
  result.black_pixels = black;
  result.white_pixels = white;
  const double pixels = static_cast<double>(result.pixels);
  // The code counts `R == 256 | R == 0`: on 8-bit data only black pixels.
  const int64_t saturated = options.variant == VisibleEdgeVariant::kIfsttar
                                ? result.black_pixels
                                : result.black_pixels + result.white_pixels;
  result.sigma = static_cast<double>(saturated) / pixels;
  result.m = static_cast<double>(result.black_pixels) / pixels;
  return result;
}

}  // namespace turbid
