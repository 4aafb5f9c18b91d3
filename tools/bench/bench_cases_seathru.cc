// `turbid bench` cases of issue 31 item 7: `turbid water fit`'s estimate (FitWater) and the
// `seathru` method on a 1000x665 frame (the Sea-thru D1/D3 size), one core. The frame is the
// built-in seafloor stretched to 1000x665 (nearest neighbour, image and depth alike) with every
// 37th pixel black, rendered in coastal `revised` water (no LEDs, PSF, snow or noise). No peer
// runs here: the published Python/MATLAB implementations take tens of seconds per frame.
#include <benchmark/benchmark.h>

#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "enhancer/seathru/seathru.h"
#include "enhancer/seathru/water_fit.h"
#include "scenes/builtin.h"
#include "simulator/render.h"
#include "tools/bench/bench_cases.h"

namespace turbid::bench {
namespace {

struct SeathruInput {
  cv::Mat image, range_m;
};

const SeathruInput& Frame() {
  static std::once_flag once;
  static SeathruInput input;
  std::call_once(once, [] {
    Scene scene = MakeBuiltinScene("seafloor");
    const cv::Size size(1000, 665);
    cv::resize(scene.image, scene.image, size, 0, 0, cv::INTER_NEAREST);
    cv::resize(scene.depth_m, scene.depth_m, size, 0, 0, cv::INTER_NEAREST);
    scene.normals = cv::Mat();
    scene.camera.fx *= 1000.0 / 640.0;
    scene.camera.cx = (scene.camera.cx + 0.5) * 1000.0 / 640.0 - 0.5;
    scene.camera.fy *= 665.0 / 480.0;
    scene.camera.cy = (scene.camera.cy + 0.5) * 665.0 / 480.0 - 0.5;
    scene.camera.width = size.width;
    scene.camera.height = size.height;
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x)
        if ((y * size.width + x) % 37 == 0) scene.image.at<cv::Vec3f>(y, x) = {0, 0, 0};
    RenderOptions o;
    o.model = ImageModel::kRevised;
    o.water.beta_rgb_per_m = {0.60, 0.25, 0.30};
    o.water.ambient_rgb = {1, 1, 1};
    o.water.backscatter = true;
    o.water.backscatter_rgb = {0.06, 0.28, 0.30};
    o.revised.beta_b_rgb_per_m = {0.55, 0.40, 0.45};
    o.light.lights.clear();
    o.psf.enabled = false;
    o.snow.enabled = false;
    o.sensor.enabled = false;
    o.camera.bit_depth = 32;
    Renderer renderer(scene);
    input.image = renderer.Render(o).image;
    input.range_m = renderer.range_m().clone();
  });
  return input;
}

}  // namespace

void AddSeathruCases(std::vector<BenchCase>& cases, const InputsFn&) {
  BenchCase fit;
  fit.name = "water/fit/1000x665";
  fit.ours = [] {
    const SeathruInput& f = Frame();
    benchmark::DoNotOptimize(FitWater({{f.image, f.range_m, "bench"}}).backscatter.b_inf[0]);
  };
  fit.goal = {0.0, 1000.0, "issue 31 item 7 (water fit <= 1 s at 1000x665, one core)"};
  cases.push_back(fit);
  BenchCase method;
  method.name = "seathru/1000x665";
  method.ours = [] {
    const SeathruInput& f = Frame();
    benchmark::DoNotOptimize(Seathru({}, f.image, f.range_m).image.data);
  };
  method.goal = {0.0, 200.0, "issue 31 item 7 (seathru <= 200 ms at 1000x665, one core)"};
  cases.push_back(method);
}

}  // namespace turbid::bench
