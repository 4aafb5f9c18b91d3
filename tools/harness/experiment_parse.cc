// Reading an experiment file (docs/experiments.md, "The experiment file"): every key of the top
// level, of a scene, of 'samples' and of a registry method is declared once in a field table
// (core/fields.h), which checks its JSON type and range and refuses unknown keys, naming the key's
// path ("'scenes[1].scale'", "'samples.count'"). The semantic checks (names, paths, methods and
// metrics the catalog knows, render options) follow on the typed values.
#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "core/error.h"
#include "core/limits.h"
#include "core/safe_name.h"
#include "tools/harness/config_fields.h"
#include "tools/harness/experiment.h"
#include "tools/harness/experiment_grid.h"
#include "tools/harness/external_method.h"
#include "tools/harness/param_tree.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using config_fields::Shape;
using nlohmann::json;

// The keys of an experiment file as written (absent: nullopt / null), checked for type and range.
struct ExperimentKeys {
  std::optional<std::string> name;
  std::string description;
  std::optional<uint64_t> seed;
  json scenes;
  std::optional<double> scale;
  json render, grid, samples;
  std::optional<std::string> level;
  std::optional<int64_t> level_bins;
  std::optional<std::string> seed_path;
  json methods;
  std::optional<bool> reference_methods;
  std::optional<std::vector<std::string>> metrics;
  std::string ground_truth = "clean";
  ScoreDomain score_domain = ScoreDomain::kEncoded;
  std::string split;
  std::optional<std::vector<std::string>> best_excludes;
  std::optional<int> thumbnails;  // width in pixels; true = 160, false = 0
  json schema, comment;
};

// An object entry of 'scenes'.
struct SceneKeys {
  std::string spec;
  std::optional<std::string> name;
  std::optional<double> scale;
  json trajectory;
};

// An object entry of 'methods' naming a registry method (external methods have their own tables,
// external_method_spec.cc).
struct MethodKeys {
  std::string name;
  std::optional<std::string> label;
  json params = json::object();
};

const Fields<ExperimentKeys>& ExperimentKeyFields() {
  static const Fields<ExperimentKeys> fields = [] {
    using K = ExperimentKeys;
    Fields<K> f;
    config_fields::OptionalString(f, "name", &K::name, "short name, [A-Za-z0-9_.-], 1-64 chars");
    f.String("description", &K::description, "free text");
    config_fields::OptionalUnsigned(f, "seed", &K::seed, "the experiment's seed");
    config_fields::Raw(f, "scenes", &K::scenes, Shape::kArray, "scene specs or objects");
    config_fields::OptionalNumber(f, "scale", &K::scale, "default scale of built-in scenes",
                                  NumberRange::AboveUpTo(0.0, 1.0));
    config_fields::Raw(f, "render", &K::render, Shape::kObject, "base render options");
    config_fields::Raw(f, "grid", &K::grid, Shape::kObject, "{path: values}");
    config_fields::Raw(f, "samples", &K::samples, Shape::kObject, "random draws");
    config_fields::OptionalString(f, "level", &K::level, "the level parameter's path");
    config_fields::OptionalInteger(f, "level_bins", &K::level_bins, "bins of a sampled level", 1,
                                   100);
    config_fields::OptionalString(f, "seed_path", &K::seed_path, "where item seeds go");
    config_fields::Raw(f, "methods", &K::methods, Shape::kArray, "methods to run");
    config_fields::OptionalBoolean(f, "reference_methods", &K::reference_methods,
                                   "add the reference rows");
    config_fields::OptionalStrings(f, "metrics", &K::metrics, "metric names");
    f.Choice("ground_truth", &K::ground_truth,
             {{"clean", std::string("clean")}, {"lit", std::string("lit")}},
             "what the full-reference metrics compare against");
    f.Choice("score_domain", &K::score_domain,
             {{"encoded", ScoreDomain::kEncoded}, {"linear", ScoreDomain::kLinear}},
             "where full-reference metrics compare");
    f.Choice("split", &K::split,
             {{"tuning", std::string("tuning")}, {"evaluation", std::string("evaluation")}},
             "the scenes' role in a tuning / evaluation protocol");
    config_fields::OptionalStrings(f, "best_excludes", &K::best_excludes,
                                   "labels never marked best");
    config_fields::Optional(
        f, "thumbnails", "boolean or integer", "in [0, 4096]", "thumbnail width", &K::thumbnails,
        [](const json& v, int* out) -> std::string {
          if (v.is_boolean()) {
            *out = v.get<bool>() ? 160 : 0;
            return "";
          }
          int64_t width = 0;
          if (v.is_number() && fields_detail::IntegerProblem(v, 0, 4096, &width).empty()) {
            *out = static_cast<int>(width);
            return "";
          }
          return "expected true, false or a width in pixels in [0, 4096], got " +
                 fields_detail::ShownValue(v);
        });
    config_fields::Raw(f, "$schema", &K::schema, Shape::kAny, "ignored");
    config_fields::Raw(f, "comment", &K::comment, Shape::kAny, "ignored");
    return f;
  }();
  return fields;
}

const Fields<SceneKeys>& SceneKeyFields() {
  static const Fields<SceneKeys> fields = [] {
    Fields<SceneKeys> f;
    f.String("spec", &SceneKeys::spec, "builtin:NAME, a bare built-in name or a scene file");
    config_fields::OptionalString(f, "name", &SceneKeys::name, "the scene's unique name");
    config_fields::OptionalNumber(f, "scale", &SceneKeys::scale, "built-in scene scale",
                                  NumberRange::AboveUpTo(0.0, 1.0));
    config_fields::Raw(f, "trajectory", &SceneKeys::trajectory, Shape::kObject,
                       "a built-in scene flown along a trajectory");
    return f;
  }();
  return fields;
}

const Fields<MethodKeys>& MethodKeyFields() {
  static const Fields<MethodKeys> fields = [] {
    Fields<MethodKeys> f;
    f.String("name", &MethodKeys::name, "registry name");
    config_fields::OptionalString(f, "label", &MethodKeys::label, "column name");
    config_fields::Raw(f, "params", &MethodKeys::params, Shape::kObject, "parameter overrides");
    return f;
  }();
  return fields;
}

// The experiment file being parsed, for the parts of ParseExperiment.
struct ExperimentInput {
  const ExperimentKeys& keys;
  const std::string& file;
  const HarnessCatalog& catalog;
};

void CheckSceneName(const std::string& file, const std::string& name) {
  if (!IsSafeName(name) || name.find('.') != std::string::npos) {
    throw Error(
        file, "scene name '" + PrintableName(name) + "' must be 1-64 characters of [A-Za-z0-9_-]");
  }
}

// Sequences (frames) and single frames (checked by the catalog) alike.
void LoadSceneFrames(const ExperimentInput& x, bool builtin, const json& trajectory,
                     ExperimentScene* scene) {
  try {
    if (!builtin && !trajectory.is_null())
      throw Error("'trajectory' is for built-in scenes (an rgbd_sequence file has its poses)");
    if (x.catalog.sequence_frames) {
      scene->frames =
          x.catalog.sequence_frames(scene->load_spec, scene->scale, trajectory, &scene->trajectory);
    } else if (!trajectory.is_null()) {
      throw Error("sequences are not supported here");
    }
    if (!scene->IsSequence()) x.catalog.check_scene(scene->load_spec);
  } catch (const Error& error) {
    throw Error(x.file, std::string("scene '") + PrintableName(scene->spec) + "': " + error.what());
  }
}

ExperimentScene ParseScene(const ExperimentInput& x, const json& entry, size_t index) {
  const std::string& file = x.file;
  SceneKeys keys;
  if (entry.is_string()) {
    keys.spec = entry.get<std::string>();
  } else if (entry.is_object()) {
    SceneKeyFields().Read(entry, &keys, file, "scenes[" + std::to_string(index) + "]");
  } else {
    throw Error(file, "each scene must be a string or an object");
  }
  if (keys.spec.empty()) {
    throw Error(file, "each scene needs a 'spec' string (builtin:NAME or a scene file)");
  }
  ExperimentScene scene;
  scene.spec = keys.spec;
  scene.scale = keys.scale.value_or(x.keys.scale.value_or(1.0));
  // A bare name without folder or extension is a built-in scene, as in `turbid scene`.
  const bool builtin =
      scene.spec.rfind("builtin:", 0) == 0 ||
      (scene.spec.find('/') == std::string::npos && fs::path(scene.spec).extension().empty());
  scene.load_spec = scene.spec;
  const fs::path base_dir = fs::path(file).parent_path();
  if (!builtin && fs::path(scene.spec).is_relative() && !base_dir.empty()) {
    scene.load_spec = (base_dir / scene.spec).lexically_normal().string();
  }
  scene.name = keys.name.value_or(builtin ? scene.spec.substr(scene.spec.rfind(':') + 1)
                                          : fs::path(scene.spec).stem().string());
  CheckSceneName(file, scene.name);
  LoadSceneFrames(x, builtin, keys.trajectory, &scene);
  if (!builtin && scene.scale != 1.0) {
    throw Error(file, "scene '" + scene.spec + "': 'scale' applies to built-in scenes only");
  }
  return scene;
}

void ParseScenes(const ExperimentInput& x, Experiment* out) {
  const std::string& file = x.file;
  if (!x.keys.scenes.is_array() || x.keys.scenes.empty()) {
    throw Error(file, "'scenes' must be a non-empty array");
  }
  std::set<std::string> scene_names;
  std::map<std::string, std::string> scene_keys;  // FileNameKey -> scene name
  for (size_t i = 0; i < x.keys.scenes.size(); ++i) {
    ExperimentScene scene = ParseScene(x, x.keys.scenes[i], i);
    // A folder on a case-insensitive file system holds one of thumbs/Reef-c0 and thumbs/reef-c0.
    if (const auto [it, inserted] = scene_keys.emplace(FileNameKey(scene.name), scene.name);
        !inserted && it->second != scene.name) {
      throw Error(file, "scene names '" + it->second + "' and '" + scene.name +
                            "' differ only in case; their files would collide on a "
                            "case-insensitive file system");
    }
    if (!scene_names.insert(scene.name).second) {
      throw Error(file,
                  "scene name '" + scene.name + "' is used twice (give each a unique 'name')");
    }
    out->scenes.push_back(std::move(scene));
  }
}

// 'samples': count and params are required when it is given; the seed defaults to the
// experiment's.
void ParseSamples(const ExperimentInput& x, std::set<std::string>* swept, Experiment* out) {
  const std::string& file = x.file;
  config_fields::DrawKeys keys;
  config_fields::DrawKeyFields().Read(x.keys.samples, &keys, file, "samples");
  if (!keys.count) throw Error(file, "'samples.count' is required (an integer in [1, 1000000])");
  out->sample_count = static_cast<int>(*keys.count);
  out->sample_seed = keys.seed.value_or(out->seed);
  if (!keys.params.is_object() || keys.params.empty()) {
    throw Error(file, "'samples.params' must be a non-empty object {path: distribution}");
  }
  // Dotted paths and nested objects alike (param_tree.h), drawn in dotted-path order.
  const json sampled = FlattenSamplers(keys.params, file, "'samples.params'");
  for (const auto& [path, spec] : sampled.items()) {
    if (path.rfind('@', 0) == 0) throw Error(file, "named axes ('" + path + "') are grid-only");
    if (swept->count(path)) {
      throw Error(file, "parameter '" + path + "' is both in 'grid' and in 'samples'");
    }
    out->sampled.push_back(ParseSampled(path, spec, file));
    swept->insert(path);
  }
}

// The base render options, the grid and the samples; returns the swept paths.
std::set<std::string> ParseRenderGridAndSamples(const ExperimentInput& x, Experiment* out) {
  const std::string& file = x.file;
  Experiment& e = *out;
  if (!x.keys.render.is_null()) {
    e.render = ExpandDottedKeys(x.keys.render, file);  // "water.type" as {"water": {"type"}}
  }
  std::set<std::string> swept;
  if (!x.keys.grid.is_null()) {
    if (x.keys.grid.empty()) throw Error(file, "'grid' is empty: give at least one parameter");
    for (const auto& [path, values] : x.keys.grid.items()) {
      e.grid.emplace_back(path, GridValues(values, file, path));
      swept.insert(path);
    }
  }
  if (!x.keys.samples.is_null()) ParseSamples(x, &swept, out);
  if (e.grid.empty() && e.sampled.empty()) {
    throw Error(file, "empty grid: give 'grid' and/or 'samples' with at least one parameter");
  }
  // Counted without overflow and checked against the item limit before anything is expanded.
  int64_t scene_frames = 0;  // a sequence's frames are items each
  for (const ExperimentScene& scene : e.scenes) scene_frames += std::max(1, scene.frames);
  int64_t items = SaturatingProduct(std::max(1, e.sample_count), scene_frames);
  for (const auto& entry : e.grid)
    items = SaturatingProduct(items, static_cast<int64_t>(entry.second.size()));
  CheckItemCount(file, "the sweep (scenes x grid points x samples)", items);
  return swept;
}

void ParseLevelAndSeedPath(const ExperimentInput& x, const std::set<std::string>& swept,
                           Experiment* out) {
  const std::string& file = x.file;
  Experiment& e = *out;
  e.level_path =
      x.keys.level.value_or(e.grid.empty() ? e.sampled.front().path : e.grid.front().first);
  CheckLabelText(file, "'level'", e.level_path);
  if (!swept.count(e.level_path)) {
    throw Error(file, "'level' '" + e.level_path + "' is not a parameter of 'grid' or 'samples'");
  }
  if (x.keys.level_bins) e.level_bins = static_cast<int>(*x.keys.level_bins);
  e.seed_path = x.keys.seed_path.value_or(x.catalog.default_seed_path);
  if (!e.seed_path.empty() && swept.count(e.seed_path)) {
    throw Error(file, "'seed_path' '" + e.seed_path + "' is also a swept parameter");
  }
}

// The method's label is a column and a file name; the catalog must know a registry method.
void CheckListedMethod(const ExperimentInput& x, const ExperimentMethod& method) {
  const std::string& file = x.file;
  const HarnessCatalog& catalog = x.catalog;
  if (!IsSafeName(method.label) || method.label.find('.') != std::string::npos) {
    throw Error(file, "method label '" + PrintableName(method.label) +
                          "' must be 1-64 characters of [A-Za-z0-9_-]");
  }
  if (method.IsExternal()) {
    if (method.name == catalog.identity_method) {
      throw Error(file, "method name '" + method.name + "' is reserved for the degraded input");
    }
  } else if (method.name == catalog.identity_method) {
    if (!method.params.empty()) {
      throw Error(file, "method '" + method.name + "' (the degraded input) takes no params");
    }
  } else {
    try {
      catalog.check_method(method.name, method.params);
    } catch (const Error& error) {
      throw Error(file, std::string("method '") + method.label + "': " + error.what());
    }
  }
}

// One entry of 'methods': a registry method (name, label, params) or an external one.
ExperimentMethod ParseListedMethod(const ExperimentInput& x, const json& entry, size_t index) {
  const std::string& file = x.file;
  ExperimentMethod method;
  if (entry.is_string()) {
    method.name = method.label = entry.get<std::string>();
  } else if (!entry.is_object()) {
    throw Error(file, "each method must be a string or an object");
  } else if (IsExternalMethodObject(entry)) {
    // A user's program or a results folder (docs/experiments.md, "External methods").
    if (!entry.contains("name") || !entry["name"].is_string()) {
      throw Error(file, "each method needs a 'name' string");
    }
    method.name = entry["name"].get<std::string>();
    try {
      method.external = ParseExternalMethodSpec(entry);
    } catch (const Error& error) {
      throw Error(file, "method '" + PrintableName(method.name) + "': " + error.what());
    }
    // The external tables checked that a label is a string.
    method.label = entry.value("label", method.name);
    method.base_dir = fs::path(file).parent_path().string();
  } else {
    MethodKeys keys;
    MethodKeyFields().Read(entry, &keys, file, "methods[" + std::to_string(index) + "]");
    if (!entry.contains("name")) throw Error(file, "each method needs a 'name' string");
    method.name = keys.name;
    method.label = keys.label.value_or(keys.name);
    method.params = keys.params;
  }
  CheckListedMethod(x, method);
  return method;
}

// Methods: the reference rows first, then the listed ones.
void ParseMethods(const ExperimentInput& x, Experiment* out) {
  const std::string& file = x.file;
  Experiment& e = *out;
  const HarnessCatalog& catalog = x.catalog;
  if (!x.keys.methods.is_array() || x.keys.methods.empty()) {
    throw Error(file, "'methods' must be a non-empty array");
  }
  std::vector<ExperimentMethod> listed;
  for (size_t i = 0; i < x.keys.methods.size(); ++i)
    listed.push_back(ParseListedMethod(x, x.keys.methods[i], i));
  // Reference rows (identity, oracle) first in the catalog's order, listed or added; then the
  // listed methods in their order.
  const auto is_plain = [](const ExperimentMethod& m, const std::string& name) {
    return m.name == name && m.label == name && m.params.empty() && !m.IsExternal();
  };
  std::vector<bool> placed(listed.size(), false);
  if (x.keys.reference_methods.value_or(true)) {
    for (const std::string& name : catalog.reference_methods) {
      bool present = false;
      for (size_t i = 0; i < listed.size(); ++i) {
        if (!placed[i] && is_plain(listed[i], name)) {
          placed[i] = present = true;
          break;
        }
      }
      if (!present && name != catalog.identity_method) {
        try {
          catalog.check_method(name, json::object());
        } catch (const Error&) {
          continue;  // not available in this build
        }
      }
      ExperimentMethod method;
      method.name = method.label = name;
      e.methods.push_back(std::move(method));
    }
  }
  for (size_t i = 0; i < listed.size(); ++i) {
    if (!placed[i]) e.methods.push_back(listed[i]);
  }
  for (ExperimentMethod& method : e.methods) {
    // External methods see only the degraded image: never privileged.
    if (method.name != catalog.identity_method && !method.IsExternal() && catalog.is_privileged) {
      method.privileged = catalog.is_privileged(method.name, method.params);
    }
  }
}

// Labels are unique, not reserved, and distinct without case; returns them.
std::set<std::string> CheckMethodLabels(const std::string& file, const Experiment& e) {
  std::set<std::string> labels;
  std::map<std::string, std::string> label_keys;  // FileNameKey -> label
  for (const ExperimentMethod& method : e.methods) {
    if (!labels.insert(method.label).second) {
      throw Error(file, "method label '" + method.label +
                            "' is used twice (give the variants distinct 'label's)");
    }
    // Labels name files (thumbs/<id>/<label>.png) and folders (external/<label>/); the item's
    // own thumbnails are degraded.png, lit.png and clean.png.
    for (const char* reserved : {"degraded", "lit", "clean"}) {
      if (FileNameKey(method.label) == reserved) {
        throw Error(file, "method label '" + method.label + "' is reserved (thumbs/<id>/" +
                              reserved + ".png is the item's own thumbnail; set another 'label')");
      }
    }
    const auto [it, inserted] = label_keys.emplace(FileNameKey(method.label), method.label);
    if (!inserted) {
      throw Error(file, "method labels '" + it->second + "' and '" + method.label +
                            "' differ only in case; their files would collide on a "
                            "case-insensitive file system");
    }
  }
  return labels;
}

void ParseMetrics(const ExperimentInput& x, Experiment* out) {
  const std::string& file = x.file;
  Experiment& e = *out;
  if (!x.keys.metrics || x.keys.metrics->empty()) {
    throw Error(file, "'metrics' must be a non-empty array of metric names");
  }
  std::set<std::string> metric_names;
  for (const std::string& name : *x.keys.metrics) {
    if (!metric_names.insert(name).second) {
      throw Error(file, "metric '" + PrintableName(name) + "' listed twice");
    }
    try {
      e.metrics.push_back(x.catalog.find_metric(name));
    } catch (const Error& error) {
      throw Error(file, std::string("metric '") + PrintableName(name) + "': " + error.what());
    }
  }
  // Front-end metrics score pairs of frames: every scene must be a sequence.
  for (const HarnessMetricInfo& metric : e.metrics) {
    if (!metric.sequence) continue;
    for (const ExperimentScene& scene : e.scenes) {
      if (!scene.IsSequence())
        throw Error(file, "metric '" + metric.name + "' scores sequences, and scene '" +
                              scene.name +
                              "' is a single frame (give it a 'trajectory' or use an "
                              "rgbd_sequence file)");
    }
  }
}

// Ground truth, best_excludes and thumbnails.
void ParseScoring(const ExperimentInput& x, const std::set<std::string>& labels, Experiment* out) {
  const std::string& file = x.file;
  Experiment& e = *out;
  e.ground_truth = x.keys.ground_truth;
  e.score_domain = x.keys.score_domain;
  e.split = x.keys.split;
  if (x.keys.best_excludes) {
    for (const std::string& label : *x.keys.best_excludes) {
      if (!labels.count(label)) {
        throw Error(file,
                    "'best_excludes' names '" + PrintableName(label) + "', not a method label");
      }
      e.best_excludes.push_back(label);
    }
  } else {
    for (const std::string& name : x.catalog.reference_methods) {
      if (labels.count(name)) e.best_excludes.push_back(name);
    }
  }
  for (const ExperimentMethod& method : e.methods) {
    if (method.privileged && std::find(e.best_excludes.begin(), e.best_excludes.end(),
                                       method.label) == e.best_excludes.end()) {
      e.best_excludes.push_back(method.label);
    }
  }
  if (x.keys.thumbnails) e.thumbnail_width = *x.keys.thumbnails;
}

// Every condition's render options must parse (strict: unknown keys, bad ranges) before any
// work starts; they are parsed here once, and the items carry them.
void ResolveRenderOptions(const ExperimentInput& x, Experiment* out) {
  const std::string& file = x.file;
  const HarnessCatalog& catalog = x.catalog;
  Experiment& e = *out;
  const auto resolve = [&](const json& options, const std::string& context) {
    try {
      return catalog.resolve_render(options);
    } catch (const Error& error) {
      throw Error(file, context + ": " + error.what());
    }
  };
  e.render_resolved = resolve(e.render, "'render'").json;
  e.condition_render.reserve(static_cast<size_t>(e.ConditionCount()));
  for (int c = 0; c < e.ConditionCount(); ++c) {
    const json params = ConditionParams(e, c);
    json options = ConditionRenderOptions(e, params);
    if (!e.seed_path.empty()) SetJsonPath(options, e.seed_path, 0);
    e.condition_render.push_back(resolve(options, "condition " + params.dump()).options);
  }
}

}  // namespace

std::vector<std::string> ExperimentFileKeys() { return ExperimentKeyFields().Keys(); }

Experiment ParseExperiment(const json& in, const std::string& file, const HarnessCatalog& catalog) {
  if (!in.is_object()) throw Error(file, "an experiment must be a JSON object");
  ExperimentKeys keys;
  ExperimentKeyFields().Read(in, &keys, file);
  Experiment e;
  e.source_path = file;
  const ExperimentInput x{keys, file, catalog};
  e.name = keys.name.value_or(fs::path(file).stem().string());
  if (!IsSafeName(e.name)) {
    throw Error(file,
                "name '" + PrintableName(e.name) + "' must be 1-64 characters of [A-Za-z0-9_.-]");
  }
  e.description = keys.description;
  if (keys.seed) e.seed = *keys.seed;
  ParseScenes(x, &e);
  const std::set<std::string> swept = ParseRenderGridAndSamples(x, &e);
  ParseLevelAndSeedPath(x, swept, &e);
  ParseMethods(x, &e);
  const std::set<std::string> labels = CheckMethodLabels(file, e);
  ParseMetrics(x, &e);
  ParseScoring(x, labels, &e);
  ResolveRenderOptions(x, &e);
  return e;
}

}  // namespace turbid
