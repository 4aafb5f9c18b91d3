// `turbid generate` as a library: the dataset config (scenes x grid x seeded random samples), its
// expansion into items with fully resolved render parameters, the random sampler, and the run that
// writes the dataset. The CLI (tools/cli/cmd_render.cc) and the Python package (python/) both call
// these, so an item's parameters are the same whoever renders it. Config schema: docs/cli/render.md.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace turbid {

// One fitted water of a config's "water_from": the file and the render parameters it holds (a
// `turbid water fit` output: only the keys model, water, revised and light).
struct WaterSource {
  std::string path;
  nlohmann::json params = nlohmann::json::object();
};

// A parsed and checked generate config (nothing loaded but the water_from files).
struct GenerateConfig {
  std::string source;                   // the config file (or "<dict>"), used in messages
  // "builtin:NAME" or scene JSON paths; multi-frame files expanded to "FILE.json#KEY" per frame
  std::vector<std::string> scene_specs;
  double scale = 1.0;                    // built-in scene scale in (0, 1]
  uint64_t seed = 0;                     // seeds each item's render (noise, snow)
  std::string format = "png";            // "png" or "exr"
  nlohmann::json base = nlohmann::json::object();  // base render parameters
  std::vector<nlohmann::json> combos;    // grid points: {dotted path: value}, key order
  int samples = 1;                       // random draws per grid point
  uint64_t random_seed = 0;              // seeds the random draws
  nlohmann::json random_params = nlohmann::json::object();  // dotted path -> distribution
  // "water_from": fitted waters; each draw takes one (seeded choice when several) over the base.
  std::vector<WaterSource> water_from;
};

// One dataset item: a scene and its fully resolved render parameters (seed included).
struct GenerateItem {
  int index = 0;
  std::string id;  // "<scene name>_<index, 6 digits>"
  size_t scene = 0;  // index into GenerateConfig::scene_specs
  nlohmann::json params;
  std::string water_from;  // the water_from file the item's water came from ("" without)
};

// A named preset: {"base": render parameters, "random_params": path -> distribution}. Known:
// "uwcnn_nyu" (UWCNN's NYU-v2 recipe: ten Jerlov types, farthest pixel at U(0.5, 15) m,
// B = 1.5 N^b with b ~ U(3, 5)) and "uwcnn_constant_b" (B = 0.8, farthest pixel at U(0.5, 10) m).
// A config's "preset" key applies one under its own base and random params. Throws Error.
nlohmann::json GeneratePreset(const std::string& name);

// Checks the config object; throws Error("<source>: <problem>") on the first problem.
GenerateConfig ParseGenerateConfig(const nlohmann::json& config, const std::string& source);
// The top-level keys a generate config may hold, from its field table (docs/cli/render.md's
// table is checked against it).
std::vector<std::string> GenerateConfigKeys();

// Every item in order (scene-major, then grid point, then sample); `scene_names` are the loaded
// scenes' names (for the ids). Throws Error("<source>: item N: <problem>") for a bad combination.
std::vector<GenerateItem> ExpandGenerateItems(const GenerateConfig& config,
                                              const std::vector<std::string>& scene_names);

// One draw of a distribution spec ({"uniform": [lo, hi]}, {"log_uniform": [lo, hi]} or
// {"choice": [...]}) from the counter-based generator (key, index); `path` names it in messages.
nlohmann::json SampleValue(const nlohmann::json& spec, uint64_t key, uint64_t index,
                           const std::string& path);

// Reads a `turbid water fit` output for "water_from": a JSON object whose keys are among model,
// water, revised and light and that `turbid render --params` accepts. Throws Error("<path>: ...").
WaterSource ReadWaterSource(const std::string& path);

// Which of config.water_from draw number `draw_index` takes (seeded by random.seed; 0 with one
// file); -1 without water_from.
int WaterFromIndex(const GenerateConfig& config, uint64_t draw_index);

// The parameters of grid point g for draw number `draw_index` (g * samples + r in generate), before
// the render seed: base, then the drawn water_from file's keys over it (as `turbid render --params
// FIT.json` reads them), then the grid point, then the random draw.
nlohmann::json DrawItemParams(const GenerateConfig& config, size_t g, uint64_t draw_index);

// Applies random draw number `draw_index` of `random_params` (dotted path -> distribution) to
// `params`, as generate does for grid point g and sample r with draw_index = g * samples + r.
void ApplyRandomDraw(nlohmann::json& params, const nlohmann::json& random_params,
                     uint64_t random_seed, uint64_t draw_index);

// The render seed generate gives item `index` when the parameters name none.
uint64_t GenerateItemSeed(uint64_t seed, uint64_t index);

// Sets a render parameter at a dotted path ("psf.forward_scatter", "light.lights.0.power");
// indexing a light starts from the default light list when the parameters name none.
void SetRenderParam(nlohmann::json& params, const std::string& path, const nlohmann::json& value);
// One `--set KEY=VALUE` of `turbid render`: VALUE parsed as JSON, else taken as a string, then
// SetRenderParam(params, KEY, value). Throws Error for text without "=" or with an empty KEY.
void ApplyRenderSet(nlohmann::json& params, const std::string& assignment);

// Renders the dataset into out_dir (resumable; output bytes independent of `threads`).
void RunGenerate(const GenerateConfig& config, const std::string& out_dir, int threads);

}  // namespace turbid
