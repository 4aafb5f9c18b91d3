// `turbid render` (one scene -> degraded image + sidecar + maps) and `turbid generate` (a dataset
// from a config: scenes x parameter grid and/or seeded random samples). docs/cli/render.md.
#include <atomic>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

#include "scenes/atomic_file.h"
#include "scenes/error.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "simulator/render.h"
#include "tools/cli.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json ReadJsonFile(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw Error(path, "cannot open");
  try {
    return json::parse(file);
  } catch (const json::exception& e) {
    throw Error(path, std::string("not valid JSON: ") + e.what());
  }
}

// Sets a dotted path ("psf.forward_scatter", "light.lights.0.power") in a JSON object.
void SetPath(json& root, const std::string& path, const json& value) {
  json* node = &root;
  std::stringstream stream(path);
  std::string part;
  std::vector<std::string> parts;
  while (std::getline(stream, part, '.')) parts.push_back(part);
  if (parts.empty()) throw Error("parameter path '" + path + "' is empty");
  for (size_t i = 0; i < parts.size(); ++i) {
    const bool last = i + 1 == parts.size();
    const std::string& key = parts[i];
    if (node->is_array()) {
      size_t index = 0;
      try {
        index = std::stoul(key);
      } catch (...) {
        throw Error("parameter path '" + path + "': '" + key + "' is not an array index");
      }
      while (node->size() <= index) node->push_back(json::object());
      node = &(*node)[index];
    } else {
      if (!node->is_object()) *node = json::object();
      node = &(*node)[key];
    }
    if (last) *node = value;
  }
}

// SetPath for render parameters: indexing a light ("light.lights.0.power") starts from the
// default light list when the parameters name none, so defaults are not written twice.
void SetParam(json& params, const std::string& path, const json& value) {
  if (path.rfind("light.lights.", 0) == 0 &&
      !(params.contains("light") && params["light"].contains("lights"))) {
    if (!params.contains("light")) params["light"] = json::object();
    params["light"]["lights"] = RenderOptionsToJson(RenderOptions{})["light"]["lights"];
  }
  SetPath(params, path, value);
}

// "--set key=value": value parsed as JSON, else taken as a string.
void ApplySet(json& params, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw Error("--set '" + assignment + "': expected KEY=VALUE");
  const std::string key = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  json value;
  try {
    value = json::parse(text);
  } catch (const json::exception&) {
    value = text;
  }
  SetParam(params, key, value);
}

std::string Extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::string Stem(const std::string& path) {
  const fs::path p(path);
  return (p.parent_path() / p.stem()).string();
}

// Writes an image as 16-bit PNG (maps, ground truth) or float EXR.
void WriteMap(const std::string& path, const cv::Mat& image, int png_bits, bool overwrite) {
  WriteImageOptions options;
  options.bit_depth = png_bits;
  options.overwrite = overwrite;
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
  std::vector<double> beta;
  double scale = 1.0;
  int64_t seed = -1;
  int bit_depth = 0;
  bool explain = false, force = false;
};

void RunRender(const RenderArgs& args) {
  json params = args.params.empty() ? json::object() : ReadJsonFile(args.params);
  if (!params.is_object()) throw Error(args.params, "parameters must be a JSON object");
  if (!args.water.empty()) SetPath(params, "water.type", args.water);
  if (!args.beta.empty()) {
    if (args.beta.size() != 1 && args.beta.size() != 3)
      throw Error("--beta: give 1 value or 3 (R,G,B)");
    const double r = args.beta[0], g = args.beta.size() == 3 ? args.beta[1] : r,
                 b = args.beta.back();
    SetPath(params, "water.type", "custom");
    SetPath(params, "water.beta_rgb_per_m", json::array({r, g, b}));
    if (args.beta.size() == 1) SetPath(params, "water.beta_gray_per_m", r);
  }
  for (const std::string& s : args.sets) ApplySet(params, s);
  if (args.seed >= 0) params["seed"] = static_cast<uint64_t>(args.seed);
  if (args.bit_depth) SetPath(params, "camera.bit_depth", args.bit_depth);
  const std::string ext = args.out.empty() ? "" : Extension(args.out);
  if (!args.out.empty() && ext != ".png" && ext != ".exr")
    throw Error(args.out, "output must end in .png or .exr");
  if (ext == ".exr" && !params.contains("camera")) SetPath(params, "camera.bit_depth", 32);
  RenderOptions options = RenderOptionsFromJson(params);
  options.maps = MapSelection::FromList(args.maps);
  if (ext == ".png" && options.camera.bit_depth == 32)
    throw Error(args.out, "camera.bit_depth 32 (float) needs an .exr output");

  LoadSceneOptions scene_options;
  scene_options.builtin_scale = args.scale;
  ThrowIfInvalid(scene_options, "--scale");
  const Scene scene = LoadScene(args.scene, scene_options);
  Renderer renderer(scene);
  if (args.explain) std::cout << renderer.Plan(options).ToText();
  if (args.out.empty()) return;

  // Every output is checked before anything is written, so a refusal leaves nothing behind.
  const std::string stem = Stem(args.out);
  const std::string map_ext = ext == ".exr" ? ".exr" : ".png";
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

  const RenderResult result = renderer.Render(options);
  json sidecar = result.sidecar;
  sidecar["scene"]["spec"] = args.scene;
  sidecar["scene"]["builtin_scale"] = args.scale;
  sidecar["outputs"] = {{"image", fs::path(args.out).filename().string()}};
  const std::vector<std::pair<std::string, const cv::Mat*>> maps = {
      {"transmission", &result.transmission},
      {"light", &result.light},
      {"veil", &result.veil},
      {"psf", &result.psf},
      {"noise", &result.noise}};
  const int bits = options.camera.bit_depth == 32 ? 16 : options.camera.bit_depth;
  WriteMap(args.out, result.image, bits, args.force);
  for (const auto& [name, mat] : maps) {
    if (mat->empty()) continue;
    cv::Mat image = *mat;
    if (name == "psf") {  // scaled so the peak is 1 in a PNG; the EXR keeps the true weights
      double peak = 0.0;
      cv::minMaxLoc(image, nullptr, &peak);
      if (map_ext == ".png" && peak > 0.0) image = image / peak;
      sidecar["outputs"]["psf_peak"] = peak;
    }
    if (name == "noise" && map_ext == ".png") image = image + 0.5;  // signed: offset by 0.5
    const std::string path = stem + "_" + name + map_ext;
    WriteMap(path, image, 16, args.force);
    sidecar["outputs"][name] = fs::path(path).filename().string();
  }
  AtomicWriteText(stem + ".json", sidecar.dump(2) + "\n", args.force);
  std::cout << "wrote " << args.out << " and " << stem << ".json\n";
}

// ---- generate ----------------------------------------------------------------------------------

// One dataset item: a scene and the JSON render parameters.
struct Item {
  int index = 0;
  std::string id;
  size_t scene = 0;
  json params;
};

json SampleValue(const json& spec, uint64_t key, uint64_t index, const std::string& path) {
  if (!spec.is_object() || spec.size() != 1)
    throw Error("generate: random.params." + path +
                ": expected {\"uniform\": [lo, hi]}, "
                "{\"log_uniform\": [lo, hi]} or {\"choice\": [...]}");
  const std::string kind = spec.begin().key();
  const json& args = spec.begin().value();
  const double u = RandomUniform(key, index);
  if (kind == "choice") {
    if (!args.is_array() || args.empty())
      throw Error("generate: random.params." + path + ".choice: non-empty array");
    return args[std::min<size_t>(static_cast<size_t>(u * args.size()), args.size() - 1)];
  }
  if (!args.is_array() || args.size() != 2 || !args[0].is_number() || !args[1].is_number())
    throw Error("generate: random.params." + path + "." + kind + ": expected [lo, hi]");
  const double lo = args[0].get<double>(), hi = args[1].get<double>();
  if (kind == "uniform") return lo + u * (hi - lo);
  if (kind == "log_uniform") {
    if (lo <= 0.0 || hi <= 0.0)
      throw Error("generate: random.params." + path + ".log_uniform: bounds must be > 0");
    return std::exp(std::log(lo) + u * (std::log(hi) - std::log(lo)));
  }
  throw Error("generate: random.params." + path + ": unknown distribution '" + kind + "'");
}

void RunGenerate(const std::string& config_path, const std::string& out_dir, int threads) {
  const json config = ReadJsonFile(config_path);
  if (!config.is_object()) throw Error(config_path, "must be a JSON object");
  for (auto it = config.begin(); it != config.end(); ++it)
    if (it.key() != "scenes" && it.key() != "scale" && it.key() != "base" && it.key() != "grid" &&
        it.key() != "random" && it.key() != "seed" && it.key() != "format")
      throw Error(config_path,
                  it.key() + ": unknown key (scenes, scale, base, grid, random, seed, format)");
  if (!config.contains("scenes") || !config["scenes"].is_array() || config["scenes"].empty())
    throw Error(config_path, "scenes: a non-empty array of scene specs is required");
  const double scale = config.value("scale", 1.0);
  const uint64_t seed = config.value("seed", uint64_t{0});
  const std::string format = config.value("format", std::string("png"));
  if (format != "png" && format != "exr") throw Error(config_path, "format: png or exr");
  const json base = config.value("base", json::object());
  RenderOptionsFromJson(base);  // fail early on a bad base

  // Grid: cartesian product over dotted parameter paths, in key order.
  std::vector<json> combos = {json::object()};
  if (config.contains("grid")) {
    const json& grid = config["grid"];
    if (!grid.is_object())
      throw Error(config_path, "grid: must be an object of path -> array of values");
    for (auto it = grid.begin(); it != grid.end(); ++it) {
      if (!it.value().is_array() || it.value().empty())
        throw Error(config_path, "grid." + it.key() + ": must be a non-empty array");
      std::vector<json> next;
      for (const json& combo : combos)
        for (const json& value : it.value()) {
          json c = combo;
          c[it.key()] = value;
          next.push_back(c);
        }
      combos = next;
    }
  }
  int samples = 1;
  json random_params = json::object();
  uint64_t random_seed = seed;
  if (config.contains("random")) {
    const json& random = config["random"];
    if (!random.is_object()) throw Error(config_path, "random: must be an object");
    samples = random.value("count", 1);
    random_seed = random.value("seed", seed);
    random_params = random.value("params", json::object());
    if (samples < 1 || samples > 1000000)
      throw Error(config_path, "random.count: must be in [1, 1e6]");
  }

  LoadSceneOptions scene_options;
  scene_options.builtin_scale = scale;
  ThrowIfInvalid(scene_options, config_path + ": scale");
  std::vector<std::unique_ptr<Renderer>> renderers;
  std::vector<std::string> specs;
  for (const json& spec : config["scenes"]) {
    if (!spec.is_string()) throw Error(config_path, "scenes: entries must be strings");
    specs.push_back(spec.get<std::string>());
    renderers.push_back(std::make_unique<Renderer>(LoadScene(specs.back(), scene_options)));
  }

  // Items and their fully resolved parameters (validated before any rendering starts).
  std::vector<Item> items;
  const uint64_t sample_key = RandomKey(random_seed, 0x5a4d);
  const uint64_t seed_key = RandomKey(seed, 0x5eed);
  for (size_t s = 0; s < specs.size(); ++s)
    for (size_t g = 0; g < combos.size(); ++g)
      for (int r = 0; r < samples; ++r) {
        Item item;
        item.index = static_cast<int>(items.size());
        item.scene = s;
        json params = base;
        for (auto it = combos[g].begin(); it != combos[g].end(); ++it)
          SetParam(params, it.key(), it.value());
        // Random samples depend on (random seed, grid point, sample number), not on the scene.
        uint64_t draw = 0;
        for (auto it = random_params.begin(); it != random_params.end(); ++it, ++draw)
          SetParam(params, it.key(),
                   SampleValue(it.value(), sample_key, (g * samples + r) * 64 + draw, it.key()));
        if (!params.contains("seed")) params["seed"] = RandomBits(seed_key, item.index) >> 1;
        try {
          params = RenderOptionsToJson(RenderOptionsFromJson(params));
        } catch (const Error& e) {
          throw Error(config_path,
                      std::string("item ") + std::to_string(item.index) + ": " + e.what());
        }
        item.params = params;
        std::ostringstream id;
        id << renderers[s]->scene().name << "_" << std::setw(6) << std::setfill('0') << item.index;
        item.id = id.str();
        items.push_back(item);
      }

  for (const char* sub : {"images", "ground_truth", "lit", "sidecars"})
    fs::create_directories(fs::path(out_dir) / sub);
  const std::string ext = "." + format;
  auto paths = [&](const Item& item) {
    const fs::path dir(out_dir);
    return std::array<std::string, 4>{(dir / "images" / (item.id + ext)).string(),
                                      (dir / "ground_truth" / (item.id + ext)).string(),
                                      (dir / "lit" / (item.id + ".pfm")).string(),
                                      (dir / "sidecars" / (item.id + ".json")).string()};
  };
  // An item is complete when its sidecar (written last) exists and names the same parameters.
  auto complete = [&](const Item& item) {
    const auto p = paths(item);
    if (!fs::exists(p[3])) return false;
    for (int i = 0; i < 3; ++i)
      if (!fs::exists(p[i])) return false;
    try {
      return ReadJsonFile(p[3]).at("options") == item.params;
    } catch (...) {
      return false;
    }
  };

  std::atomic<int> next{0}, done{0}, skipped{0};
  std::mutex error_mutex;
  std::string first_error;
  auto worker = [&] {
    for (;;) {
      const int i = next.fetch_add(1);
      if (i >= static_cast<int>(items.size())) return;
      {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!first_error.empty()) return;
      }
      const Item& item = items[i];
      try {
        if (complete(item)) {
          ++skipped;
        } else {
          const auto p = paths(item);
          const Renderer& renderer = *renderers[item.scene];
          RenderOptions options = RenderOptionsFromJson(item.params);
          if (format == "exr") options.camera.bit_depth = 32;
          const RenderResult result = renderer.Render(options);
          const int bits = options.camera.bit_depth == 32 ? 16 : options.camera.bit_depth;
          WriteMap(p[0], result.image, bits, true);
          WriteMap(p[1], renderer.scene().image, 16, true);
          WriteMap(p[2], result.lit, 16, true);
          json sidecar = result.sidecar;
          sidecar["options"] = item.params;
          sidecar["scene"]["spec"] = specs[item.scene];
          sidecar["scene"]["builtin_scale"] = scale;
          sidecar["item"] = {{"index", item.index}, {"id", item.id}};
          sidecar["outputs"] = {{"image", "images/" + item.id + ext},
                                {"ground_truth", "ground_truth/" + item.id + ext},
                                {"lit", "lit/" + item.id + ".pfm"}};
          AtomicWriteText(p[3], sidecar.dump(2) + "\n", true);
        }
        const int n = ++done;
        if (n % 10 == 0 || n == static_cast<int>(items.size()))
          std::cerr << "generate: " << n << "/" << items.size() << " items\r" << std::flush;
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (first_error.empty()) first_error = item.id + ": " + e.what();
      }
    }
  };
  const int count = std::max(1, threads);
  std::vector<std::thread> pool;
  for (int t = 0; t < count; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  std::cerr << "\n";
  if (!first_error.empty()) throw Error("generate: " + first_error);

  // Manifest in item order: the same bytes whatever the thread count or interruption history.
  std::string csv =
      "index,id,scene,image,ground_truth,lit,sidecar,seed,beta_r,beta_g,beta_b,beta_gray,psf_T,psf_"
      "q\n";
  std::string jsonl;
  for (const Item& item : items) {
    const json& o = item.params;
    const json& b = o["water"]["beta_rgb_per_m"];
    std::ostringstream row;
    row << item.index << "," << item.id << "," << specs[item.scene] << ",images/" << item.id << ext
        << ",ground_truth/" << item.id << ext << ",lit/" << item.id << ".pfm,sidecars/" << item.id
        << ".json," << o["seed"].get<uint64_t>() << "," << b[0].dump() << "," << b[1].dump() << ","
        << b[2].dump() << "," << o["water"]["beta_gray_per_m"].dump() << ","
        << o["psf"]["optical_thickness"].dump() << "," << o["psf"]["forward_scatter"].dump()
        << "\n";
    csv += row.str();
    jsonl += json({{"index", item.index},
                   {"id", item.id},
                   {"scene", specs[item.scene]},
                   {"image", "images/" + item.id + ext},
                   {"ground_truth", "ground_truth/" + item.id + ext},
                   {"lit", "lit/" + item.id + ".pfm"},
                   {"sidecar", "sidecars/" + item.id + ".json"},
                   {"options", o}})
                 .dump() +
             "\n";
  }
  AtomicWriteText((fs::path(out_dir) / "manifest.csv").string(), csv, true);
  AtomicWriteText((fs::path(out_dir) / "manifest.jsonl").string(), jsonl, true);
  std::cout << "generate: " << items.size() << " items (" << skipped.load()
            << " already complete) in " << out_dir << "\n";
}

}  // namespace

void AddRenderCommands(CLI::App& app) {
  auto render_args = std::make_shared<RenderArgs>();
  CLI::App* render =
      app.add_subcommand("render", "degrade one scene with the forward model (paper eq. 2)");
  render
      ->add_option("--scene", render_args->scene,
                   "scene spec: builtin:NAME, a built-in name or a scene JSON file")
      ->required();
  render->add_option("--params", render_args->params, "JSON render parameters (docs/model.md)");
  render->add_option("--out", render_args->out,
                     "output image (.png: 8/16-bit, .exr: float) ; OUT.json is the sidecar");
  render->add_option("--maps", render_args->maps, "extra maps: transmission,light,veil,psf,noise");
  render->add_option("--seed", render_args->seed, "random seed (overrides the parameters' seed)");
  render->add_option("--water", render_args->water,
                     "water type: custom, I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C");
  render
      ->add_option("--beta", render_args->beta,
                   "attenuation 1/m: one value for all channels or R,G,B")
      ->delimiter(',');
  render->add_option("--bit-depth", render_args->bit_depth, "camera output: 8, 16 or 32 (float)");
  render->add_option("--set", render_args->sets,
                     "KEY=VALUE on the JSON parameters, e.g. psf.forward_scatter=0.5 (repeatable)")
      ->allow_extra_args(false);
  render->add_option("--scale", render_args->scale, "size scale in (0, 1] for built-in scenes");
  render->add_flag("--explain", render_args->explain,
                   "print the render plan (what is computed and skipped)");
  render->add_flag("--force", render_args->force, "replace existing outputs");
  render->callback([render_args] {
    if (render_args->out.empty() && !render_args->explain)
      throw Error("render: --out is required (or --explain)");
    RunRender(*render_args);
  });

  auto config = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  auto threads =
      std::make_shared<int>(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  CLI::App* generate =
      app.add_subcommand("generate", "render a dataset: scenes x parameter grid / random samples");
  generate->add_option("config", *config, "dataset config JSON (docs/cli/render.md)")->required();
  generate->add_option("--out", *out, "output folder (resumes when it holds a previous run)")
      ->required();
  generate->add_option("--threads", *threads, "worker threads (output bytes do not depend on it)")
      ->check(CLI::Range(1, 256));
  generate->callback([config, out, threads] { RunGenerate(*config, *out, *threads); });
}

}  // namespace turbid
