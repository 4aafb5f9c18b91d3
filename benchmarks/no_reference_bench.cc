// No-reference metrics: time per image for the visible-edge indicators (both variants), UIQM and
// UCIQE at 640×480 and 1360×1024 (the source paper's two image sizes). There is no fast published
// peer: the published visible-edge code is an Octave/MATLAB triple loop (≈ 3 ms per pixel per
// image pair in Octave, reference README). As an in-process peer we time a direct C++
// transcription of that loop (per window, every threshold s × every pixel pair, explicit Fcube),
// which gives the same mask as ours (tests/metrics/no_reference_visible_edges_test.cc).
//   ./build-nr/benchmarks/bench_no_reference --benchmark_min_time=1
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "metrics/no_reference.h"

namespace turbid {
namespace {

// Deterministic textured scene (edges at several contrasts, smooth shading, noise) and a hazy
// version of it (contrast × 0.55 towards a veil of 190), 8-bit BGR or gray.
cv::Mat Scene(int width, int height, bool colour, bool hazy) {
  cv::Mat img(height, width, colour ? CV_8UC3 : CV_8UC1);
  cv::RNG rng(12345);
  for (int i = 0; i < height; ++i) {
    for (int j = 0; j < width; ++j) {
      const double shade = 60 + 40 * std::sin(i * 0.02) * std::cos(j * 0.015);
      const double tiles = (((i / 37) + (j / 53)) % 3) * 45.0;
      const double stripes = ((j / 7) % 2) * 12.0;
      for (int c = 0; c < img.channels(); ++c) {
        double v = shade + tiles + stripes + c * 15 + rng.gaussian(4.0);
        if (hazy) v = 0.55 * v + 0.45 * 190;
        img.ptr<uint8_t>(i)[j * img.channels() + c] = cv::saturate_cast<uint8_t>(v);
      }
    }
  }
  return img;
}

int Width(const benchmark::State& state) { return static_cast<int>(state.range(0)); }
int Height(const benchmark::State& state) { return static_cast<int>(state.range(1)); }

void VisibleEdgesBench(benchmark::State& state, VisibleEdgeVariant variant) {
  const cv::Mat original = Scene(Width(state), Height(state), false, true);
  const cv::Mat restored = Scene(Width(state), Height(state), false, false);
  VisibleEdgeOptions options;
  options.variant = variant;
  VisibleEdgeResult r;
  for (auto _ : state) benchmark::DoNotOptimize(r = VisibleEdges(options, original, restored));
  state.counters["e"] = r.e;
  state.counters["r_mean"] = r.r_mean;
  state.counters["pixels"] = static_cast<double>(r.pixels);
}

void BM_VisibleEdgesIfsttar(benchmark::State& state) {
  VisibleEdgesBench(state, VisibleEdgeVariant::kIfsttar);
}
void BM_VisibleEdgesPaper(benchmark::State& state) {
  VisibleEdgesBench(state, VisibleEdgeVariant::kPaper);
}

// The published loop, transcribed (ifsttar maps): per window, for s in [round(min), round(max)]
// test all 2×36 pairs and keep a Fcube slice; mask of the first argmax when 2·C > 5 %.
cv::Mat PublishedLoopMask(const cv::Mat& gray) {
  const int nl = gray.rows, nc = gray.cols, S = 7;
  auto refl = [](int i, int n) {
    const int k = ((i % (2 * n)) + 2 * n) % (2 * n);
    return k < n ? k : 2 * n - 1 - k;
  };
  auto I = [&](int i, int j) { return gray.at<double>(refl(i, nl), refl(j, nc)); };
  cv::Mat gmin(nl, nc, CV_64F), gmax(nl, nc, CV_64F), hmin(nl, nc, CV_64F), hmax(nl, nc, CV_64F);
  for (int i = 0; i < nl; ++i) {
    for (int j = 0; j < nc; ++j) {
      gmin.at<double>(i, j) = std::min(I(i - 1, j - 2), I(i - 1, j - 1));
      gmax.at<double>(i, j) = std::max(I(i - 1, j - 1), I(i - 1, j));
      hmin.at<double>(i, j) = std::min(I(i - 2, j - 1), I(i - 1, j - 1));
      hmax.at<double>(i, j) = std::max(I(i - 1, j - 1), I(i, j - 1));
    }
  }
  auto M = [&](const cv::Mat& m, int i, int j) { return m.at<double>(refl(i, nl), refl(j, nc)); };
  cv::Mat mask = cv::Mat::zeros(nl + S, nc + S, CV_8UC1);
  std::vector<cv::Mat> cube;
  for (int ii = 0; ii < nl; ii += 4) {
    for (int jj = 0; jj < nc; jj += 4) {
      double lo = 1e9, hi = -1e9;
      for (int a = 0; a < S; ++a) {
        for (int b = 0; b < S; ++b) {
          lo = std::min(lo, I(ii + a, jj + b));
          hi = std::max(hi, I(ii + a, jj + b));
        }
      }
      const int smin = std::clamp(static_cast<int>(std::round(lo)), 1, 256);
      const int smax = std::clamp(static_cast<int>(std::round(hi)), 1, 256);
      std::vector<double> C(smax + 1, 0.0);
      cube.assign(smax - smin + 1, cv::Mat());
      for (int s = smin; s <= smax; ++s) {
        cv::Mat f = cv::Mat::zeros(S, S, CV_8UC1);
        int F = 0;
        double sg = 0, sh = 0;
        for (int nn = 1; nn < S; ++nn) {
          for (int mm = 1; mm < S; ++mm) {
            const int i = ii + nn, j = jj + mm;
            auto w = [&](double v) { return std::abs(s - v) / std::max<double>(s, v); };
            if (M(gmin, i, j) <= s && M(gmax, i, j) > s) {
              sg += std::min(w(I(i, j)), w(I(i, j - 1)));
              ++F;
              f.at<uint8_t>(nn, mm) = f.at<uint8_t>(nn, mm - 1) = 1;
            }
            if (M(hmin, i, j) <= s && M(hmax, i, j) > s) {
              sh += std::min(w(I(i, j)), w(I(i - 1, j)));
              ++F;
              f.at<uint8_t>(nn, mm) = f.at<uint8_t>(nn - 1, mm) = 1;
            }
          }
        }
        if (F > 0) C[s] = (1.0 / F) * (sg + sh);
        cube[s - smin] = f;
      }
      int s0 = 1;
      for (int s = 1; s <= smax; ++s) {
        if (C[s] > C[s0]) s0 = s;
      }
      s0 = std::max(s0, smin);
      if (C[s0] > 0.025) mask(cv::Rect(jj, ii, S, S)).setTo(255, cube[s0 - smin]);
    }
  }
  return mask(cv::Rect(0, 0, nc, nl)).clone();
}

// Mask only (one image), ours vs the transcribed loop: the ratio is the algorithmic speed-up.
void BM_VisibleEdgeMaskOurs(benchmark::State& state) {
  const cv::Mat gray = ToGray255(Scene(Width(state), Height(state), false, false), "bench");
  VisibleEdgeOptions options;
  options.variant = VisibleEdgeVariant::kIfsttar;
  for (auto _ : state) benchmark::DoNotOptimize(VisibleEdgeMask(options, gray));
}
void BM_VisibleEdgeMaskPublishedLoop(benchmark::State& state) {
  const cv::Mat gray = ToGray255(Scene(Width(state), Height(state), false, false), "bench");
  for (auto _ : state) benchmark::DoNotOptimize(PublishedLoopMask(gray));
}

void BM_Uiqm(benchmark::State& state) {
  const cv::Mat image = Scene(Width(state), Height(state), true, false);
  UiqmResult r;
  for (auto _ : state) benchmark::DoNotOptimize(r = Uiqm({}, image));
  state.counters["uiqm"] = r.uiqm;
}

void BM_Uciqe(benchmark::State& state) {
  const cv::Mat image = Scene(Width(state), Height(state), true, false);
  UciqeResult r;
  for (auto _ : state) benchmark::DoNotOptimize(r = Uciqe({}, image));
  state.counters["uciqe"] = r.uciqe;
}

#define SIZES ->Args({640, 480})->Args({1360, 1024})->Unit(benchmark::kMillisecond)
BENCHMARK(BM_VisibleEdgesIfsttar) SIZES;
BENCHMARK(BM_VisibleEdgesPaper) SIZES;
BENCHMARK(BM_VisibleEdgeMaskOurs) SIZES;
BENCHMARK(BM_VisibleEdgeMaskPublishedLoop)
    ->Args({640, 480})
    ->Iterations(2)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Uiqm) SIZES;
BENCHMARK(BM_Uciqe) SIZES;

}  // namespace
}  // namespace turbid

BENCHMARK_MAIN();
