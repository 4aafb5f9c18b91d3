// The sweep's reuse of work that does not depend on the swept parameter, made visible: the same
// beta sweep over one built-in scene run item by item (a) with reuse (scene loaded once, one
// Renderer whose caches - range, light geometry, PSF kernel, blurred J - serve every beta, and the
// ground truth's no-reference scores computed once) and (b) without (each item loads the scene,
// builds a fresh renderer and rescores the ground truth). Same results; the ratio is the reuse.
//   ./build-harness/bench_harness --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include <string>

#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"

namespace turbid {
namespace {

Experiment BetaSweep(const std::string& scene, double scale) {
  const nlohmann::json in = {{"name", "bench"},
                             {"scale", scale},
                             {"scenes", {"builtin:" + scene}},
                             {"grid",
                              {{"water.beta_gray_per_m", {0.1, 0.3, 0.5, 0.7, 0.9, 1.1, 1.3, 1.5}},
                               {"water.beta_rgb_per_m", {{0.7, 0.7, 0.7}}}}},
                             {"reference_methods", false},
                             {"methods", {"none"}},
                             {"metrics", {"psnr", "ssim", "uiqm"}},
                             {"thumbnails", 0}};
  return ParseExperiment(in, "bench.json", RegistryCatalog());
}

void RunItems(benchmark::State& state, const std::string& scene, bool reuse) {
  const Experiment experiment = BetaSweep(scene, state.range(0) / 100.0);
  const std::vector<ItemSpec> items = ExpandItems(experiment);
  HarnessRunnerOptions options;
  options.reuse = reuse;
  for (auto _ : state) {
    HarnessRunner runner(experiment, "/tmp", options);  // fresh: reuse starts from nothing too
    for (const ItemSpec& item : items) benchmark::DoNotOptimize(runner.Run(item));
  }
  state.counters["items"] = static_cast<double>(items.size());
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * items.size()));
}

void BM_SweepHullWithReuse(benchmark::State& state) { RunItems(state, "hull", true); }
void BM_SweepHullNoReuse(benchmark::State& state) { RunItems(state, "hull", false); }
void BM_SweepSeafloorWithReuse(benchmark::State& state) { RunItems(state, "seafloor", true); }
void BM_SweepSeafloorNoReuse(benchmark::State& state) { RunItems(state, "seafloor", false); }

// Argument: scene scale in percent (50: hull 680x512, seafloor 320x240).
BENCHMARK(BM_SweepHullWithReuse)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SweepHullNoReuse)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SweepSeafloorWithReuse)->Arg(50)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SweepSeafloorNoReuse)->Arg(50)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace turbid

BENCHMARK_MAIN();
