#include "tools/harness/experiment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/json_io.h"
#include "core/limits.h"
#include "core/safe_name.h"
#include "tools/harness/experiment_grid.h"
#include "tools/harness/external_method.h"
#include "tools/harness/param_tree.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kFormat = "turbid-experiment/1";
// nlohmann reads non-negative integers up to 2^64 - 1 as unsigned, negative ones as signed and
// larger ones as floats (a json built in code may hold a signed non-negative one).
const std::string kSeedRange = "must be an integer in [0, 18446744073709551615]";
bool IsSeed(const json& value) {
  return value.is_number_unsigned() || (value.is_number_integer() && value.get<int64_t>() >= 0);
}

bool IsSafeName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-' || c == '.';
    if (!ok) return false;
  }
  return name != "." && name != "..";
}

// Throws for keys of `object` outside `allowed`; `where` names the object in the message.
void CheckKeys(const json& object, const std::set<std::string>& allowed, const std::string& file,
               const std::string& where) {
  for (const auto& [key, value] : object.items()) {
    if (allowed.count(key) == 0) {
      std::string list;
      for (const std::string& name : allowed) list += (list.empty() ? "" : ", ") + name;
      throw Error(file, "unknown key '" + key + "' in " + where + " (allowed: " + list + ")");
    }
  }
}

}  // namespace

json Experiment::ToJson() const {
  json out = json::object();
  out["format"] = kFormat;
  out["name"] = name;
  out["description"] = description;
  out["seed"] = seed;
  json scene_list = json::array();
  for (const ExperimentScene& scene : scenes) {
    json entry = {{"spec", scene.spec}, {"name", scene.name}, {"scale", scene.scale}};
    if (scene.IsSequence()) {  // only then: single-frame experiments keep their bytes
      entry["frames"] = scene.frames;
      if (!scene.trajectory.is_null()) entry["trajectory"] = scene.trajectory;
    }
    scene_list.push_back(entry);
  }
  out["scenes"] = scene_list;
  out["render"] = render;
  out["render_resolved"] = render_resolved;
  json grid_list = json::array();
  for (const auto& [path, values] : grid) grid_list.push_back({{"path", path}, {"values", values}});
  out["grid"] = grid_list;
  json params = json::array();
  for (const SampledParam& p : sampled) {
    params.push_back({{"path", p.path},
                      {"distribution", p.distribution},
                      {"low", p.low},
                      {"high", p.high},
                      {"choices", p.choices}});
  }
  out["samples"] = {{"count", sample_count}, {"seed", sample_seed}, {"params", params}};
  out["level"] = {{"path", level_path}, {"bins", level_bins}};
  out["seed_path"] = seed_path;
  json method_list = json::array();
  for (const ExperimentMethod& m : methods) {
    json entry = {
        {"name", m.name}, {"label", m.label}, {"params", m.params}, {"privileged", m.privileged}};
    if (m.IsExternal()) entry["external"] = m.external;
    method_list.push_back(entry);
  }
  out["methods"] = method_list;
  json metric_list = json::array();
  for (const HarnessMetricInfo& m : metrics) {
    metric_list.push_back({{"name", m.name},
                           {"higher_is_better", m.higher_is_better},
                           {"needs_reference", m.needs_reference},
                           {"needs_original", m.needs_original}});
    if (m.sequence) metric_list.back()["sequence"] = true;
  }
  out["metrics"] = metric_list;
  out["ground_truth"] = ground_truth;
  out["score_domain"] = ScoreDomainName(score_domain);
  if (!split.empty()) out["split"] = split;
  out["best_excludes"] = best_excludes;
  out["thumbnail_width"] = thumbnail_width;
  out["items"] = ItemCount();
  return out;
}

namespace {
// An integer of a resolved experiment file, read strictly (a float such as 1e300 is refused, never
// cast: core/json_io.h).
int64_t ResolvedInteger(const json& value, int64_t lo, int64_t hi, const std::string& source,
                        const char* key) {
  const std::optional<int64_t> v = JsonInteger(value, lo, hi);
  if (!v) throw Error(source, std::string("'") + key + "' must be an integer in [" +
                                  std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return *v;
}
uint64_t ResolvedSeed(const json& value, const std::string& source, const char* key) {
  const std::optional<uint64_t> v = JsonUnsigned(value);
  if (!v) throw Error(source, std::string("'") + key + "' must be an integer in [0, 2^64 - 1]");
  return *v;
}
}  // namespace

Experiment ExperimentFromResolvedJson(const json& in, const std::string& source) {
  try {
    if (!in.is_object() || in.value("format", "") != kFormat) {
      throw Error(source, std::string("not a resolved experiment (format ") + kFormat + ")");
    }
    Experiment e;
    e.source_path = source;
    e.name = in.at("name").get<std::string>();
    e.description = in.at("description").get<std::string>();
    e.seed = ResolvedSeed(in.at("seed"), source, "seed");
    for (const json& s : in.at("scenes")) {
      ExperimentScene scene;
      scene.spec = s.at("spec").get<std::string>();
      scene.load_spec = scene.spec;
      scene.name = s.at("name").get<std::string>();
      scene.scale = s.at("scale").get<double>();
      if (s.contains("frames"))
        scene.frames =
            static_cast<int>(ResolvedInteger(s.at("frames"), 1, 100000000, source, "frames"));
      if (s.contains("trajectory")) scene.trajectory = s.at("trajectory");
      e.scenes.push_back(scene);
    }
    e.render = in.at("render");
    e.render_resolved = in.at("render_resolved");
    for (const json& g : in.at("grid")) {
      e.grid.emplace_back(g.at("path").get<std::string>(), g.at("values").get<std::vector<json>>());
    }
    const json& samples = in.at("samples");
    e.sample_count =
        static_cast<int>(ResolvedInteger(samples.at("count"), 0, 1000000, source, "samples.count"));
    e.sample_seed = ResolvedSeed(samples.at("seed"), source, "samples.seed");
    for (const json& p : samples.at("params")) {
      SampledParam param;
      param.path = p.at("path").get<std::string>();
      param.distribution = p.at("distribution").get<std::string>();
      param.low = p.at("low").get<double>();
      param.high = p.at("high").get<double>();
      param.choices = p.at("choices");
      e.sampled.push_back(param);
    }
    e.level_path = in.at("level").at("path").get<std::string>();
    e.level_bins =
        static_cast<int>(ResolvedInteger(in.at("level").at("bins"), 0, 100, source, "level.bins"));
    e.seed_path = in.at("seed_path").get<std::string>();
    for (const json& m : in.at("methods")) {
      ExperimentMethod method;
      method.name = m.at("name").get<std::string>();
      method.label = m.at("label").get<std::string>();
      method.params = m.at("params");
      method.privileged = m.value("privileged", false);
      if (m.contains("external")) method.external = m.at("external");
      method.base_dir = fs::path(source).parent_path().string();
      e.methods.push_back(method);
    }
    for (const json& m : in.at("metrics")) {
      e.metrics.push_back({m.at("name").get<std::string>(), m.at("higher_is_better").get<bool>(),
                           m.at("needs_reference").get<bool>(), m.at("needs_original").get<bool>(),
                           m.value("sequence", false)});
    }
    e.ground_truth = in.at("ground_truth").get<std::string>();
    e.score_domain = ScoreDomainFromName(in.value("score_domain", "linear"), source);
    e.split = in.value("split", "");
    e.best_excludes = in.at("best_excludes").get<std::vector<std::string>>();
    e.thumbnail_width =
        static_cast<int>(ResolvedInteger(in.at("thumbnail_width"), 0, 4096, source, "thumbnail_width"));
    // Scene names and method labels become file names (thumbs/<scene>-c<n>/<label>.png,
    // external/<label>/): a resolved file holds only the names a sweep accepts.
    const auto check_name = [&](const char* what, const std::string& name) {
      if (!IsSafeName(name) || name.find('.') != std::string::npos) {
        throw Error(source, std::string(what) + " '" + PrintableName(name) +
                                "' must be 1-64 characters of [A-Za-z0-9_-] (the file was not "
                                "written by turbid, or was edited)");
      }
    };
    for (const ExperimentScene& scene : e.scenes) check_name("scene name", scene.name);
    for (const ExperimentMethod& method : e.methods) check_name("method label", method.label);
    for (const HarnessMetricInfo& metric : e.metrics) check_name("metric name", metric.name);
    return e;
  } catch (const json::exception& error) {
    throw Error(source, std::string("malformed resolved experiment: ") + error.what());
  }
}

namespace {

// The experiment file being parsed, for the parts of ParseExperiment (each checks its keys in the
// order the whole did, so the first problem reported stays the same).
struct ExperimentInput {
  const json& in;
  const std::string& file;
  const HarnessCatalog& catalog;
  // The string at `key`, `fallback` when absent; Error when it is not a string.
  std::string String(const char* key, const std::string& fallback) const {
    if (!in.contains(key)) return fallback;
    if (!in[key].is_string()) throw Error(file, std::string("'") + key + "' must be a string");
    return in[key].get<std::string>();
  }
};

void ParseScenes(const ExperimentInput& x, Experiment* out) {
  const json& in = x.in;
  const std::string& file = x.file;
  Experiment& e = *out;
  const HarnessCatalog& catalog = x.catalog;
  double default_scale = 1.0;
  if (in.contains("scale")) {
    default_scale = FiniteNumber(in["scale"], file, "'scale'");
    if (default_scale <= 0.0 || default_scale > 1.0) throw Error(file, "'scale' must be in (0, 1]");
  }
  if (!in.contains("scenes") || !in["scenes"].is_array() || in["scenes"].empty()) {
    throw Error(file, "'scenes' must be a non-empty array");
  }
  const fs::path base_dir = fs::path(file).parent_path();
  std::set<std::string> scene_names;
  std::map<std::string, std::string> scene_keys;  // FileNameKey -> scene name
  for (const json& entry : in["scenes"]) {
    ExperimentScene scene;
    scene.scale = default_scale;
    json object = entry.is_string() ? json{{"spec", entry}} : entry;
    if (!object.is_object()) throw Error(file, "each scene must be a string or an object");
    CheckKeys(object, {"spec", "name", "scale", "trajectory"}, file, "a scene");
    if (!object.contains("spec") || !object["spec"].is_string() ||
        object["spec"].get<std::string>().empty()) {
      throw Error(file, "each scene needs a 'spec' string (builtin:NAME or a scene file)");
    }
    scene.spec = object["spec"].get<std::string>();
    if (object.contains("scale")) {
      scene.scale = FiniteNumber(object["scale"], file, "scene scale");
      if (scene.scale <= 0.0 || scene.scale > 1.0) {
        throw Error(file, "scene '" + scene.spec + "': scale must be in (0, 1]");
      }
    }
    // A bare name without folder or extension is a built-in scene, as in `turbid scene`.
    const bool builtin =
        scene.spec.rfind("builtin:", 0) == 0 ||
        (scene.spec.find('/') == std::string::npos && fs::path(scene.spec).extension().empty());
    scene.load_spec = scene.spec;
    if (!builtin && fs::path(scene.spec).is_relative() && !base_dir.empty()) {
      scene.load_spec = (base_dir / scene.spec).lexically_normal().string();
    }
    std::string default_name = builtin ? scene.spec.substr(scene.spec.rfind(':') + 1)
                                       : fs::path(scene.spec).stem().string();
    scene.name = object.contains("name") && object["name"].is_string()
                     ? object["name"].get<std::string>()
                     : default_name;
    if (!IsSafeName(scene.name) || scene.name.find('.') != std::string::npos) {
      throw Error(file, "scene name '" + scene.name + "' must be 1-64 characters of [A-Za-z0-9_-]");
    }
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
    try {
      const json trajectory = object.contains("trajectory") ? object["trajectory"] : json();
      if (!builtin && !trajectory.is_null())
        throw Error("'trajectory' is for built-in scenes (an rgbd_sequence file has its poses)");
      if (catalog.sequence_frames) {
        scene.frames = catalog.sequence_frames(scene.load_spec, scene.scale, trajectory,
                                               &scene.trajectory);
      } else if (!trajectory.is_null()) {
        throw Error("sequences are not supported here");
      }
      if (!scene.IsSequence()) catalog.check_scene(scene.load_spec);
    } catch (const Error& error) {
      throw Error(file, std::string("scene '") + PrintableName(scene.spec) + "': " + error.what());
    }
    if (!builtin && scene.scale != 1.0) {
      throw Error(file, "scene '" + scene.spec + "': 'scale' applies to built-in scenes only");
    }
    e.scenes.push_back(scene);
  }
}

// The base render options, the grid and the samples; returns the swept paths.
std::set<std::string> ParseRenderGridAndSamples(const ExperimentInput& x, Experiment* out) {
  const json& in = x.in;
  const std::string& file = x.file;
  Experiment& e = *out;
  if (in.contains("render")) {
    if (!in["render"].is_object()) throw Error(file, "'render' must be an object");
    e.render = ExpandDottedKeys(in["render"], file);  // "water.type" as {"water": {"type"}}
  }
  std::set<std::string> swept;
  if (in.contains("grid")) {
    if (!in["grid"].is_object()) throw Error(file, "'grid' must be an object {path: values}");
    if (in["grid"].empty()) throw Error(file, "'grid' is empty: give at least one parameter");
    for (const auto& [path, values] : in["grid"].items()) {
      e.grid.emplace_back(path, GridValues(values, file, path));
      swept.insert(path);
    }
  }
  if (in.contains("samples")) {
    const json& samples = in["samples"];
    if (!samples.is_object()) throw Error(file, "'samples' must be an object");
    CheckKeys(samples, {"count", "seed", "params"}, file, "'samples'");
    if (!samples.contains("count") || !samples["count"].is_number_integer() ||
        samples["count"].get<int64_t>() < 1 || samples["count"].get<int64_t>() > 1000000) {
      throw Error(file, "'samples.count' must be an integer in [1, 1000000]");
    }
    e.sample_count = samples["count"].get<int>();
    if (samples.contains("seed")) {
      if (!IsSeed(samples["seed"])) throw Error(file, "'samples.seed' " + kSeedRange);
      e.sample_seed = samples["seed"].get<uint64_t>();
    } else {
      e.sample_seed = e.seed;
    }
    if (!samples.contains("params") || !samples["params"].is_object() ||
        samples["params"].empty()) {
      throw Error(file, "'samples.params' must be a non-empty object {path: distribution}");
    }
    // Dotted paths and nested objects alike (param_tree.h), drawn in dotted-path order.
    const json sampled = FlattenSamplers(samples["params"], file, "'samples.params'");
    for (const auto& [path, spec] : sampled.items()) {
      if (path.rfind('@', 0) == 0) throw Error(file, "named axes ('" + path + "') are grid-only");
      if (swept.count(path)) {
        throw Error(file, "parameter '" + path + "' is both in 'grid' and in 'samples'");
      }
      e.sampled.push_back(ParseSampled(path, spec, file));
      swept.insert(path);
    }
  }
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
  const json& in = x.in;
  const std::string& file = x.file;
  Experiment& e = *out;
  const HarnessCatalog& catalog = x.catalog;
  e.level_path = in.contains("level")
                     ? x.String("level", "")
                     : (e.grid.empty() ? e.sampled.front().path : e.grid.front().first);
  CheckLabelText(file, "'level'", e.level_path);
  if (!swept.count(e.level_path)) {
    throw Error(file, "'level' '" + e.level_path + "' is not a parameter of 'grid' or 'samples'");
  }
  if (in.contains("level_bins")) {
    if (!in["level_bins"].is_number_integer() || in["level_bins"].get<int>() < 1 ||
        in["level_bins"].get<int>() > 100) {
      throw Error(file, "'level_bins' must be an integer in [1, 100]");
    }
    e.level_bins = in["level_bins"].get<int>();
  }
  e.seed_path = x.String("seed_path", catalog.default_seed_path);
  if (!e.seed_path.empty() && swept.count(e.seed_path)) {
    throw Error(file, "'seed_path' '" + e.seed_path + "' is also a swept parameter");
  }
}

// One entry of 'methods': a registry method (name, label, params) or an external one.
ExperimentMethod ParseListedMethod(const ExperimentInput& x, const json& entry) {
  const std::string& file = x.file;
  const HarnessCatalog& catalog = x.catalog;
  ExperimentMethod method;
  json object = entry.is_string() ? json{{"name", entry}} : entry;
  if (!object.is_object()) throw Error(file, "each method must be a string or an object");
  if (!object.contains("name") || !object["name"].is_string()) {
    throw Error(file, "each method needs a 'name' string");
  }
  if (IsExternalMethodObject(object)) {
    // A user's program or a results folder (docs/experiments.md, "External methods").
    try {
      method.external = ParseExternalMethodSpec(object);
    } catch (const Error& error) {
      throw Error(file, "method '" + object["name"].get<std::string>() + "': " + error.what());
    }
    method.base_dir = fs::path(file).parent_path().string();
  } else {
    CheckKeys(object, {"name", "label", "params"}, file, "a method");
  }
  method.name = object["name"].get<std::string>();
  method.label = object.contains("label") && object["label"].is_string()
                     ? object["label"].get<std::string>()
                     : method.name;
  if (object.contains("params")) {
    if (!object["params"].is_object()) {
      throw Error(file, "method '" + method.label + "': 'params' must be an object");
    }
    method.params = object["params"];
  }
  if (!IsSafeName(method.label) || method.label.find('.') != std::string::npos) {
    throw Error(file,
                "method label '" + method.label + "' must be 1-64 characters of [A-Za-z0-9_-]");
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
  return method;
}

// Methods: the reference rows first, then the listed ones.
void ParseMethods(const ExperimentInput& x, Experiment* out) {
  const json& in = x.in;
  const std::string& file = x.file;
  Experiment& e = *out;
  const HarnessCatalog& catalog = x.catalog;
  if (!in.contains("methods") || !in["methods"].is_array() || in["methods"].empty()) {
    throw Error(file, "'methods' must be a non-empty array");
  }
  std::vector<ExperimentMethod> listed;
  for (const json& entry : in["methods"]) listed.push_back(ParseListedMethod(x, entry));
  bool add_reference_rows = true;
  if (in.contains("reference_methods")) {
    if (!in["reference_methods"].is_boolean()) {
      throw Error(file, "'reference_methods' must be true or false");
    }
    add_reference_rows = in["reference_methods"].get<bool>();
  }
  // Reference rows (identity, oracle) first in the catalog's order, listed or added; then the
  // listed methods in their order.
  const auto is_plain = [](const ExperimentMethod& m, const std::string& name) {
    return m.name == name && m.label == name && m.params.empty() && !m.IsExternal();
  };
  std::vector<bool> placed(listed.size(), false);
  if (add_reference_rows) {
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
  const json& in = x.in;
  const std::string& file = x.file;
  Experiment& e = *out;
  const HarnessCatalog& catalog = x.catalog;
  if (!in.contains("metrics") || !in["metrics"].is_array() || in["metrics"].empty()) {
    throw Error(file, "'metrics' must be a non-empty array of metric names");
  }
  std::set<std::string> metric_names;
  for (const json& entry : in["metrics"]) {
    if (!entry.is_string()) throw Error(file, "each metric must be a name string");
    const std::string name = entry.get<std::string>();
    if (!metric_names.insert(name).second) throw Error(file, "metric '" + name + "' listed twice");
    try {
      e.metrics.push_back(catalog.find_metric(name));
    } catch (const Error& error) {
      throw Error(file, std::string("metric '") + name + "': " + error.what());
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
  const json& in = x.in;
  const std::string& file = x.file;
  Experiment& e = *out;
  const HarnessCatalog& catalog = x.catalog;
  e.ground_truth = x.String("ground_truth", "clean");
  if (e.ground_truth != "clean" && e.ground_truth != "lit") {
    throw Error(file, "'ground_truth' must be \"clean\" (rho) or \"lit\" (J), got '" +
                          e.ground_truth + "'");
  }
  e.score_domain = ScoreDomainFromName(x.String("score_domain", "encoded"), file);
  e.split = x.String("split", "");
  if (!e.split.empty() && e.split != "tuning" && e.split != "evaluation") {
    throw Error(file, "'split' must be \"tuning\" or \"evaluation\"");
  }
  if (in.contains("best_excludes")) {
    if (!in["best_excludes"].is_array()) {
      throw Error(file, "'best_excludes' must be an array of method labels");
    }
    for (const json& label : in["best_excludes"]) {
      if (!label.is_string() || !labels.count(label.get<std::string>())) {
        throw Error(file, "'best_excludes' names " + label.dump() + ", not a method label");
      }
      e.best_excludes.push_back(label.get<std::string>());
    }
  } else {
    for (const std::string& name : catalog.reference_methods) {
      if (labels.count(name)) e.best_excludes.push_back(name);
    }
  }
  for (const ExperimentMethod& method : e.methods) {
    if (method.privileged && std::find(e.best_excludes.begin(), e.best_excludes.end(),
                                       method.label) == e.best_excludes.end()) {
      e.best_excludes.push_back(method.label);
    }
  }
  if (in.contains("thumbnails")) {
    const json& thumbnails = in["thumbnails"];
    if (thumbnails.is_boolean()) {
      e.thumbnail_width = thumbnails.get<bool>() ? 160 : 0;
    } else if (thumbnails.is_number_integer() && thumbnails.get<int64_t>() >= 0 &&
               thumbnails.get<int64_t>() <= 4096) {
      e.thumbnail_width = thumbnails.get<int>();
    } else {
      throw Error(file, "'thumbnails' must be true, false or a width in pixels [0, 4096]");
    }
  }
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

Experiment ParseExperiment(const json& in, const std::string& file, const HarnessCatalog& catalog) {
  if (!in.is_object()) throw Error(file, "an experiment must be a JSON object");
  CheckKeys(in,
            {"name", "description", "seed", "scenes", "scale", "render", "grid", "samples", "level",
             "level_bins", "seed_path", "methods", "reference_methods", "metrics", "ground_truth",
             "score_domain", "split", "best_excludes", "thumbnails", "$schema", "comment"},
            file, "the experiment");
  Experiment e;
  e.source_path = file;
  const ExperimentInput x{in, file, catalog};
  e.name = x.String("name", fs::path(file).stem().string());
  if (!IsSafeName(e.name)) {
    throw Error(file, "name '" + e.name + "' must be 1-64 characters of [A-Za-z0-9_.-]");
  }
  e.description = x.String("description", "");
  if (in.contains("seed")) {
    if (!IsSeed(in["seed"])) throw Error(file, "'seed' " + kSeedRange);
    e.seed = in["seed"].get<uint64_t>();
  }
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

Experiment LoadExperimentFile(const std::string& path, const HarnessCatalog& catalog) {
  return ParseExperiment(ReadJsonFile(path), path, catalog);
}

Shard ParseShard(const std::string& text) {
  const size_t slash = text.find('/');
  Shard shard;
  try {
    if (slash == std::string::npos) throw std::invalid_argument("no slash");
    size_t used = 0;
    shard.index = std::stoi(text.substr(0, slash), &used);
    if (used != slash) throw std::invalid_argument("trailing");
    const std::string count = text.substr(slash + 1);
    shard.count = std::stoi(count, &used);
    if (used != count.size()) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw Error("--shard '" + text + "': expected i/N, e.g. 0/4");
  }
  if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count) {
    throw Error("--shard '" + text + "': need 0 <= i < N");
  }
  return shard;
}

}  // namespace turbid
