// `turbid water fit SCENE... --out FIT.json`: Sea-thru's water estimate from real RGB-D, written as
// a render-parameter file plus diagnostics and a plot. Reference: docs/cli/water.md.
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_io.h"
#include "enhancer/seathru/water_fit.h"
#include "enhancer/seathru/water_report.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "tools/cli/cli.h"

namespace turbid {
namespace {
namespace fs = std::filesystem;

struct WaterFitArgs {
  std::vector<std::string> scenes;
  std::string out;
  std::string options_path;
  bool force = false;
};

// FIT.json -> FIT.diagnostics.json, FIT.plot.png (next to it).
std::string Sibling(const std::string& out, const std::string& suffix) {
  fs::path p(out);
  return (p.parent_path() / (p.stem().string() + suffix)).string();
}

void RunWaterFit(const WaterFitArgs& args) {
  WaterFitOptions options;
  if (!args.options_path.empty())
    WaterFitFields().Read(ReadJsonFile(args.options_path), &options, args.options_path);
  std::string why;
  if (!options.Check(&why))
    throw Error(args.options_path.empty() ? "water fit" : args.options_path, why);
  const std::string diagnostics_path = Sibling(args.out, ".diagnostics.json");
  const std::string plot_path = Sibling(args.out, ".plot.png");
  if (!args.force)
    for (const std::string& p : {args.out, diagnostics_path, plot_path})
      if (fs::exists(p)) throw Error(p, "exists (use --force to overwrite)");
  std::vector<WaterFitFrame> frames;
  for (const std::string& spec : args.scenes) {
    for (const std::string& one : ExpandSceneSpec(spec)) {
      Scene scene = LoadScene(one);
      if (scene.channels() != 3) throw Error(one, "water fit needs a colour image");
      frames.push_back({scene.image, RangeFromDepth(scene.camera, scene.depth_m), scene.name});
    }
  }
  const WaterFit fit = FitWater(frames, options);
  AtomicWriteText(args.out, WaterFitParamsJson(fit).dump(2) + "\n", args.force);
  AtomicWriteText(diagnostics_path, WaterFitDiagnosticsJson(fit, options).dump(2) + "\n",
                  args.force);
  WriteImageOptions png;
  png.overwrite = args.force;
  WriteImage(plot_path, WaterFitPlot(fit), png);
  const BackscatterFit& b = fit.backscatter;
  const AttenuationFit& a = fit.attenuation;
  const double r_mid = 0.5 * (fit.min_range_m + fit.max_range_m);
  std::printf("%d frame(s), %lld valid pixels, range %.3f..%.3f m\n", fit.frames, fit.valid_pixels,
              fit.min_range_m, fit.max_range_m);
  std::printf("  B_inf (R, G, B)       %.4f %.4f %.4f\n", b.b_inf[0], b.b_inf[1], b.b_inf[2]);
  std::printf("  beta^B (1/m)          %.4f %.4f %.4f\n", b.beta_b[0], b.beta_b[1], b.beta_b[2]);
  std::printf("  beta^D at %.2f m (1/m) %.4f %.4f %.4f\n", r_mid, a.Beta(0, r_mid),
              a.Beta(1, r_mid), a.Beta(2, r_mid));
  std::printf("  backscatter residual RMS %.5f %.5f %.5f\n", b.rms[0], b.rms[1], b.rms[2]);
  std::printf("  wrote %s, %s, %s\n", args.out.c_str(), diagnostics_path.c_str(),
              plot_path.c_str());
}

}  // namespace

void AddWaterCommand(CLI::App& app) {
  CLI::App* water = app.add_subcommand("water", "estimate water from real underwater RGB-D");
  water->require_subcommand(1);
  water->footer("Example: turbid water fit clean/seafloor/scene.json --out water.json");
  auto args = std::make_shared<WaterFitArgs>();
  CLI::App* fit = water->add_subcommand(
      "fit",
      "fit Sea-thru's backscatter and attenuation to scenes of the same water; write a "
      "render-parameter file (model revised)");
  PathOption(
      fit->add_option("scenes", args->scenes, "scene files (real RGB-D frames)")->required());
  PathOption(fit->add_option("--out", args->out,
                             "FIT.json (turbid render --params); FIT.diagnostics.json and "
                             "FIT.plot.png are written next to it")
                 ->required());
  PathOption(fit->add_option("--options", args->options_path,
                             "fit options JSON (keys: docs/cli/water.md)"));
  fit->add_flag("--force", args->force, "overwrite existing outputs");
  fit->callback([args]() { RunWaterFit(*args); });
  fit->footer("Example: turbid water fit d3.json --out d3_water.json");
}

}  // namespace turbid
