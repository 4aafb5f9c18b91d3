// Simulator speed: full renders at 1360x1024 (color and gray), the skip paths, and the PSF
// convolution against OpenCV's GaussianBlur / filter2D in the same process. One thread
// (cv::setNumThreads(1)). Figures: docs/performance-simulator.md.
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>

#include "scenes/builtin.h"
#include "simulator/psf.h"
#include "simulator/render.h"

namespace turbid {
namespace {

// The hull scene (1360x1024, gray, oblique plate 1.7-9 m) and a color version with the same
// geometry: the paper's ACFR frames are 1360x1024 color.
const Scene& HullGray() {
  static const Scene scene = MakeBuiltinScene("hull");
  return scene;
}

const Scene& HullColor() {
  static const Scene scene = [] {
    Scene s = HullGray();
    cv::Mat tinted;
    cv::merge(std::vector<cv::Mat>{s.image * 0.8, s.image * 0.95, s.image}, tinted);
    s.image = tinted;
    s.name = "hull_color";
    return s;
  }();
  return scene;
}

// All terms on: the defaults (one LED, paper PSF T = 4 / q = 0.9, snow, Poisson-Gaussian noise,
// 8-bit output) with Jerlov 3C water.
RenderOptions Full() {
  RenderOptions o;
  o.water.type = "3C";
  return o;
}

enum Variant { kFull, kNoPsf, kNoNoise, kNoLight, kZeroBeta, kBare };

RenderOptions Make(Variant v) {
  RenderOptions o = Full();
  if (v == kNoPsf || v == kBare) o.psf.enabled = false;
  if (v == kNoNoise || v == kBare) o.snow.enabled = false, o.sensor.enabled = false;
  if (v == kNoLight || v == kBare) o.light.lights.clear();
  if (v == kZeroBeta || v == kBare)
    o.water = WaterOptions{}, o.water.beta_rgb_per_m = {0, 0, 0}, o.water.beta_gray_per_m = 0;
  return o;
}

// One-shot Render(options, scene): range map, normals, light geometry and everything else.
void BM_RenderOneShot(benchmark::State& state) {
  const Scene& scene = state.range(0) ? HullColor() : HullGray();
  const RenderOptions o = Make(static_cast<Variant>(state.range(1)));
  for (auto _ : state) benchmark::DoNotOptimize(Render(o, scene).image.data);
}

// A sweep over beta with one Renderer: the scene validation, range map and normals are done once;
// everything else (light, J, J * h, composition, noise with a new seed) is rendered each time.
void BM_RendererBetaSweep(benchmark::State& state) {
  const Scene& scene = state.range(0) ? HullColor() : HullGray();
  Renderer renderer(scene);
  RenderOptions o = Make(static_cast<Variant>(state.range(1)));
  o.water = WaterOptions{};
  int i = 0;
  for (auto _ : state) {
    const double beta = 0.1 + 0.01 * (i++ % 100);
    o.water.beta_rgb_per_m = {beta, beta, beta};
    o.water.beta_gray_per_m = beta;
    o.seed = i;
    benchmark::DoNotOptimize(renderer.Render(o).image.data);
  }
}

// Uniform range: a sphere of radius 3 m around the camera (t constant per channel).
void BM_RenderUniformRange(benchmark::State& state) {
  static const Scene scene = [] {
    Scene s = HullColor();
    for (int y = 0; y < s.depth_m.rows; ++y)
      for (int x = 0; x < s.depth_m.cols; ++x)
        s.depth_m.at<float>(y, x) = static_cast<float>(3.0 / cv::norm(s.camera.Ray(x, y)));
    s.normals = cv::Mat();
    return s;
  }();
  Renderer renderer(scene);
  RenderOptions o = Make(kNoLight);
  for (auto _ : state) benchmark::DoNotOptimize(renderer.Render(o).image.data);
}

cv::Mat ColorImage() {
  static const cv::Mat image = HullColor().image.clone();
  return image;
}

// PSF convolution at the paper's T = 4 (Gaussian) with sigma = state.range(0)/10 px.
void BM_PsfOurs(benchmark::State& state) {
  PsfOptions o;
  o.pixels_per_unit = state.range(0) / 10.0 / (0.5 / std::sqrt(0.9));
  const Psf psf = PsfKernel(o);
  const cv::Mat image = ColorImage();
  for (auto _ : state) benchmark::DoNotOptimize(ApplyPsf(psf, image).data);
  state.counters["radius_px"] = psf.radius_px;
}

void BM_PsfPeerGaussianBlur(benchmark::State& state) {
  PsfOptions o;
  o.pixels_per_unit = state.range(0) / 10.0 / (0.5 / std::sqrt(0.9));
  const Psf psf = PsfKernel(o);
  const cv::Mat image = ColorImage();
  cv::Mat out;
  for (auto _ : state) {
    cv::GaussianBlur(image, out, cv::Size(2 * psf.radius_px + 1, 2 * psf.radius_px + 1),
                     psf.sigma_px, psf.sigma_px, cv::BORDER_REFLECT_101);
    benchmark::DoNotOptimize(out.data);
  }
}

void BM_PsfPeerFilter2D(benchmark::State& state) {
  PsfOptions o;
  o.pixels_per_unit = state.range(0) / 10.0 / (0.5 / std::sqrt(0.9));
  const Psf psf = PsfKernel(o);
  const cv::Mat image = ColorImage();
  cv::Mat out;
  for (auto _ : state) {
    cv::filter2D(image, out, CV_32F, psf.kernel, cv::Point(-1, -1), 0, cv::BORDER_REFLECT_101);
    benchmark::DoNotOptimize(out.data);
  }
}

// Non-Gaussian kernel (T = 1, p = 1): ours runs the 2-D kernel through filter2D.
void BM_PsfOursNonGaussian(benchmark::State& state) {
  PsfOptions o;
  o.optical_thickness = 1.0;
  o.pixels_per_unit = state.range(0) / 10.0 / (0.5 / std::sqrt(0.9));
  const Psf psf = PsfKernel(o);
  const cv::Mat image = ColorImage();
  for (auto _ : state) benchmark::DoNotOptimize(ApplyPsf(psf, image).data);
  state.counters["radius_px"] = psf.radius_px;
}

#define VARIANTS(B)                 \
  B->ArgNames({"color", "variant"}) \
      ->Args({1, kFull})            \
      ->Args({0, kFull})            \
      ->Args({1, kNoPsf})           \
      ->Args({1, kNoNoise})         \
      ->Args({1, kNoLight})         \
      ->Args({1, kZeroBeta})        \
      ->Args({1, kBare})            \
      ->Args({0, kBare})            \
      ->Unit(benchmark::kMillisecond)

VARIANTS(BENCHMARK(BM_RenderOneShot));
VARIANTS(BENCHMARK(BM_RendererBetaSweep));
BENCHMARK(BM_RenderUniformRange)->Unit(benchmark::kMillisecond);
// Turbidity-dependent forward scatter: planning (per-pixel T -> levels, weights, e^{-T}) and
// applying it, colour 1360x1024, T = beta r of the hull with beta (0.9, 0.7, 0.55) /m.
cv::Mat HullThickness() {
  static const cv::Mat t = [] {
    const Scene& s = HullColor();
    return ThicknessFromRange(RangeFromDepth(s.camera, s.depth_m), {0.9, 0.7, 0.55});
  }();
  return t;
}

void BM_TurbidityPsfPlan(benchmark::State& state) {
  PsfOptions o;
  o.turbidity_dependent = true;
  const cv::Mat t = HullThickness();
  for (auto _ : state) benchmark::DoNotOptimize(PlanTurbidityPsf(o, t).glow.size());
}

void BM_TurbidityPsfApply(benchmark::State& state) {
  PsfOptions o;
  o.turbidity_dependent = true;
  const TurbidityPsf plan = PlanTurbidityPsf(o, HullThickness());
  const cv::Mat image = ColorImage();
  for (auto _ : state) benchmark::DoNotOptimize(ApplyTurbidityPsf(plan, image).data);
}

BENCHMARK(BM_TurbidityPsfPlan)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TurbidityPsfApply)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PsfOurs)->Arg(5)->Arg(20)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PsfPeerGaussianBlur)->Arg(5)->Arg(20)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PsfPeerFilter2D)->Arg(5)->Arg(20)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PsfOursNonGaussian)->Arg(5)->Arg(20)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace turbid

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // the goals are single-core
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
