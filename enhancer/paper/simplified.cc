// `simplified` (§III-B): I_g + alpha (I_f - I_g), then CLAHE; streamed by rows for one and three
// channels.
#include "enhancer/paper/simplified.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/error.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/blocks/guided_segments.h"
#include "enhancer/method.h"
#include "enhancer/paper/full_internal.h"
#include "enhancer/paper/kernels.h"
#include "enhancer/paper/simplified_rows.h"
#include "enhancer/simd_switch.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace turbid {

using paper_internal::ClampUnit;
using paper_internal::Fail;

bool SimplifiedOptions::Check(std::string* why) const {
  if (fine_radius < 1 || fine_radius > 1000 || coarse_radius < 1 || coarse_radius > 1000) {
    return Fail(why, "fine_radius and coarse_radius must be in [1, 1000]");
  }
  if (!std::isfinite(fine_eps) || fine_eps <= 0 || !std::isfinite(coarse_eps) || coarse_eps <= 0) {
    return Fail(why, "fine_eps and coarse_eps must be > 0");
  }
  if (coarse_subsample < 1 || coarse_subsample > 8)
    return Fail(why, "coarse_subsample must be in [1, 8]");
  if (!std::isfinite(alpha) || alpha < 0 || alpha > 100)
    return Fail(why, "alpha must be in [0, 100]");
  std::string sub;
  if (!clahe.Check(&sub)) return Fail(why, "clahe: " + sub);
  return true;
}

namespace {

using paper_internal::AddWeightedRow;
using paper_internal::ClampRow;
using paper_internal::ClampUnitRow;
using paper_internal::CpuHasFma;
using paper_internal::DetailBoostRow;
#ifdef TURBID_HAVE_BOOST_AVX2
using paper_internal::BoostClampRowAvx2;
#endif

// One-channel `simplified`, streamed: both guided filters by rows, the detail boost per row, then
// straight into CLAHE's bin indices; no full-size float intermediates (each costs ~1 ms of page
// faults). The input's finiteness is not scanned up front: a non-finite input value makes the
// boosted rows around it non-finite, which the binning (or, without CLAHE, RowIsFinite) detects.
cv::Mat SimplifiedGray(const SimplifiedOptions& o, const GuidedFilterOptions& fine,
                       const GuidedFilterOptions& coarse, const cv::Mat& image) {
  const int w = image.cols;
  const float a = static_cast<float>(o.alpha), one_minus_a = static_cast<float>(1.0 - o.alpha);
  cv::Mat out, bins;
  std::vector<float> boosted;
  if (o.contrast) {
    bins = ClaheNewBins(o.clahe, image.size());
    boosted.resize(w);
  } else {
    out.create(image.size(), CV_32F);
  }
  GuidedFilterSelfRows({fine, coarse}, image, [&](int y, const std::vector<const float*>& q) {
    float* dst = o.contrast ? boosted.data() : out.ptr<float>(y);
    DetailBoostRow(q[0], q[1], a, one_minus_a, dst, w);
    if (o.contrast) {
      ClaheBinRow(o.clahe, dst, bins, y);  // clamps to [0, 1] as it bins; throws if not finite
    } else {
      if (!RowIsFinite(dst, static_cast<size_t>(w))) {
        throw Error("simplified: the detail layers have non-finite values");
      }
      ClampRow(dst, w);
    }
  });
  // CLAHE's output is in [0, 1] already.
  return o.contrast ? ClaheFromBins(o.clahe, bins) : out;
}

// Output images above this size are written with non-temporal stores (they do not stay in the
// last-level cache until CLAHE's pass reads them back; smaller ones do, and keep plain stores).
constexpr size_t kStreamBytes = size_t{8} << 20;

// Three-channel `simplified` with both filters exact (subsample 1): one segment-layout Input
// feeds both guided_segments streams (each input row transposed once); the boost, the clamp, the
// output row and CLAHE's luminance are one pass over the two segment rows (simplified_rows.h),
// then the luminance row is binned and the colour CLAHE runs in place.
cv::Mat SimplifiedColorSegments(const SimplifiedOptions& o, const cv::Mat& image) {
  cv::Mat out(image.size(), CV_32FC3), bins;
  if (o.contrast) bins = ClaheNewBins(o.clahe, image.size());
  const cv::Mat src = image.isContinuous() ? image : image.clone();
  guided_segments::Input input(src, std::max(o.fine_radius, o.coarse_radius));
  guided_segments::Stream fine(&input, o.fine_radius, static_cast<float>(o.fine_eps));
  guided_segments::Stream coarse(&input, o.coarse_radius, static_cast<float>(o.coarse_eps));
  guided_segments::Buffer lum;
  lum.Assign(fine.SegmentFloats() / 3);  // K L luminance values (K lanes)
  const simplified_internal::BoostOutFn boost_out = simplified_internal::ChosenBoostOut();
  simplified_internal::BoostOutArgs args;
  args.L = fine.L();
  args.lanes = fine.lanes();
  args.cols = image.cols;
  args.alpha = static_cast<float>(o.alpha);
  args.rgb = o.clahe.rgb;
  args.stream = out.total() * out.elemSize() > kStreamBytes;
  args.lum = o.contrast ? lum.data : nullptr;
  bool validated = false;
  for (int y = 0; y < image.rows; ++y) {
    args.i_f = fine.RowSegments(y);
    args.i_g = coarse.RowSegments(y);
    args.dst = out.ptr<float>(y);
    const bool finite = boost_out(args);
    if (!validated && !finite) {
      ValidateEnhanceImage(image, "simplified");
      validated = true;
    }
    if (o.contrast) ClaheBinRow(o.clahe, lum.data, bins, y);
  }
#if defined(__x86_64__)
  if (args.stream) _mm_sfence();  // the non-temporal stores ordered before CLAHE's reads
#endif
  if (o.contrast) ClaheColorFromBins(o.clahe, bins, out);  // in [0, 1]
  return out;
}

// Three-channel `simplified`, streamed as the gray path is: both guided filters interleaved by
// rows, the boost, the clamp and CLAHE's luminance binning per row into the output buffer, then
// the colour CLAHE in place. The input is scanned for non-finite values only when a boosted row
// is not finite (the up-front check's error then; a finite input that overflows is clamped).
cv::Mat SimplifiedColor(const SimplifiedOptions& o, const GuidedFilterOptions& fine,
                        const GuidedFilterOptions& coarse, const cv::Mat& image) {
  const int n = image.cols * 3;
  cv::Mat out(image.size(), CV_32FC3), bins;
  // Images too large to stay in the last-level cache until CLAHE's pass reads them back are
  // written with non-temporal stores (smaller ones: the pass finds them in cache).
  const bool stream = o.contrast && out.total() * out.elemSize() > kStreamBytes;
  std::vector<float> lum(image.cols), row(stream ? n : 0);
  if (o.contrast) bins = ClaheNewBins(o.clahe, image.size());
  bool validated = false;
  [[maybe_unused]] const bool avx2 = enhancer_internal::UseHandWrittenAvx2(), fma = CpuHasFma();
  GuidedFilterSelfRows({fine, coarse}, image, [&](int y, const std::vector<const float*>& q) {
    float* dst = out.ptr<float>(y);
    bool finite;
#ifdef TURBID_HAVE_BOOST_AVX2
    if (avx2) {
      float* next_dst = nullptr;
      float* stream_dst = nullptr;
      if (stream && reinterpret_cast<uintptr_t>(dst) % 32 == 0) {
        // CLAHE's binning reads the row from `row` (still in L1); the image row is written with
        // non-temporal stores (no read of its old contents).
        stream_dst = dst;
        dst = row.data();
      } else if (y + 1 < image.rows) {
        next_dst = out.ptr<float>(y + 1);  // fetched for writing while this row is boosted
      }
      finite = fma ? BoostClampRowAvx2<true>(q[1], q[0], 1.0 - o.alpha, o.alpha, dst, n, next_dst,
                                             stream_dst)
                   : BoostClampRowAvx2<false>(q[1], q[0], 1.0 - o.alpha, o.alpha, dst, n, next_dst,
                                              stream_dst);
    } else
#endif
    {
      AddWeightedRow(q[1], q[0], 1.0 - o.alpha, o.alpha, dst, n);
      finite = RowIsFinite(dst, static_cast<size_t>(n));
      ClampUnitRow(dst, n);
    }
    if (!validated && !finite) {
      ValidateEnhanceImage(image, "simplified");
      validated = true;
    }
    if (o.contrast) ClaheBinColorRow(o.clahe, dst, lum.data(), bins, y);
  });
#if defined(__x86_64__)
  _mm_sfence();  // the non-temporal stores ordered before CLAHE's reads
#endif
  if (o.contrast) ClaheColorFromBins(o.clahe, bins, out);  // in [0, 1]
  return out;
}

}  // namespace

cv::Mat SimplifiedEnhance(const SimplifiedOptions& o, const cv::Mat& image) {
  ThrowIfInvalid(o, "simplified");
  ValidateEnhanceImageLayout(image, "simplified");
  GuidedFilterOptions fine, coarse;
  fine.radius = o.fine_radius;
  fine.eps = o.fine_eps;
  coarse.radius = o.coarse_radius;
  coarse.eps = o.coarse_eps;
  coarse.subsample = o.coarse_subsample;
  if (image.channels() == 1) {
    try {
      return SimplifiedGray(o, fine, coarse, image);
    } catch (const Error&) {
      ValidateEnhanceImage(image, "simplified");  // a non-finite input: say where
      throw;
    }
  }
  if (image.channels() == 3) {
    if (o.coarse_subsample == 1) return SimplifiedColorSegments(o, image);
    return SimplifiedColor(o, fine, coarse, image);
  }
  ValidateEnhanceImage(image, "simplified");
  const cv::Mat i_f = GuidedFilterSelf(fine, image);
  const cv::Mat i_g = GuidedFilterSelf(coarse, image);
  cv::Mat out;
  cv::addWeighted(i_g, 1.0 - o.alpha, i_f, o.alpha, 0.0, out);  // I_g + alpha (I_f - I_g)
  ClampUnit(out);
  if (o.contrast) out = Clahe(o.clahe, out);
  ClampUnit(out);
  return out;
}

void ReportSimplifiedSteps(const SimplifiedOptions& o, const cv::Mat& image, StepSink& sink) {
  GuidedFilterOptions fine, coarse;
  fine.radius = o.fine_radius;
  fine.eps = o.fine_eps;
  coarse.radius = o.coarse_radius;
  coarse.eps = o.coarse_eps;
  coarse.subsample = o.coarse_subsample;
  const cv::Mat i_f = GuidedFilterSelf(fine, image);
  const cv::Mat i_g = GuidedFilterSelf(coarse, image);
  sink.Image("01_fine", i_f, true);
  sink.Image("02_coarse", i_g, true);
  cv::Mat boosted;
  cv::addWeighted(i_g, 1.0 - o.alpha, i_f, o.alpha, 0.0, boosted);  // I_g + alpha (I_f - I_g)
  ClampUnit(boosted);
  sink.Image("03_boosted", boosted, true);
}

}  // namespace turbid
