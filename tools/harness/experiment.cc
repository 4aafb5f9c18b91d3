#include "tools/harness/experiment.h"

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "core/json_io.h"
#include "core/safe_name.h"
#include "tools/harness/experiment_grid.h"

namespace turbid {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kFormat = "turbid-experiment/1";
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

// The entries of a resolved file's lists (json::exception on a missing key or a wrong type, which
// the caller turns into one line naming the file).
ExperimentScene ResolvedScene(const json& s, const std::string& source) {
  ExperimentScene scene;
  scene.spec = s.at("spec").get<std::string>();
  scene.load_spec = scene.spec;
  scene.name = s.at("name").get<std::string>();
  scene.scale = s.at("scale").get<double>();
  if (s.contains("frames"))
    scene.frames =
        static_cast<int>(ResolvedInteger(s.at("frames"), 1, 100000000, source, "frames"));
  if (s.contains("trajectory")) scene.trajectory = s.at("trajectory");
  return scene;
}
SampledParam ResolvedSampled(const json& p) {
  SampledParam param;
  param.path = p.at("path").get<std::string>();
  param.distribution = p.at("distribution").get<std::string>();
  param.low = p.at("low").get<double>();
  param.high = p.at("high").get<double>();
  param.choices = p.at("choices");
  return param;
}
ExperimentMethod ResolvedMethod(const json& m, const std::string& source) {
  ExperimentMethod method;
  method.name = m.at("name").get<std::string>();
  method.label = m.at("label").get<std::string>();
  method.params = m.at("params");
  method.privileged = m.value("privileged", false);
  if (m.contains("external")) method.external = m.at("external");
  method.base_dir = fs::path(source).parent_path().string();
  return method;
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
    for (const json& s : in.at("scenes")) e.scenes.push_back(ResolvedScene(s, source));
    e.render = in.at("render");
    e.render_resolved = in.at("render_resolved");
    for (const json& g : in.at("grid")) {
      e.grid.emplace_back(g.at("path").get<std::string>(), g.at("values").get<std::vector<json>>());
    }
    const json& samples = in.at("samples");
    e.sample_count =
        static_cast<int>(ResolvedInteger(samples.at("count"), 0, 1000000, source, "samples.count"));
    e.sample_seed = ResolvedSeed(samples.at("seed"), source, "samples.seed");
    for (const json& p : samples.at("params")) e.sampled.push_back(ResolvedSampled(p));
    e.level_path = in.at("level").at("path").get<std::string>();
    e.level_bins =
        static_cast<int>(ResolvedInteger(in.at("level").at("bins"), 0, 100, source, "level.bins"));
    e.seed_path = in.at("seed_path").get<std::string>();
    for (const json& m : in.at("methods")) e.methods.push_back(ResolvedMethod(m, source));
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
