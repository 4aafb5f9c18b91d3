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

// A textured reference (smoothed noise) and a blurred, noisy copy: realistic SSIM around 0.6-0.8.
std::pair<cv::Mat, cv::Mat> MakePair(int width, int height, int channels) {
  cv::RNG rng(12345);
  cv::Mat noise(height, width, CV_32FC(channels));
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 255.0);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 2.0);
  cv::normalize(smooth.reshape(1), smooth, 0, 255, cv::NORM_MINMAX);
  smooth = smooth.reshape(channels);
  cv::Mat blurred, extra(height, width, CV_32FC(channels));
  cv::GaussianBlur(smooth, blurred, cv::Size(0, 0), 1.2);
  rng.fill(extra, cv::RNG::NORMAL, 0.0, 6.0);
  cv::Mat ref8, img8;
  smooth.convertTo(ref8, CV_8U);
  cv::Mat(blurred + extra).convertTo(img8, CV_8U);
  return {ref8, img8};
}

void SetThreads(const benchmark::State& state) { cv::setNumThreads(static_cast<int>(state.range(3))); }

void BM_SsimOurs(benchmark::State& state) {
  const auto [ref, img] = MakePair(state.range(0), state.range(1), state.range(2));
  SetThreads(state);
  double value = 0;
  for (auto _ : state) {
    value = turbid::Ssim({}, ref, img).mean;
    benchmark::DoNotOptimize(value);
  }
  state.counters["value"] = value;
  state.SetItemsProcessed(state.iterations() * ref.total());
}

void BM_SsimOpenCvQuality(benchmark::State& state) {
  const auto [ref, img] = MakePair(state.range(0), state.range(1), state.range(2));
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
BENCHMARK(BM_PsnrOurs)->Apply(SizesAndThreads);
BENCHMARK(BM_PsnrOpenCv)->Apply(SizesAndThreads);
BENCHMARK(BM_MemoryReadBoth)->Args({1360, 1024, 3, 1})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
