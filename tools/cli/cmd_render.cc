// `turbid render` (one scene -> degraded image + sidecar + maps) and `turbid generate` (a dataset
// from a config: scenes x parameter grid and/or seeded random samples). docs/cli/render.md.
#include <atomic>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_io.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "simulator/render.h"
#include "tools/cli/cli.h"
#include "tools/harness/file_context.h"
#include "tools/harness/generate.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::string Stem(const std::string& path) {
  const fs::path p(path);
  return (p.parent_path() / p.stem()).string();
}

// Writes an image as PNG (`png_bits`, values coded with `transfer`) or float EXR (linear).
void WriteMap(const std::string& path, const cv::Mat& image, int png_bits, bool overwrite,
              Transfer transfer = Transfer::kLinear) {
  WriteImageOptions options;
  options.bit_depth = png_bits;
  options.overwrite = overwrite;
  options.transfer = transfer;
  WriteImage(path, image, options);
}

struct RenderOutputs {
  std::string image, sidecar;
  std::vector<std::pair<std::string, const cv::Mat*>> maps;
};

// ---- render ------------------------------------------------------------------------------------

struct RenderArgs {
  std::string scene, params, out, maps, water;
  std::vector<std::string> sets;
  std::string beta;  // "B" or "R,G,B" (split here: CLI11's delimiter drops empty items)
  double scale = 1.0;
  std::optional<uint64_t> seed;  // any uint64; '-1' or 2^64 are refused when parsed
  int bit_depth = 0;
  bool explain = false, force = false;
};

// --beta B (grey water, the same in every channel) or R,G,B: custom water.
void ApplyBeta(const RenderArgs& args, json& params) {
  std::vector<double> beta;
  std::stringstream items(args.beta + ",");
  for (std::string item; std::getline(items, item, ',');) {
    if (item.empty()) throw UsageError("--beta '" + args.beta + "': empty item (give B or R,G,B)");
    beta.push_back(ParseDecimalOption("--beta", item));
  }
  if (beta.size() != 1 && beta.size() != 3) throw Error("--beta: give 1 value or 3 (R,G,B)");
  const double r = beta[0], g = beta.size() == 3 ? beta[1] : r, b = beta.back();
  SetRenderParam(params, "water.type", "custom");
  SetRenderParam(params, "water.beta_rgb_per_m", json::array({r, g, b}));
  if (beta.size() == 1) SetRenderParam(params, "water.beta_gray_per_m", r);
}

// The render options: --params, then the flags over them; `ext` is the output's extension.
RenderOptions ResolveRenderOptions(const RenderArgs& args, const std::string& ext) {
  json params = args.params.empty() ? json::object() : ReadJsonFile(args.params);
  if (!params.is_object()) throw Error(args.params, "parameters must be a JSON object");
  if (!args.water.empty()) SetRenderParam(params, "water.type", args.water);
  if (!args.beta.empty()) ApplyBeta(args, params);
  for (const std::string& s : args.sets) ApplyRenderSet(params, s);
  if (args.seed) params["seed"] = *args.seed;
  if (args.bit_depth) SetRenderParam(params, "camera.bit_depth", args.bit_depth);
  if (!args.out.empty() && ext != ".png" && ext != ".exr")
    throw Error(args.out, "output must end in .png or .exr");
  if (ext == ".exr" && !params.contains("camera")) SetRenderParam(params, "camera.bit_depth", 32);
  RenderOptions options;
  try {
    options = RenderOptionsFromJson(params);
  } catch (const Error& e) {  // name the file the parameters came from
    if (args.params.empty()) throw;
    throw Error(args.params, e.what());
  }
  options.maps = MapSelection::FromList(args.maps);
  if (ext == ".png" && options.camera.bit_depth == 32)
    throw Error(args.out, "camera.bit_depth 32 (float) needs an .exr output");
  return options;
}

// Every output is checked before anything is written, so a refusal leaves nothing behind.
void CheckOutputsFree(const RenderArgs& args, const RenderOptions& options, const std::string& stem,
                      const std::string& map_ext) {
  std::vector<std::string> names = {args.out, stem + ".json"};
  const std::vector<std::pair<std::string, bool>> wanted = {
      {"transmission", options.maps.transmission},
      {"light", options.maps.light},
      {"veil", options.maps.veil},
      {"psf", options.maps.psf},
      {"noise", options.maps.noise}};
  for (const auto& [name, on] : wanted)
    if (on) names.push_back(stem + "_" + name + map_ext);
  if (!args.force)
    for (const std::string& name : names)
      if (fs::exists(name)) throw Error(name, "exists (use --force to replace it)");
}

// The image, the maps asked for (STEM_NAME.EXT) and the sidecar STEM.json, written last.
void WriteRenderOutputs(const RenderArgs& args, const RenderOptions& options,
                        const RenderResult& result, const std::string& stem,
                        const std::string& map_ext) {
  RenderRecord sidecar = result.sidecar;
  sidecar.scene.spec = args.scene;
  sidecar.scene.builtin_scale = args.scale;
  sidecar.outputs = {{"image", fs::path(args.out).filename().string()}};
  const std::vector<std::pair<std::string, const cv::Mat*>> maps = {
      {"transmission", &result.transmission},
      {"light", &result.light},
      {"veil", &result.veil},
      {"psf", &result.psf},
      {"noise", &result.noise}};
  const int bits = options.camera.bit_depth == 32 ? 16 : options.camera.bit_depth;
  // The image holds decoded codes of the camera encoding: written with it, the file stores them.
  WriteMap(args.out, result.image, bits, args.force, TransferFor(options.camera.FileEncoding()));
  for (const auto& [name, mat] : maps) {
    if (mat->empty()) continue;
    cv::Mat image = *mat;
    if (name == "psf") {  // scaled so the peak is 1 in a PNG; the EXR keeps the true weights
      double peak = 0.0;
      cv::minMaxLoc(image, nullptr, &peak);
      if (map_ext == ".png" && peak > 0.0) image = image / peak;
      sidecar.psf_peak = peak;
    }
    if (name == "noise" && map_ext == ".png") image = image + 0.5;  // signed: offset by 0.5
    const std::string path = stem + "_" + name + map_ext;
    WriteMap(path, image, 16, args.force);
    sidecar.outputs[name] = fs::path(path).filename().string();
  }
  AtomicWriteText(stem + ".json", sidecar.ToJson().dump(2) + "\n", args.force);
}

void RunRender(const RenderArgs& args) {
  const std::string ext = args.out.empty() ? "" : Extension(args.out);
  const RenderOptions options = ResolveRenderOptions(args, ext);
  LoadSceneOptions scene_options;
  scene_options.builtin_scale = args.scale;
  ThrowIfInvalid(scene_options, "--scale");
  const Scene scene = LoadScene(args.scene, scene_options);
  Renderer renderer(scene);
  if (args.explain) std::cout << renderer.Plan(options).ToText();
  if (args.out.empty()) return;

  const std::string stem = Stem(args.out);
  const std::string map_ext = ext == ".exr" ? ".exr" : ".png";
  CheckOutputsFree(args, options, stem, map_ext);
  const RenderResult result = renderer.Render(options);
  WriteRenderOutputs(args, options, result, stem, map_ext);
  std::cout << "wrote " << args.out << " and " << stem << ".json\n";
}

}  // namespace

void AddRenderCommand(CLI::App& app) {
  auto render_args = std::make_shared<RenderArgs>();
  CLI::App* render =
      app.add_subcommand("render", "degrade one scene with the forward model (paper eq. 2)");
  PathOption(render->add_option("--scene", render_args->scene,
                                "scene spec: builtin:NAME, a built-in name or a scene JSON file"))
      ->required();
  PathOption(render->add_option("--params", render_args->params,
                                "JSON render parameters (docs/model.md)"));
  PathOption(
      render->add_option("--out", render_args->out,
                         "output image (.png: 8/16-bit, .exr: float) ; OUT.json is the sidecar"));
  render->add_option("--maps", render_args->maps, "extra maps: transmission,light,veil,psf,noise");
  render->add_option("--seed", render_args->seed,
                     "random seed in [0, 2^64 - 1] (overrides the parameters' seed)");
  render->add_option("--water", render_args->water,
                     "water type: custom, I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C");
  render->add_option("--beta", render_args->beta,
                     "attenuation 1/m: one value for all channels or R,G,B");
  render->add_option("--bit-depth", render_args->bit_depth, "camera output: 8, 16 or 32 (float)");
  render
      ->add_option("--set", render_args->sets,
                   "KEY=VALUE on the JSON parameters, e.g. psf.forward_scatter=0.5 (repeatable)")
      ->type_name("KEY=VALUE")
      ->allow_extra_args(false);
  render->add_option("--scale", render_args->scale, "size scale in (0, 1] for built-in scenes");
  render->add_flag("--explain", render_args->explain,
                   "print the render plan (what is computed and skipped)");
  render->add_flag("--force", render_args->force, "replace existing outputs");
  render->callback([render_args] {
    if (render_args->out.empty() && !render_args->explain)
      throw Error("render: --out is required (or --explain)");
    // Out of memory or an OpenCV failure while rendering names the scene.
    WithFileContext(render_args->scene, "rendering it", [&] { RunRender(*render_args); });
  });
  render->footer(
      "Example: turbid render --scene builtin:seafloor --water 3C --seed 1 --out sea.png");
}

void AddGenerateCommand(CLI::App& app) {
  auto config = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  auto threads =
      std::make_shared<int>(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  CLI::App* generate =
      app.add_subcommand("generate", "render a dataset: scenes x parameter grid / random samples");
  PathOption(generate->add_option("config", *config, "dataset config JSON (docs/cli/render.md)"))
      ->required();
  PathOption(
      generate->add_option("--out", *out, "output folder (resumes when it holds a previous run)"))
      ->required();
  InRange(generate->add_option("--threads", *threads,
                               "worker threads (output bytes do not depend on it)"),
          1, 256);
  generate->callback([config, out, threads] {
    RunGenerate(ParseGenerateConfig(ReadJsonFile(*config), *config), *out, *threads);
  });
  generate->footer("Example: turbid generate dataset.json --out dataset");
}

}  // namespace turbid
