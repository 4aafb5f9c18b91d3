// Enhancer speed at 1360x1024 gray on one core (cv::setNumThreads(1) for ours and the peers):
// guided filter vs cv::ximgproc::guidedFilter at equal output, CLAHE vs cv::CLAHE (8-bit, uniform),
// and the full / simplified methods end to end. docs/performance-enhancer.md has the figures.
#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>

#include "enhancer/blocks/clahe.h"
#include "enhancer/blocks/guided_filter.h"
#include "enhancer/paper/full.h"
#include "enhancer/paper/simplified.h"

namespace {

const cv::Mat& Image() {
  static const cv::Mat img = [] {
    cv::setNumThreads(1);
    cv::Mat m(1024, 1360, CV_32F);
    cv::RNG(1).fill(m, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::GaussianBlur(m, m, cv::Size(0, 0), 2.0);
    cv::normalize(m, m, 0.1, 0.9, cv::NORM_MINMAX);
    return m;
  }();
  return img;
}

void BM_GuidedFilter_Ours(benchmark::State& state) {
  const cv::Mat& img = Image();
  turbid::GuidedFilterOptions o;
  o.radius = static_cast<int>(state.range(0));
  o.eps = 0.01;
  for (auto _ : state) benchmark::DoNotOptimize(turbid::GuidedFilter(o, img, img));
}
BENCHMARK(BM_GuidedFilter_Ours)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kMillisecond);

void BM_GuidedFilter_Ximgproc(benchmark::State& state) {
  const cv::Mat& img = Image();
  cv::Mat out;
  for (auto _ : state) {
    cv::ximgproc::guidedFilter(img, img, out, static_cast<int>(state.range(0)), 0.01, CV_32F);
    benchmark::DoNotOptimize(out.data);
  }
}
BENCHMARK(BM_GuidedFilter_Ximgproc)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kMillisecond);

void BM_Clahe_Ours(benchmark::State& state) {
  const cv::Mat& img = Image();
  turbid::ClaheOptions o;
  o.distribution = state.range(0) ? turbid::ClaheDistribution::kRayleigh
                                  : turbid::ClaheDistribution::kUniform;
  for (auto _ : state) benchmark::DoNotOptimize(turbid::Clahe(o, img));
}
BENCHMARK(BM_Clahe_Ours)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// OpenCV's CLAHE works on 8-bit input; the conversions are counted, as a float pipeline needs them.
void BM_Clahe_OpenCv(benchmark::State& state) {
  const cv::Mat& img = Image();
  cv::Ptr<cv::CLAHE> clahe = cv::createCLAHE(2.56, cv::Size(8, 8));
  cv::Mat u8, out, f;
  for (auto _ : state) {
    img.convertTo(u8, CV_8U, 255.0);
    clahe->apply(u8, out);
    out.convertTo(f, CV_32F, 1.0 / 255.0);
    benchmark::DoNotOptimize(f.data);
  }
}
BENCHMARK(BM_Clahe_OpenCv)->Unit(benchmark::kMillisecond);

void BM_Full(benchmark::State& state) {
  const cv::Mat& img = Image();
  turbid::FullOptions o;
  for (auto _ : state) benchmark::DoNotOptimize(turbid::FullEnhance(o, img, nullptr, nullptr));
}
BENCHMARK(BM_Full)->Unit(benchmark::kMillisecond);

void BM_Simplified(benchmark::State& state) {
  const cv::Mat& img = Image();
  turbid::SimplifiedOptions o;
  for (auto _ : state) benchmark::DoNotOptimize(turbid::SimplifiedEnhance(o, img));
}
BENCHMARK(BM_Simplified)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
