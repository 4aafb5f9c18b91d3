// Dark channel prior (He, Sun, Tang, TPAMI 2011) and its underwater variant over G and B only
// (Drews et al., ICCV Workshops 2013). See enhancer/baselines/dcp.h.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "enhancer/baselines/dcp.h"
#include "enhancer/baselines/common.h"
#include "core/error.h"
#include "core/row_kernel.h"
#include "simulator/image_pool.h"

namespace turbid {
namespace {

using baselines_internal::GuidedSmooth;
using baselines_internal::IsOddPositive;
using baselines_internal::MinFilter;
using baselines_internal::RecoverRadiance;
using baselines_internal::ValidateImage;

// A channel of the airlight this small is treated as this value, so I/A stays finite on black
// input.
constexpr float kMinAirlight = 1e-6f;

// Per-pixel minimum of I^c / A^c over B, G (and R unless skip_red), He 2011 eq. 11 before the
// patch minimum; min with FLT_MAX first, as the definition's running minimum starts there.
TURBID_ROW_KERNEL void NormalisedMinRow3(const float* __restrict in, float a0, float a1, float a2,
                                         bool skip_red, float* __restrict out, int w) {
  constexpr float kMax = std::numeric_limits<float>::max();
  if (skip_red) {
    for (int x = 0; x < w; ++x)
      out[x] = std::min(std::min(kMax, in[3 * x] / a0), in[3 * x + 1] / a1);
  } else {
    for (int x = 0; x < w; ++x) {
      out[x] = std::min(std::min(std::min(kMax, in[3 * x] / a0), in[3 * x + 1] / a1),
                        in[3 * x + 2] / a2);
    }
  }
}

TURBID_ROW_KERNEL void DivideRow(const float* __restrict in, float a, float* __restrict out,
                                 int w) {
  constexpr float kMax = std::numeric_limits<float>::max();
  for (int x = 0; x < w; ++x) out[x] = std::min(kMax, in[x] / a);
}

TURBID_ROW_KERNEL void ChannelMinRow(const float* __restrict in, bool skip_red,
                                     float* __restrict out, int w) {
  if (skip_red) {
    for (int x = 0; x < w; ++x) out[x] = std::min(in[3 * x], in[3 * x + 1]);
  } else {
    for (int x = 0; x < w; ++x)
      out[x] = std::min(std::min(in[3 * x], in[3 * x + 1]), in[3 * x + 2]);
  }
}

// How many of v[0..n) are >= g.
TURBID_ROW_KERNEL int CountAtLeast(const float* __restrict v, int n, float g) {
  int count = 0;
  for (int i = 0; i < n; ++i) count += v[i] >= g ? 1 : 0;
  return count;
}

// min over the patch of min_c I^c / A^c (He 2011 eq. 12's double minimum), colour images. Gray
// ones need no second minimum filter: division by a positive constant is monotone in float too,
// so the patch minimum of I / A is the dark channel divided by A, value for value
// (RawTransmission divides it row by row).
cv::Mat NormalisedDarkChannel(const cv::Mat& image, const cv::Vec3f& airlight, bool skip_red,
                              int patch_size) {
  cv::Mat out = internal::PooledMat(image.size(), CV_32FC1);
  const float a0 = std::max(airlight[0], kMinAirlight);
  const float a1 = std::max(airlight[1], kMinAirlight), a2 = std::max(airlight[2], kMinAirlight);
  for (int y = 0; y < image.rows; ++y) {
    NormalisedMinRow3(image.ptr<float>(y), a0, a1, a2, skip_red, out.ptr<float>(y), image.cols);
  }
  return MinFilter(out, patch_size);
}

// t = clamp(1 - ω m, 0, 1) into `raw` (one channel), in blocks of >= 16 rows while they are in
// cache: per block, m's rows (the gray dark channel over A, formed here, or the rows of the given
// colour map), then cv::Mat::convertTo with α = -ω, β = 1 — the expression 1.0 - ω m evaluates to
// that call, and its vector loop covers every value of a block of >= 16 values (it overlaps the
// last vector rather than finishing with scalar code), so each value is the whole-image
// expression's — then the clamp.
void RawTransmission(const cv::Mat& image, const cv::Mat& dark, float a0, const cv::Mat& colour_m,
                     double omega, cv::Mat& raw) {
  const int h = image.rows, w = image.cols;
  constexpr int kBlockRows = 16;
  const bool gray = image.channels() == 1;
  cv::Mat scratch;
  if (gray) scratch.create(std::min(h, 2 * kBlockRows), w, CV_32FC1);
  for (int y0 = 0; y0 < h;) {
    const int rows = h - y0 < 2 * kBlockRows ? h - y0 : kBlockRows;  // the last block: the rest
    cv::Mat m;
    if (gray) {
      m = scratch.rowRange(0, rows);
      for (int i = 0; i < rows; ++i) DivideRow(dark.ptr<float>(y0 + i), a0, m.ptr<float>(i), w);
    } else {
      m = colour_m.rowRange(y0, y0 + rows);
    }
    cv::Mat out = raw.rowRange(y0, y0 + rows);
    m.convertTo(out, CV_32F, -omega, 1.0);
    for (int i = 0; i < rows; ++i)
      baselines_internal::ClampRangeRow(out.ptr<float>(i), 0.0f, 1.0f, w);
    y0 += rows;
  }
}

DcpResult RunDarkChannelPrior(const DcpOptions& options, const cv::Mat& image, bool underwater,
                              const std::string& method) {
  ValidateImage(image, method);
  ThrowIfInvalid(options, method);
  DcpResult result;
  result.dark_channel = DarkChannel(image, options.patch_size, underwater);
  result.airlight_pixel =
      EstimateAirlight(image, result.dark_channel, options.airlight_fraction, &result.airlight);
  // He 2011 eq. 12: t = 1 - ω min_Ω min_c I^c / A^c. Clamped to [0,1]: where a pixel is brighter
  // than A the estimate goes negative, which no transmission can be. (RawTransmission keeps
  // OpenCV's evaluation of 1 - ω m, an FMA where the CPU has one, so the values stay the same.)
  result.raw_transmission = internal::PooledMat(image.size(), CV_32FC1);
  const float a0 = std::max(result.airlight[0], kMinAirlight);
  const cv::Mat colour_m =
      image.channels() == 1
          ? cv::Mat()
          : NormalisedDarkChannel(image, result.airlight, underwater, options.patch_size);
  RawTransmission(image, result.dark_channel, a0, colour_m, options.omega, result.raw_transmission);
  if (options.refine && image.channels() == 1) {
    // The clamp and the radiance recovery (He 2011 eq. 22) of each refined row as soon as the
    // guided filter has written it (the same arithmetic as ClampRange and RecoverRadiance).
    result.image = internal::PooledMat(image.size(), image.type());
    const float floor = static_cast<float>(options.t0);
    result.transmission =
        GuidedSmooth(image, result.raw_transmission, options.guided_radius, options.guided_eps,
                     [&](int y, float* t) {
                       baselines_internal::ClampRangeRow(t, 0.0f, 1.0f, image.cols);
                       baselines_internal::RecoverRadianceRow(
                           image.ptr<float>(y), t, image.channels(), result.airlight, floor,
                           result.image.ptr<float>(y), image.cols);
                     });
  } else {
    // (A colour guide filters the whole image before any row is out: nothing to gain per row.)
    if (options.refine) {
      result.transmission =
          GuidedSmooth(image, result.raw_transmission, options.guided_radius, options.guided_eps);
      baselines_internal::ClampRange(result.transmission, 0.0f, 1.0f);
    } else {
      result.transmission = result.raw_transmission.clone();
    }
    result.image = RecoverRadiance(image, result.transmission, result.airlight, options.t0);
  }
  return result;
}

}  // namespace

bool DcpOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (!IsOddPositive(patch_size)) return fail("patch_size must be an odd integer >= 1");
  if (!(omega > 0.0 && omega <= 1.0)) return fail("omega must be in (0, 1]");
  if (!(t0 > 0.0 && t0 <= 1.0)) return fail("t0 must be in (0, 1]");
  if (!(airlight_fraction > 0.0 && airlight_fraction <= 1.0)) {
    return fail("airlight_fraction must be in (0, 1]");
  }
  if (guided_radius < 1) return fail("guided_radius must be >= 1");
  if (!(guided_eps > 0.0) || !std::isfinite(guided_eps)) return fail("guided_eps must be > 0");
  return true;
}

cv::Mat DarkChannel(const cv::Mat& image, int patch_size, bool skip_red) {
  CV_Assert(image.depth() == CV_32F && (image.channels() == 1 || image.channels() == 3));
  if (image.channels() == 1) return MinFilter(image, patch_size);
  cv::Mat channel_min = internal::PooledMat(image.size(), CV_32FC1);
  for (int y = 0; y < image.rows; ++y) {
    ChannelMinRow(image.ptr<float>(y), skip_red, channel_min.ptr<float>(y), image.cols);
  }
  return MinFilter(channel_min, patch_size);
}

cv::Point EstimateAirlight(const cv::Mat& image, const cv::Mat& prior, double fraction,
                           cv::Vec3f* airlight) {
  CV_Assert(prior.type() == CV_32FC1 && prior.size() == image.size() && prior.isContinuous());
  const int total = static_cast<int>(prior.total());
  const int count = std::clamp(static_cast<int>(std::ceil(fraction * total)), 1, total);
  const float* p = prior.ptr<float>();
  // The `count` brightest pixels (ties: the lower index first) are a fixed set; only it is
  // searched. It lies among the pixels at or above any value g that at least `count` pixels
  // reach, so a g read from every 16th row (at the rank that leaves about twice `count` above;
  // whole rows, so that the sample reads 1/16 of the map's cache lines, not all of them) narrows
  // the sort to those; when too few reach g, all pixels are sorted.
  std::vector<int> order;
  constexpr int kStride = 16;
  const int rows = prior.rows, cols = prior.cols;
  if (rows >= 4 * kStride && total >= 64 * kStride && count <= total / (4 * kStride)) {
    std::vector<float> sample;
    sample.reserve(static_cast<size_t>((rows + kStride - 1) / kStride) * cols);
    for (int y = 0; y < rows; y += kStride)
      sample.insert(sample.end(), p + static_cast<size_t>(y) * cols,
                    p + static_cast<size_t>(y + 1) * cols);
    const size_t rank =
        std::min(sample.size() - 1,
                 static_cast<size_t>(2.0 * count * static_cast<double>(sample.size()) / total) + 1);
    std::nth_element(sample.begin(), sample.begin() + rank, sample.end(), std::greater<float>());
    const float g = sample[rank];
    // Blocks of 64 with no value at or above g (almost all) are skipped after one vector count.
    constexpr int kBlock = 64;
    int i = 0;
    for (; i + kBlock <= total; i += kBlock) {
      if (CountAtLeast(p + i, kBlock, g) == 0) continue;
      for (int j = i; j < i + kBlock; ++j) {
        if (p[j] >= g) order.push_back(j);
      }
    }
    for (; i < total; ++i) {
      if (p[i] >= g) order.push_back(i);
    }
    if (static_cast<int>(order.size()) < count) order.clear();
  }
  if (order.empty()) {
    order.resize(total);
    std::iota(order.begin(), order.end(), 0);
  }
  auto brighter = [p](int a, int b) { return p[a] > p[b] || (p[a] == p[b] && a < b); };
  std::nth_element(order.begin(), order.begin() + (count - 1), order.end(), brighter);
  const int channels = image.channels();
  int best = -1;
  float best_sum = -1.0f;
  for (int i = 0; i < count; ++i) {
    const int index = order[i];
    const float* px = image.ptr<float>(index / image.cols) + (index % image.cols) * channels;
    float sum = 0.0f;
    for (int c = 0; c < channels; ++c) sum += px[c];
    if (sum > best_sum || (sum == best_sum && index < best)) {
      best_sum = sum;
      best = index;
    }
  }
  const cv::Point at(best % image.cols, best / image.cols);
  const float* px = image.ptr<float>(at.y) + at.x * channels;
  for (int c = 0; c < 3; ++c) (*airlight)[c] = px[channels == 3 ? c : 0];
  return at;
}

DcpResult DarkChannelPriorDetailed(const DcpOptions& options, const cv::Mat& image) {
  return RunDarkChannelPrior(options, image, /*underwater=*/false, "dcp");
}

cv::Mat DarkChannelPrior(const DcpOptions& options, const cv::Mat& image) {
  return DarkChannelPriorDetailed(options, image).image;
}

DcpResult UnderwaterDarkChannelPriorDetailed(const UdcpOptions& options, const cv::Mat& image) {
  return RunDarkChannelPrior(options, image, /*underwater=*/true, "udcp");
}

cv::Mat UnderwaterDarkChannelPrior(const UdcpOptions& options, const cv::Mat& image) {
  return UnderwaterDarkChannelPriorDetailed(options, image).image;
}

}  // namespace turbid
