// `turbid generate` as a library (tools/harness/generate.h). Moved out of tools/cli/cmd_render.cc
// unchanged so that the Python package expands and samples items exactly as the CLI does.
#include "tools/harness/generate.h"

#include <array>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_io.h"
#include "core/limits.h"
#include "core/safe_name.h"
#include "scenes/image_io.h"
#include "scenes/scene_loader.h"
#include "simulator/noise.h"
#include "simulator/render.h"
#include "tools/harness/config_fields.h"
#include "tools/harness/experiment_grid.h"
#include "tools/harness/param_tree.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

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
      // An index into the list, or its size to append one entry; nothing further (a huge index
      // would append entries until memory runs out).
      const bool digits = !key.empty() && key.size() <= 9 &&
                          key.find_first_not_of("0123456789") == std::string::npos;
      if (!digits)
        throw Error("parameter path '" + path + "': '" + key + "' is not an array index");
      const size_t index = std::stoul(key);
      if (index > node->size())
        throw Error("parameter path '" + path + "': index " + key +
                    " is past the end of a list of " + std::to_string(node->size()) + " (index " +
                    std::to_string(node->size()) + " appends one)");
      if (index == node->size()) node->push_back(json::object());
      node = &(*node)[index];
    } else {
      if (!node->is_object()) *node = json::object();
      node = &(*node)[key];
    }
    if (last) *node = value;
  }
}

// Writes an image as PNG (`png_bits`, values coded with `transfer`) or float EXR / PFM (linear).
void WriteMap(const std::string& path, const cv::Mat& image, int png_bits, bool overwrite,
              Transfer transfer = Transfer::kLinear) {
  WriteImageOptions options;
  options.bit_depth = png_bits;
  options.overwrite = overwrite;
  options.transfer = transfer;
  WriteImage(path, image, options);
}

// The encoding of an item's image and ground-truth files (linear for EXR datasets).
std::string FileEncodingName(const json& params, const std::string& format) {
  if (format == "exr") return "linear";
  RenderOptions options = RenderOptionsFromJson(params);
  return CameraEncodingName(options.camera.FileEncoding());
}

}  // namespace

// SetPath for render parameters: indexing a light ("light.lights.0.power") starts from the
// default light list when the parameters name none, so defaults are not written twice.
void SetRenderParam(json& params, const std::string& path, const json& value) {
  if (path.rfind("light.lights.", 0) == 0 &&
      !(params.contains("light") && params["light"].is_object() &&
        params["light"].contains("lights"))) {
    // A "light" that is not an object is replaced, as SetPath replaces any non-object on a path.
    if (!params.contains("light") || !params["light"].is_object()) params["light"] = json::object();
    params["light"]["lights"] = RenderOptionsToJson(RenderOptions{})["light"]["lights"];
  }
  SetPath(params, path, value);
}

// "--set key=value": value parsed as JSON, else taken as a string.
void ApplyRenderSet(json& params, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw Error("--set '" + assignment + "': expected KEY=VALUE");
  const std::string key = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  // The flag as the error names it (a long value shortened: the message stays one short line).
  const std::string shown = assignment.size() > 60 ? assignment.substr(0, 57) + "..." : assignment;
  std::optional<json> value = ParseJsonIfValid(text, "--set '" + shown + "'");
  MergeRenderParam(params, key, value ? std::move(*value) : json(text));  // an object merges
}

// One draw of a "random.params" entry: the sweep's samplers (experiment_grid.h), so the same
// distributions and checks hold in both.
json SampleValue(const json& spec, uint64_t key, uint64_t index, const std::string& path) {
  return DrawDistribution(ParseDistribution(spec, "generate", "random.params." + path),
                          RandomUniform(key, index));
}

json GeneratePreset(const std::string& name) {
  // The UWCNN synthesis recipes (Li, Anwar & Porikli 2020; docs/model.md "Models"): the ten
  // Jerlov types with equal probability, a distance scale and the background light as published,
  // no forward scatter, snow or noise (the recipes have none).
  const json no_extras = {{"psf", {{"enabled", false}}},
                          {"snow", {{"enabled", false}}},
                          {"sensor", {{"enabled", false}}}};
  const json types = json::array({"I", "IA", "IB", "II", "III", "1C", "3C", "5C", "7C", "9C"});
  if (name == "uwcnn_nyu") {
    json base = no_extras;
    base["model"] = "uwcnn";
    base["uwcnn"] = {{"backlight_scale", 1.5}};
    return {{"base", base},
            {"random_params",
             {{"uwcnn.type", {{"choice", types}}},
              {"uwcnn.max_distance_m", {{"uniform", {0.5, 15.0}}}},
              {"uwcnn.backlight_exponent", {{"uniform", {3.0, 5.0}}}}}}};
  }
  if (name == "uwcnn_constant_b") {
    json base = no_extras;
    base["model"] = "uwcnn";
    base["uwcnn"] = {{"backlight_scale", 0.8}, {"backlight_exponent", 0.0}};
    return {{"base", base},
            {"random_params",
             {{"uwcnn.type", {{"choice", types}}},
              {"uwcnn.max_distance_m", {{"uniform", {0.5, 10.0}}}}}}};
  }
  throw Error("generate: preset: unknown preset '" + name + "' (uwcnn_nyu, uwcnn_constant_b)");
}

namespace {

// The keys of a generate config as written (absent: nullopt / null), checked for type and range
// by their field tables (core/fields.h); docs/cli/render.md's table is checked against them.
struct GenerateKeys {
  json scenes;
  std::optional<double> scale;
  json base, grid, random;
  std::optional<uint64_t> seed;
  std::string format = "png";
  std::optional<std::string> preset;
  json water_from;
};

const Fields<GenerateKeys>& GenerateKeyFields() {
  static const Fields<GenerateKeys> fields = [] {
    using K = GenerateKeys;
    using config_fields::Shape;
    Fields<K> f;
    config_fields::Raw(f, "scenes", &K::scenes, Shape::kArray, "scene specs");
    config_fields::OptionalNumber(f, "scale", &K::scale, "built-in scene scale",
                                  NumberRange::Any());
    config_fields::OptionalUnsigned(f, "seed", &K::seed, "the dataset's seed");
    f.Choice("format", &K::format, {{"png", std::string("png")}, {"exr", std::string("exr")}},
             "image file format");
    config_fields::Raw(f, "base", &K::base, Shape::kObject, "render parameters of every item");
    config_fields::Raw(f, "grid", &K::grid, Shape::kObject, "path -> list of values");
    config_fields::Raw(f, "water_from", &K::water_from, Shape::kAny, "fitted water file(s)");
    config_fields::Raw(f, "random", &K::random, Shape::kObject, "random draws");
    config_fields::OptionalString(f, "preset", &K::preset, "uwcnn_nyu or uwcnn_constant_b");
    return f;
  }();
  return fields;
}

// The named preset's base and random draws (empty without "preset").
json ReadPreset(const GenerateKeys& keys, const std::string& config_path) {
  json preset = {{"base", json::object()}, {"random_params", json::object()}};
  if (keys.preset) {
    try {
      preset = GeneratePreset(*keys.preset);
    } catch (const Error& e) {
      throw Error(config_path, e.what());
    }
  }
  return preset;
}

// Grid: cartesian product over dotted parameter paths, in key order. Its size (times the
// samples) is checked against the item limit before the product is built.
std::vector<json> GridCombos(const json& grid, int64_t samples, const std::string& config_path) {
  std::vector<json> combos = {json::object()};
  if (grid.is_null()) return combos;
  int64_t points = samples;
  for (auto it = grid.begin(); it != grid.end(); ++it) {
    if (!it.value().is_array() || it.value().empty())
      throw Error(config_path, "'grid." + it.key() + "': must be a non-empty array");
    points = SaturatingProduct(points, static_cast<int64_t>(it.value().size()));
  }
  CheckItemCount(config_path, "the dataset (grid points x random.count)", points);
  for (auto it = grid.begin(); it != grid.end(); ++it) {
    std::vector<json> next;
    for (const json& combo : combos)
      for (const json& value : it.value()) {
        json c = combo;
        c[it.key()] = value;
        next.push_back(c);
      }
    combos = next;
  }
  return combos;
}

// The "random" block, with the preset's draws under it.
void ReadRandom(const config_fields::DrawKeys& random, const json& preset,
                const std::string& config_path, GenerateConfig* out) {
  out->samples = static_cast<int>(random.count.value_or(1));
  out->random_seed = random.seed.value_or(out->seed);
  out->random_params = FlattenSamplers(random.params.is_null() ? json::object() : random.params,
                                       config_path, "random.params");
  if (!preset["random_params"].empty()) {
    json params = preset["random_params"];
    for (auto it = out->random_params.begin(); it != out->random_params.end(); ++it)
      params[it.key()] = it.value();
    out->random_params = params;
  }
}

// The scene specs, a multi-frame scene file (nyu_v2, folder) standing for every frame it selects.
void ReadScenes(const json& scenes, const std::string& config_path, GenerateConfig* out) {
  LoadSceneOptions scene_options;
  scene_options.builtin_scale = out->scale;
  ThrowIfInvalid(scene_options, config_path + ": scale");
  for (const json& spec : scenes) {
    if (!spec.is_string()) throw Error(config_path, "scenes: entries must be strings");
    for (const std::string& one : ExpandSceneSpec(spec.get<std::string>()))
      out->scene_specs.push_back(one);
  }
  CheckItemCount(
      config_path, "the dataset (scenes x grid points x random.count)",
      SaturatingProduct(static_cast<int64_t>(out->scene_specs.size()),
                        SaturatingProduct(static_cast<int64_t>(out->combos.size()), out->samples)));
}

// "water_from": one fit file or a non-empty list of them (each read and checked now).
void ReadWaterFrom(const json& value, const std::string& config_path, GenerateConfig* out) {
  if (value.is_null()) return;
  const char* expected =
      "water_from: a fit file (turbid water fit --out) or a non-empty list of them";
  std::vector<std::string> paths;
  if (value.is_string()) {
    paths.push_back(value.get<std::string>());
  } else if (value.is_array() && !value.empty()) {
    for (const json& one : value) {
      if (!one.is_string()) throw Error(config_path, expected);
      paths.push_back(one.get<std::string>());
    }
  } else {
    throw Error(config_path, expected);
  }
  CheckItemCount(config_path, "water_from", static_cast<int64_t>(paths.size()));
  for (const std::string& path : paths) out->water_from.push_back(ReadWaterSource(path));
}

}  // namespace

std::vector<std::string> GenerateConfigKeys() { return GenerateKeyFields().Keys(); }

WaterSource ReadWaterSource(const std::string& path) {
  if (path.empty()) throw Error("water_from: an empty file name");
  WaterSource source;
  source.path = path;
  source.params = ReadJsonFile(path);
  if (!source.params.is_object())
    throw Error(path, "water_from: must be a JSON object (a turbid water fit output)");
  for (auto it = source.params.begin(); it != source.params.end(); ++it) {
    if (it.key() != "model" && it.key() != "water" && it.key() != "revised" && it.key() != "light")
      throw Error(path, "water_from: key '" + PrintableName(it.key()) +
                            "' is not part of a water (model, water, revised, light)");
    // null would delete the base's section when merged (JSON merge patch).
    if (it.value().is_null()) throw Error(path, "water_from: " + it.key() + ": must not be null");
  }
  try {
    RenderOptionsFromJson(source.params);
  } catch (const Error& e) {
    throw Error(path, e.what());
  }
  return source;
}

int WaterFromIndex(const GenerateConfig& config, uint64_t draw_index) {
  const size_t n = config.water_from.size();
  if (n == 0) return -1;
  if (n == 1) return 0;
  // The same choice as a {"choice": [...]} draw, on a stream of its own.
  const double u = RandomUniform(RandomKey(config.random_seed, 0x77a7), draw_index);
  return static_cast<int>(std::min(n - 1, static_cast<size_t>(u * static_cast<double>(n))));
}

json DrawItemParams(const GenerateConfig& config, size_t g, uint64_t draw_index) {
  json params = config.base;
  const int water = WaterFromIndex(config, draw_index);
  if (water >= 0) params.merge_patch(config.water_from[water].params);
  for (auto it = config.combos.at(g).begin(); it != config.combos.at(g).end(); ++it)
    SetRenderParam(params, it.key(), it.value());
  // Random samples depend on (random seed, grid point, sample number), not on the scene.
  ApplyRandomDraw(params, config.random_params, config.random_seed, draw_index);
  return params;
}

GenerateConfig ParseGenerateConfig(const json& config, const std::string& config_path) {
  if (!config.is_object()) throw Error(config_path, "must be a JSON object");
  GenerateKeys keys;
  GenerateKeyFields().Read(config, &keys, config_path);
  config_fields::DrawKeys random;
  config_fields::DrawKeyFields().Read(keys.random, &random, config_path, "random");
  const json preset = ReadPreset(keys, config_path);
  if (!keys.scenes.is_array() || keys.scenes.empty())
    throw Error(config_path, "scenes: a non-empty array of scene specs is required");
  GenerateConfig out;
  out.source = config_path;
  out.scale = keys.scale.value_or(1.0);
  out.seed = keys.seed.value_or(0);
  out.format = keys.format;
  // A preset's base and random draws come first; the config's own entries override them.
  out.base = preset["base"];
  if (!keys.base.is_null()) out.base.merge_patch(ExpandDottedKeys(keys.base, config_path));
  RenderOptionsFromJson(out.base);  // fail early on a bad base
  out.combos = GridCombos(keys.grid, random.count.value_or(1), config_path);
  ReadRandom(random, preset, config_path, &out);
  ReadWaterFrom(keys.water_from, config_path, &out);
  ReadScenes(keys.scenes, config_path, &out);
  return out;
}

void ApplyRandomDraw(json& params, const json& random_params, uint64_t random_seed,
                     uint64_t draw_index) {
  const uint64_t sample_key = RandomKey(random_seed, 0x5a4d);
  uint64_t draw = 0;
  for (auto it = random_params.begin(); it != random_params.end(); ++it, ++draw)
    SetRenderParam(params, it.key(),
                   SampleValue(it.value(), sample_key, draw_index * 64 + draw, it.key()));
}

uint64_t GenerateItemSeed(uint64_t seed, uint64_t index) {
  return RandomBits(RandomKey(seed, 0x5eed), index) >> 1;
}

std::vector<GenerateItem> ExpandGenerateItems(const GenerateConfig& config,
                                              const std::vector<std::string>& scene_names) {
  // Scene names become file names (images/<name>_<index>.png, ...): one plain component each.
  for (const std::string& name : scene_names) {
    std::string why;
    if (!IsSafeFileComponent(name, &why))
      throw Error(config.source, "scene name '" + PrintableName(name) + "' " + why);
  }
  // Items and their fully resolved parameters (validated before any rendering starts).
  std::vector<GenerateItem> items;
  for (size_t s = 0; s < config.scene_specs.size(); ++s)
    for (size_t g = 0; g < config.combos.size(); ++g)
      for (int r = 0; r < config.samples; ++r) {
        GenerateItem item;
        item.index = static_cast<int>(items.size());
        item.scene = s;
        const uint64_t draw = g * config.samples + r;
        json params = DrawItemParams(config, g, draw);
        const int water = WaterFromIndex(config, draw);
        if (water >= 0) item.water_from = config.water_from[water].path;
        if (!params.contains("seed")) params["seed"] = GenerateItemSeed(config.seed, item.index);
        try {
          params = RenderOptionsToJson(RenderOptionsFromJson(params));
        } catch (const Error& e) {
          throw Error(config.source,
                      std::string("item ") + std::to_string(item.index) + ": " + e.what());
        }
        item.params = params;
        std::ostringstream id;
        id << scene_names.at(s) << "_" << std::setw(6) << std::setfill('0') << item.index;
        item.id = id.str();
        items.push_back(item);
      }
  return items;
}

namespace {

// An item's four outputs: degraded image, ground truth, lit J and sidecar (written last).
using ItemPaths = std::array<std::string, 4>;

ItemPaths PathsOf(const GenerateItem& item, const std::string& out_dir, const std::string& ext) {
  const fs::path dir(out_dir);
  return ItemPaths{(dir / "images" / (item.id + ext)).string(),
                   (dir / "ground_truth" / (item.id + ext)).string(),
                   (dir / "lit" / (item.id + ".pfm")).string(),
                   (dir / "sidecars" / (item.id + ".json")).string()};
}

// Two outputs never share a file (on a case-insensitive file system either), e.g. an item's
// degraded image and its ground truth.
void CheckDistinctOutputs(const std::vector<GenerateItem>& items, const std::string& out_dir,
                          const std::string& ext) {
  std::map<std::string, std::string> owners;  // FileNameKey(path) -> item id
  for (const GenerateItem& item : items) {
    for (const std::string& path : PathsOf(item, out_dir, ext)) {
      const auto [it, inserted] = owners.emplace(FileNameKey(path), item.id);
      if (!inserted) {
        throw Error(path, "would be written twice (items '" + it->second + "' and '" + item.id +
                              "'); give the scenes distinct names");
      }
    }
  }
}

// Holding the folder's lock: removes the temporaries that killed earlier runs left
// (".NAME.tmpXXXX"; their items are rendered again) and creates the output folders.
void PrepareOutputFolders(const std::string& out_dir) {
  RemoveStaleTemporaries(out_dir, /*recursive=*/false);
  for (const char* sub : {"images", "ground_truth", "lit", "sidecars"}) {
    // Clean-up never follows a link: a planted link would aim it at another folder.
    RefuseSymlink((fs::path(out_dir) / sub).string(), "cleans and writes");
    RemoveStaleTemporaries((fs::path(out_dir) / sub).string(), /*recursive=*/true);
    std::error_code ec;
    fs::create_directories(fs::path(out_dir) / sub, ec);
    if (ec) throw OutputError((fs::path(out_dir) / sub).string(), "cannot create: " + ec.message());
  }
}

// An item is complete when its sidecar (written last) exists and names the same parameters.
bool IsComplete(const GenerateItem& item, const ItemPaths& p) {
  if (!fs::exists(p[3])) return false;
  for (int i = 0; i < 3; ++i)
    if (!fs::exists(p[i])) return false;
  try {
    return ReadJsonFile(p[3]).at("options") == item.params;
  } catch (...) {
    return false;
  }
}

// Renders one item and writes its outputs, the sidecar last.
void RenderItem(const GenerateConfig& config, const Renderer& renderer, const GenerateItem& item,
                const ItemPaths& p, const std::string& ext) {
  const std::string& format = config.format;
  RenderOptions options = RenderOptionsFromJson(item.params);
  if (format == "exr") options.camera.bit_depth = 32;
  const RenderResult result = renderer.Render(options);
  const int bits = options.camera.bit_depth == 32 ? 16 : options.camera.bit_depth;
  // The ground truth goes through the same camera (encoding and bit depth) as the image,
  // so an identity render scores SSIM 1 against it; lit J is float (PFM), linear.
  const CameraEncoding encoding = options.camera.FileEncoding();
  const cv::Mat& clean = renderer.scene().image;
  WriteMap(p[0], result.image, bits, true, TransferFor(encoding));
  WriteMap(p[1], format == "exr" ? clean : QuantiseEncoded(clean, encoding, bits), bits, true,
           TransferFor(encoding));
  WriteMap(p[2], result.lit, 16, true);
  RenderRecord record = result.sidecar;
  record.scene.spec = config.scene_specs[item.scene];
  record.scene.builtin_scale = config.scale;
  record.item = RenderRecord::Item{item.index, item.id};
  record.outputs = {{"image", "images/" + item.id + ext},
                    {"ground_truth", "ground_truth/" + item.id + ext},
                    {"lit", "lit/" + item.id + ".pfm"}};
  json sidecar = record.ToJson();
  // generate records the options as its config gave them (the resume check above
  // compares them with the item's).
  sidecar["options"] = item.params;
  AtomicWriteText(p[3], sidecar.dump(2) + "\n", true);
}

// The items rendered by `threads` workers; the first failure stops them and is thrown once all
// have joined. Returns the items skipped as already complete.
int RenderItems(const GenerateConfig& config, const std::vector<GenerateItem>& items,
                const std::vector<std::unique_ptr<Renderer>>& renderers, const std::string& out_dir,
                const std::string& ext, int threads) {
  std::atomic<int> next{0}, done{0}, skipped{0};
  std::atomic<bool> progress_shown{false};
  std::mutex error_mutex;
  std::string first_error;
  bool output_error = false;
  auto worker = [&] {
    for (;;) {
      const int i = next.fetch_add(1);
      if (i >= static_cast<int>(items.size())) return;
      {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!first_error.empty()) return;
      }
      const GenerateItem& item = items[i];
      try {
        const ItemPaths p = PathsOf(item, out_dir, ext);
        if (IsComplete(item, p)) {
          ++skipped;
        } else {
          RenderItem(config, *renderers[item.scene], item, p, ext);
        }
        const int n = ++done;
        if (n % 10 == 0 || n == static_cast<int>(items.size())) {
          std::cerr << "generate: " << n << "/" << items.size() << " items\r" << std::flush;
          progress_shown = true;
        }
      } catch (const OutputError& e) {
        // A write of ours failed (a full disk...): the message names the file; the complete
        // items stay, so a rerun after freeing space finishes the same bytes.
        std::lock_guard<std::mutex> lock(error_mutex);
        if (first_error.empty()) {
          first_error = std::string(e.what()) +
                        "; generate stopped (complete items are kept: run it again to continue)";
          output_error = true;
        }
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
  if (progress_shown) std::cerr << "\n";  // an error after it starts a line of its own
  if (output_error) throw OutputError(first_error);
  if (!first_error.empty()) throw Error("generate: " + first_error);
  return skipped.load();
}

// Manifest in item order: the same bytes whatever the thread count or interruption history.
void WriteManifest(const GenerateConfig& config, const std::vector<GenerateItem>& items,
                   const std::string& out_dir, const std::string& ext) {
  const std::vector<std::string>& specs = config.scene_specs;
  const std::string& format = config.format;
  std::string csv =
      "index,id,scene,image,ground_truth,lit,sidecar,seed,beta_r,beta_g,beta_b,beta_gray,psf_T,psf_"
      "q,encoding\n";
  std::string jsonl;
  for (const GenerateItem& item : items) {
    const json& o = item.params;
    const json& b = o["water"]["beta_rgb_per_m"];
    std::ostringstream row;
    row << item.index << "," << item.id << "," << CsvEscape(specs[item.scene]) << ",images/"
        << item.id << ext << ",ground_truth/" << item.id << ext << ",lit/" << item.id
        << ".pfm,sidecars/" << item.id << ".json," << o["seed"].get<uint64_t>() << ","
        << b[0].dump() << "," << b[1].dump() << "," << b[2].dump() << ","
        << o["water"]["beta_gray_per_m"].dump() << "," << o["psf"]["optical_thickness"].dump()
        << "," << o["psf"]["forward_scatter"].dump() << "," << FileEncodingName(o, format) << "\n";
    csv += row.str();
    json row_json = {{"index", item.index},
                     {"id", item.id},
                     {"scene", specs[item.scene]},
                     {"image", "images/" + item.id + ext},
                     {"ground_truth", "ground_truth/" + item.id + ext},
                     {"lit", "lit/" + item.id + ".pfm"},
                     {"sidecar", "sidecars/" + item.id + ".json"},
                     {"encoding", FileEncodingName(o, format)},
                     {"options", o}};
    // Every row has the same keys (ReadManifest): water_from when the config has it.
    if (!config.water_from.empty()) row_json["water_from"] = item.water_from;
    jsonl += row_json.dump() + "\n";
  }
  AtomicWriteText((fs::path(out_dir) / "manifest.csv").string(), csv, true);
  AtomicWriteText((fs::path(out_dir) / "manifest.jsonl").string(), jsonl, true);
}

}  // namespace

void RunGenerate(const GenerateConfig& config, const std::string& out_dir, int threads) {
  LoadSceneOptions scene_options;
  scene_options.builtin_scale = config.scale;
  std::vector<std::unique_ptr<Renderer>> renderers;
  std::vector<std::string> names;
  for (const std::string& spec : config.scene_specs) {
    renderers.push_back(std::make_unique<Renderer>(LoadScene(spec, scene_options)));
    names.push_back(renderers.back()->scene().name);
  }
  const std::vector<GenerateItem> items = ExpandGenerateItems(config, names);
  const std::string ext = "." + config.format;
  CheckDistinctOutputs(items, out_dir, ext);
  // One generate per folder at a time.
  const FolderLock lock(out_dir, "generate");
  PrepareOutputFolders(out_dir);
  const int skipped = RenderItems(config, items, renderers, out_dir, ext, threads);
  WriteManifest(config, items, out_dir, ext);
  std::cout << "generate: " << items.size() << " items (" << skipped << " already complete) in "
            << out_dir << "\n";
}

}  // namespace turbid
