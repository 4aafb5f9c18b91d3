// SSIM and PSNR: ours against OpenCV (cv::quality::QualitySSIM, cv::PSNR) in one process.
// Args: {width, height, channels, threads}; cv::setNumThreads(threads) is applied to both sides.
// Counters: "value" = the score computed, so equal inputs can be checked for equal results.
//   bench_metrics --benchmark_filter=Ssim --benchmark_min_time=0.5
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/quality/qualitypsnr.hpp>
#include <opencv2/quality/qualityssim.hpp>

#include "metrics/full_reference.h"
#include "metrics/ssim.h"

namespace {

// A textured reference (smoothed noise, values in [lo, hi]) and a blurred, noisy copy (noise sd
// 6/255 of the range): realistic SSIM around 0.6-0.8. Float32, not quantised.
std::pair<cv::Mat, cv::Mat> MakeSmoothPair(int width, int height, int channels, double lo,
                                           double hi) {
  cv::RNG rng(12345);
  cv::Mat noise(height, width, CV_32FC(channels));
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 2.0);
  cv::normalize(smooth.reshape(1), smooth, lo, hi, cv::NORM_MINMAX);
  smooth = smooth.reshape(channels);
  cv::Mat blurred, extra(height, width, CV_32FC(channels));
  cv::GaussianBlur(smooth, blurred, cv::Size(0, 0), 1.2);
  rng.fill(extra, cv::RNG::NORMAL, 0.0, 6.0 / 255.0 * (hi - lo));
  return {smooth, blurred + extra};
}

// 8-bit: the 0..255 pair, saturated on conversion.
std::pair<cv::Mat, cv::Mat> MakePair(int width, int height, int channels) {
  const auto [ref, img] = MakeSmoothPair(width, height, channels, 0.0, 255.0);
  cv::Mat ref8, img8;
  ref.convertTo(ref8, CV_8U);
  img.convertTo(img8, CV_8U);
  return {ref8, img8};
}

// The same scene as float32 in [0, 1] without quantisation (what the harness scores: renders and
// enhancer outputs); AsKind makes the 16-bit copy.
std::pair<cv::Mat, cv::Mat> MakeFloatPair(int width, int height, int channels) {
  const auto [ref, img] = MakeSmoothPair(width, height, channels, 0.02, 0.98);
  return {ref, cv::min(cv::max(img, 0.0), 1.0)};
}

// Args' pixel kind: 0 = float32 [0, 1] (data range 1), 1 = 16-bit (range 65535).
cv::Mat AsKind(const cv::Mat& unit, int kind) {
  cv::Mat out = unit;
  if (kind == 1) unit.convertTo(out, CV_16U, 65535.0);
  return out;
}

void SetThreads(const benchmark::State& state) {
  cv::setNumThreads(static_cast<int>(state.range(3)));
}

// The timing loops shared by the 8-bit and float cases: our SSIM with `options`, and
// QualitySSIM's channel mean.
void TimeOurs(benchmark::State& state, const turbid::SsimOptions& options, const cv::Mat& ref,
              const cv::Mat& img) {
  SetThreads(state);
  double value = 0;
  for (auto _ : state) {
    value = turbid::Ssim(options, ref, img).mean;
    benchmark::DoNotOptimize(value);
  }
  state.counters["value"] = value;
  state.SetItemsProcessed(state.iterations() * ref.total());
}

void TimeQualitySsim(benchmark::State& state, const cv::Mat& ref, const cv::Mat& img) {
  SetThreads(state);
  double value = 0;
  for (auto _ : state) {
    const cv::Scalar s = cv::quality::QualitySSIM::compute(ref, img, cv::noArray());
    value = 0;
    for (int c = 0; c < ref.channels(); ++c) value += s[c] / ref.channels();
    benchmark::DoNotOptimize(value);
  }
  state.counters["value"] = value;
  state.SetItemsProcessed(state.iterations() * ref.total());
}

void BM_SsimOurs(benchmark::State& state) {
  const auto [ref, img] = MakePair(state.range(0), state.range(1), state.range(2));
  TimeOurs(state, {}, ref, img);
}

void BM_SsimOpenCvQuality(benchmark::State& state) {
  const auto [ref, img] = MakePair(state.range(0), state.range(1), state.range(2));
  TimeQualitySsim(state, ref, img);
}

// Float / 16-bit inputs (args: w, h, ch, threads, kind). exact_double = 1 times the plain
// double-precision path for comparison.
void BM_SsimOursFloat(benchmark::State& state) {
  const auto [unit_ref, unit_img] = MakeFloatPair(state.range(0), state.range(1), state.range(2));
  turbid::SsimOptions options;
  options.exact_double = state.range(5) != 0;
  TimeOurs(state, options, AsKind(unit_ref, state.range(4)), AsKind(unit_img, state.range(4)));
}

// QualitySSIM assumes the 0..255 range (its C1, C2): the same values scaled to 0..255, float32.
void BM_SsimOpenCvQualityFloat(benchmark::State& state) {
  const auto [unit_ref, unit_img] = MakeFloatPair(state.range(0), state.range(1), state.range(2));
  const double to_255 = state.range(4) == 1 ? 255.0 / 65535 : 255.0;
  cv::Mat ref, img;
  AsKind(unit_ref, state.range(4)).convertTo(ref, CV_32F, to_255);
  AsKind(unit_img, state.range(4)).convertTo(img, CV_32F, to_255);
  TimeQualitySsim(state, ref, img);
}

void FloatCases(benchmark::internal::Benchmark* b, bool with_exact) {
  for (int kind : {0, 1})
    for (int channels : {1, 3})
      for (int exact : {0, 1}) {
        if (exact && !with_exact) continue;
        if (exact && kind == 1) continue;
        b->Args({1360, 1024, channels, 1, kind, exact});
      }
  b->Args({1360, 1024, 3, 2, 0, 0});
  b->ArgNames({"w", "h", "ch", "threads", "kind", "exact"})->Unit(benchmark::kMillisecond);
}

void BM_PsnrOurs(benchmark::State& state) {
  const auto [ref, img] = MakePair(state.range(0), state.range(1), state.range(2));
  SetThreads(state);
  double value = 0;
  for (auto _ : state) {
    value = turbid::Psnr({}, ref, img);
    benchmark::DoNotOptimize(value);
  }
  state.counters["value"] = value;
  state.SetBytesProcessed(state.iterations() * 2 * ref.total() * ref.elemSize());
}

void BM_PsnrOpenCv(benchmark::State& state) {
  const auto [ref, img] = MakePair(state.range(0), state.range(1), state.range(2));
  SetThreads(state);
  double value = 0;
  for (auto _ : state) {
    value = cv::PSNR(ref, img, 255.0);
    benchmark::DoNotOptimize(value);
  }
  state.counters["value"] = value;
  state.SetBytesProcessed(state.iterations() * 2 * ref.total() * ref.elemSize());
}

// Memory-bandwidth yardstick: one read pass over both images (cv::sum of the absolute difference
// would also compute; this only touches the bytes).
void BM_MemoryReadBoth(benchmark::State& state) {
  const auto [ref, img] = MakePair(state.range(0), state.range(1), state.range(2));
  for (auto _ : state) {
    uint64_t sum = 0;
    const size_t n = ref.total() * ref.elemSize();
    const uint8_t* a = ref.data;
    const uint8_t* b = img.data;
    for (size_t i = 0; i < n; ++i) sum += a[i] ^ b[i];
    benchmark::DoNotOptimize(sum);
  }
  state.SetBytesProcessed(state.iterations() * 2 * ref.total() * ref.elemSize());
}

void SizesAndThreads(benchmark::internal::Benchmark* b) {
  for (int threads : {1, 2})
    for (int channels : {1, 3}) {
      b->Args({640, 480, channels, threads});
      b->Args({1360, 1024, channels, threads});
    }
  b->ArgNames({"w", "h", "ch", "threads"})->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_SsimOurs)->Apply(SizesAndThreads);
BENCHMARK(BM_SsimOpenCvQuality)->Apply(SizesAndThreads);
BENCHMARK(BM_SsimOursFloat)->Apply([](benchmark::internal::Benchmark* b) { FloatCases(b, true); });
BENCHMARK(BM_SsimOpenCvQualityFloat)->Apply([](benchmark::internal::Benchmark* b) {
  FloatCases(b, false);
});
BENCHMARK(BM_PsnrOurs)->Apply(SizesAndThreads);
BENCHMARK(BM_PsnrOpenCv)->Apply(SizesAndThreads);
BENCHMARK(BM_MemoryReadBoth)->Args({1360, 1024, 3, 1})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
