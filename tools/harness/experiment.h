// Experiment files: scenes x simulator-parameter grid and/or seeded random samples x enhancement
// methods x metrics, scored against a chosen ground truth. Schema and examples:
// docs/experiments.md.
//
// This file knows nothing about the simulator's, enhancer's or metrics' internals: parameters are
// JSON paths into the render-options JSON ("water.beta_per_m", "psf.T"), and names are checked
// through an injected HarnessCatalog (the real one reads the registries, tests pass a fake), so
// that the whole experiment is validated before any work starts.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tools/harness/score_domain.h"

namespace turbid {

struct RenderOptions;  // simulator/render.h; only the catalog and the item runner look inside

// Render options as the catalog resolves them: parsed once, and as JSON with every default filled
// in (what experiment.json records).
struct ResolvedRender {
  nlohmann::json json;
  // What a render takes; null from catalogs without a simulator (the tests' fakes).
  std::shared_ptr<const RenderOptions> options;
};

// What the harness needs to know about one metric (copied from the metrics registry).
struct HarnessMetricInfo {
  std::string name;
  bool higher_is_better = true;
  bool needs_reference = false;
  bool needs_original = false;
  // A front-end metric of sequences (tools/harness/sweep_sequence.h): scored on pairs of frames
  // of a sequence scene, for each method and for the clean frames (the ground-truth column).
  bool sequence = false;
};

// Name checks and option resolution, injected so that parsing is testable without the modules.
// Every function throws turbid::Error with a one-line message when the name/value is unusable.
struct HarnessCatalog {
  // Checks that the method exists and that every key of `params` is one of its parameters.
  std::function<void(const std::string& method, const nlohmann::json& params)> check_method;
  // Whether the method with these params is privileged (receives true simulation parameters,
  // SPEC "Fair comparisons"); unset: none is.
  std::function<bool(const std::string& method, const nlohmann::json& params)> is_privileged;
  // Returns what the registry says about the metric; throws for unknown names.
  std::function<HarnessMetricInfo(const std::string& metric)> find_metric;
  // Parses render options strictly and returns them parsed and fully resolved (defaults filled in).
  std::function<ResolvedRender(const nlohmann::json& render_options)> resolve_render;
  // Checks a scene spec ("builtin:NAME", a bare built-in name, or a scene JSON path).
  std::function<void(const std::string& spec)> check_scene;
  // Sequences (docs/experiments.md "Sequences"): the number of frames of `spec` flown along
  // `trajectory` (a built-in scene; null for none) or of an rgbd_sequence file, 0 when the scene
  // is a single frame (then check_scene checks it); *resolved receives the trajectory with every
  // default (null for files). Throws Error. Unset: no scene is a sequence.
  std::function<int(const std::string& spec, double scale, const nlohmann::json& trajectory,
                    nlohmann::json* resolved)>
      sequence_frames;
  // Name of the identity row (the degraded input scored as it is); never sent to check_method.
  std::string identity_method = "none";
  // Where each item's seed goes in the render options when the experiment does not say.
  std::string default_seed_path;
  // Rows added when the experiment does not list them (the identity row always; "oracle" when
  // check_method accepts it), so every table shows the degraded input and the oracle-parameter LMMSE reference.
  std::vector<std::string> reference_methods = {"none", "oracle"};
};

struct ExperimentScene {
  std::string spec;       // "builtin:hull" or a scene JSON path, as written in the experiment file
  std::string load_spec;  // spec with a relative path resolved against the experiment file's folder
                          // (not saved: shards on other machines resolve it themselves)
  std::string name;       // unique short id used in item ids, tables and file names ([A-Za-z0-9_-])
  double scale = 1.0;     // built-in scenes: output size scale in (0, 1]; must be 1 for scene files
  // Sequences: the built-in scene's trajectory with every default (null for rgbd_sequence files
  // and single frames) and the frame count (0: a single frame). Each frame is an item.
  nlohmann::json trajectory;
  int frames = 0;
  bool IsSequence() const { return frames > 0; }
};

struct ExperimentMethod {
  std::string name;   // registry key ("none" is the identity row)
  std::string label;  // column name in tables (defaults to name); unique
  nlohmann::json params = nlohmann::json::object();  // overrides of the method's defaults
  // Receives true simulation parameters (the registry's IsPrivileged for name + params): marked
  // with a dagger in tables and the report, never marked best.
  bool privileged = false;
  // An external method (a program or a results folder, tools/harness/external_method.h): its
  // resolved spec as saved in experiment.json; null for registry methods.
  nlohmann::json external;
  // The experiment file's folder: relative 'cwd' and 'results' paths resolve against it (not
  // saved: shards on other machines resolve it themselves).
  std::string base_dir;
  bool IsExternal() const { return !external.is_null(); }
  bool IsBatch() const { return IsExternal() && external.value("batch", false); }
};

// One randomly sampled parameter. Values are drawn from a counter-based generator keyed by
// (samples.seed, condition, parameter), so they do not depend on threads, shards or order.
struct SampledParam {
  std::string path;              // dotted path into the render options
  std::string distribution;      // "uniform", "log_uniform", "int_uniform" or "choice"
  double low = 0.0, high = 0.0;  // bounds for the continuous/integer distributions
  nlohmann::json choices;        // array of JSON values for "choice"
};

struct Experiment {
  std::string name;  // short name ([A-Za-z0-9_.-])
  std::string description;
  std::string source_path;  // the file it was read from (not part of the resolved JSON)
  uint64_t seed = 1;        // seeds each item's render (noise, marine snow)
  std::vector<ExperimentScene> scenes;
  nlohmann::json render = nlohmann::json::object();  // base render options (before grid values)
  nlohmann::json render_resolved;  // base render options with every default filled in
  // Grid: ordered (path, values) pairs; the cartesian product, last path varying fastest.
  std::vector<std::pair<std::string, std::vector<nlohmann::json>>> grid;
  int sample_count = 0;  // random draws per grid point (0: grid only)
  uint64_t sample_seed = 1;
  std::vector<SampledParam> sampled;
  std::string level_path;  // the parameter whose value is the "turbidity level" in tables
  int level_bins = 4;      // bins when the level parameter is sampled continuously
  std::string seed_path;   // where each item's seed goes in the render options ("" = none)
  std::vector<ExperimentMethod> methods;
  std::vector<HarnessMetricInfo> metrics;
  std::string ground_truth = "clean";      // "clean" (rho) or "lit" (J = (E_A + E_L) rho)
  // Where full-reference metrics compare (tools/harness/score_domain.h): camera-coded by default;
  // a resolved file without the key was scored before it existed, in linear light.
  ScoreDomain score_domain = ScoreDomain::kEncoded;
  // The split's role (docs/methods.md "Tuning and evaluation splits"): "tuning" (defaults are
  // chosen on it), "evaluation" (they are only reported on it) or "" (not said).
  std::string split;
  // Method labels never marked best (floor/identity rows, and every privileged method).
  std::vector<std::string> best_excludes;
  int thumbnail_width = 160;  // thumbnails saved during the sweep for the report (0: none)
  // Each condition's render options as the catalog parsed them (seed 0 at seed_path), parsed once
  // by ParseExperiment and handed to its items; not saved (empty when read from a resolved file).
  std::vector<std::shared_ptr<const RenderOptions>> condition_render;

  int ConditionCount() const;  // grid points x max(1, sample_count)
  // Items of one scene: conditions x frames (a sequence) or conditions.
  int SceneItemCount(int scene) const;
  bool HasSequenceMetrics() const;
  // > 0: the items are listed, not expanded from the grid (a dataset scored by `turbid score
  // --results`); ItemCount() returns it.
  int listed_items = 0;
  int ItemCount() const {
    if (listed_items > 0) return listed_items;
    int count = 0;
    for (int s = 0; s < static_cast<int>(scenes.size()); ++s) count += SceneItemCount(s);
    return count;
  }
  // The resolved experiment as canonical JSON: what is saved as DIR/experiment.json and compared
  // on resume and merge.
  nlohmann::json ToJson() const;
};

// Parses and validates; throws turbid::Error("<file>: <problem>") on the first problem.
// `source_path` is used in messages and to resolve relative scene paths.
Experiment ParseExperiment(const nlohmann::json& json, const std::string& source_path,
                           const HarnessCatalog& catalog);
Experiment LoadExperimentFile(const std::string& path, const HarnessCatalog& catalog);
// The top-level keys an experiment file may hold, from its field table (docs/experiments.md's
// table of keys is checked against it).
std::vector<std::string> ExperimentFileKeys();
// Reads DIR/experiment.json written by a sweep (no catalog needed: it is already resolved).
Experiment ExperimentFromResolvedJson(const nlohmann::json& json, const std::string& source);

// One unit of work: one scene under one parameter condition; every method is run on it.
struct ItemSpec {
  int index = 0;   // position in the global order (scene-major, then condition)
  std::string id;  // "<scene>-c<condition, zero-padded>"; sorts like index within a scene
  int scene_index = 0;
  int condition = 0;
  std::string level;              // table label of the level parameter's value
  double level_value = 0.0;       // numeric position for plots (the value, or the level's rank)
  nlohmann::json params;          // {path: value} for every gridded and sampled parameter
  nlohmann::json render_options;  // base render options with params (and seed) applied
  // The condition's parsed render options (Experiment::condition_render; null when it has none):
  // render_options without the seed, which the item runner sets from `seed`.
  std::shared_ptr<const RenderOptions> render;
  uint64_t seed = 0;
  // Sequences: the frame (0-based; -1 for a single-frame scene) and the seed its scene and
  // condition share over all frames (what stays fixed along the sequence, e.g. world-space snow).
  int frame = -1;
  uint64_t sequence_seed = 0;
};

// Every item in the global order; deterministic.
std::vector<ItemSpec> ExpandItems(const Experiment& experiment);
// The ordered level labels (first appearance in the global order).
std::vector<std::string> LevelLabels(const Experiment& experiment);

// Parses "i/N" (0 <= i < N); throws Error.
struct Shard {
  int index = 0;
  int count = 1;
  bool Contains(int item_index) const { return item_index % count == index; }
};
Shard ParseShard(const std::string& text);

// Sets a dotted path ("a.b.c") in a JSON object, creating objects on the way; throws Error when
// an intermediate value is not an object.
void SetJsonPath(nlohmann::json& root, const std::string& path, const nlohmann::json& value);
const nlohmann::json* FindJsonPath(const nlohmann::json& root, const std::string& path);

// SplitMix64: the counter-based mixer behind every seed and random draw of the harness.
uint64_t MixSeed(uint64_t value);

}  // namespace turbid
