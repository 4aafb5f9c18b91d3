// Grids, samples and levels of an experiment (tools/harness/experiment_grid.h): the parameter
// values, the conditions they make and the items those expand into.
#include "tools/harness/experiment_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "core/error.h"

namespace turbid {

bool IsSafeName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-' || c == '.';
    if (!ok) return false;
  }
  return name != "." && name != "..";
}

using nlohmann::json;
// Axis names and level labels reach the tables (CSV, Markdown), the plots and `regress` as text:
// a control character (a newline above all) would split their rows and lines. Shown JSON-quoted
// so that the message stays one line.
void CheckLabelText(const std::string& file, const std::string& what, const std::string& text) {
  for (const char c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      throw Error(file, what + " " +
                            json(text).dump(-1, ' ', false, json::error_handler_t::replace) +
                            " holds a control character (newline, tab, ...)");
    }
  }
}

namespace {

// Level labels a grid or choice value gives: strings as they are, a named axis's 'label'.
void CheckValueLabel(const std::string& file, const std::string& what, const json& value) {
  if (value.is_string()) CheckLabelText(file, what, value.get<std::string>());
  if (value.is_object() && value.contains("label") && value["label"].is_string())
    CheckLabelText(file, what + " label", value["label"].get<std::string>());
}

}  // namespace

double FiniteNumber(const json& value, const std::string& file, const std::string& what) {
  if (!value.is_number()) throw Error(file, what + " must be a number, got " + value.dump());
  const double number = value.get<double>();
  if (!std::isfinite(number)) throw Error(file, what + " must be finite");
  return number;
}

// A named axis: each value sets several paths together, e.g. gray and RGB beta.
std::vector<json> NamedAxisValues(const json& spec, const std::string& file,
                                  const std::string& path, const std::string& what) {
  std::vector<json> values;
  if (path.size() < 2) throw Error(file, "grid axis '@' needs a name");
  if (!spec.is_array() || spec.empty()) {
    throw Error(file, what + " must be a non-empty array of {path: value, \"label\": ...} objects");
  }
  std::set<std::string> labels;
  for (const json& value : spec) {
    if (!value.is_object()) throw Error(file, what + " values must be objects {path: value}");
    CheckValueLabel(file, what, value);
    int paths = 0;
    for (const auto& [key, v] : value.items()) {
      CheckLabelText(file, what + " key", key);
      if (key == "label") {
        if (!v.is_string() || v.get<std::string>().empty()) {
          throw Error(file, what + " 'label' must be a non-empty string");
        }
      } else if (key == "x") {
        FiniteNumber(v, file, what + " 'x'");
      } else {
        if (key.rfind('@', 0) == 0) throw Error(file, what + " cannot set another axis " + key);
        if (v.is_null()) throw Error(file, what + " sets '" + key + "' to null");
        ++paths;
      }
    }
    if (paths == 0) throw Error(file, what + " has a value that sets no parameter");
    const std::string label =
        value.contains("label") ? value["label"].get<std::string>() : value.dump();
    if (!labels.insert(label).second) throw Error(file, what + " repeats label '" + label + "'");
    values.push_back(value);
  }
  return values;
}

// {"linspace": [lo, hi, n]} or {"logspace": [lo, hi, n]}.
std::vector<json> RangeValues(const json& spec, const std::string& file, const std::string& what) {
  std::vector<json> values;
  if (!spec.is_object() || spec.size() != 1 ||
      !(spec.contains("linspace") || spec.contains("logspace"))) {
    throw Error(file,
                what + " must be an array of values or {\"linspace\"|\"logspace\": [lo, hi, n]}");
  }
  const bool log = spec.contains("logspace");
  const json& range = log ? spec["logspace"] : spec["linspace"];
  if (!range.is_array() || range.size() != 3) {
    throw Error(file, what + " range must be [lo, hi, n]");
  }
  const double lo = FiniteNumber(range[0], file, what + " lo");
  const double hi = FiniteNumber(range[1], file, what + " hi");
  if (!range[2].is_number_integer() || range[2].get<int64_t>() < 1 ||
      range[2].get<int64_t>() > 100000) {
    throw Error(file, what + " n must be an integer in [1, 100000]");
  }
  const int n = range[2].get<int>();
  if (lo > hi)
    throw Error(file, what + " range is empty: lo " + range[0].dump() + " > hi " + range[1].dump());
  if (log && lo <= 0.0) throw Error(file, what + " logspace needs lo > 0");
  for (int i = 0; i < n; ++i) {
    const double f = n == 1 ? 0.0 : static_cast<double>(i) / (n - 1);
    const double value =
        log ? std::exp(std::log(lo) + f * (std::log(hi) - std::log(lo))) : lo + f * (hi - lo);
    values.push_back(i == n - 1 && n > 1 ? hi : value);
  }
  return values;
}

// Grid values: an array, or {"linspace": [lo, hi, n]} / {"logspace": [lo, hi, n]}.
std::vector<json> GridValues(const json& spec, const std::string& file, const std::string& path) {
  CheckLabelText(file, "grid axis", path);
  const std::string what = "grid '" + path + "'";
  if (path.rfind('@', 0) == 0) return NamedAxisValues(spec, file, path, what);
  std::vector<json> values;
  if (spec.is_array()) {
    if (spec.empty()) throw Error(file, what + " has no values (empty grid)");
    for (const json& value : spec) {
      if (value.is_null()) throw Error(file, what + " holds a null value");
      CheckValueLabel(file, what + " value", value);
      if (value.is_number()) FiniteNumber(value, file, what + " value");
      values.push_back(value);
    }
    return values;
  }
  return RangeValues(spec, file, what);
}

SampledParam ParseSampled(const std::string& path, const json& spec, const std::string& file) {
  CheckLabelText(file, "samples param", path);
  SampledParam param = ParseDistribution(spec, file, "samples param '" + path + "'");
  param.path = path;
  return param;
}

SampledParam ParseDistribution(const json& spec, const std::string& file, const std::string& what) {
  if (!spec.is_object() || spec.size() != 1) {
    throw Error(file, what +
                          " must be one of {\"uniform\"|\"log_uniform\"|\"int_uniform\": [lo, "
                          "hi]} or {\"choice\": [values...]}");
  }
  SampledParam param;
  param.distribution = spec.begin().key();
  const json& args = spec.begin().value();
  if (param.distribution == "choice") {
    if (!args.is_array() || args.empty())
      throw Error(file, what + " choice needs a non-empty array");
    for (const json& choice : args) CheckValueLabel(file, what + " choice", choice);
    param.choices = args;
    return param;
  }
  if (param.distribution != "uniform" && param.distribution != "log_uniform" &&
      param.distribution != "int_uniform") {
    throw Error(file, what + " has unknown distribution '" + param.distribution +
                          "' (uniform, log_uniform, int_uniform, choice)");
  }
  if (!args.is_array() || args.size() != 2) throw Error(file, what + " range must be [lo, hi]");
  param.low = FiniteNumber(args[0], file, what + " lo");
  param.high = FiniteNumber(args[1], file, what + " hi");
  if (param.low > param.high) {
    throw Error(file, what + " range is empty: lo " + args[0].dump() + " > hi " + args[1].dump());
  }
  if (param.distribution == "log_uniform" && param.low <= 0.0) {
    throw Error(file, what + " log_uniform needs lo > 0");
  }
  if (param.distribution == "int_uniform" &&
      (!args[0].is_number_integer() || !args[1].is_number_integer())) {
    throw Error(file, what + " int_uniform bounds must be integers");
  }
  return param;
}

namespace {

double Uniform01(uint64_t key) { return static_cast<double>(key >> 11) * 0x1.0p-53; }

json DrawSample(const SampledParam& param, uint64_t key) { return DrawDistribution(param, Uniform01(key)); }

}  // namespace

json DrawDistribution(const SampledParam& param, double u) {
  if (param.distribution == "choice") {
    const size_t n = param.choices.size();
    return param.choices[std::min(n - 1, static_cast<size_t>(u * static_cast<double>(n)))];
  }
  if (param.distribution == "int_uniform") {
    const int64_t lo = static_cast<int64_t>(param.low), hi = static_cast<int64_t>(param.high);
    const int64_t span = hi - lo + 1;
    return lo + std::min<int64_t>(span - 1, static_cast<int64_t>(u * static_cast<double>(span)));
  }
  if (param.distribution == "log_uniform") {
    return std::exp(std::log(param.low) + u * (std::log(param.high) - std::log(param.low)));
  }
  return param.low + u * (param.high - param.low);
}

namespace {

std::string FormatLevelNumber(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6g", value);
  return buffer;
}

std::string LevelLabel(const json& value) {
  if (value.is_object() && value.contains("label")) return value["label"].get<std::string>();
  if (value.is_string()) return value.get<std::string>();
  if (value.is_number()) return FormatLevelNumber(value.get<double>());
  return value.dump();
}

// A binned level: the parameter is sampled from a continuous distribution.
const SampledParam* BinnedLevel(const Experiment& experiment) {
  for (const SampledParam& param : experiment.sampled) {
    if (param.path == experiment.level_path &&
        (param.distribution == "uniform" || param.distribution == "log_uniform")) {
      return &param;
    }
  }
  return nullptr;
}

int BinOf(const SampledParam& param, int bins, double value) {
  double f = 0.0;
  if (param.high > param.low) {
    f = param.distribution == "log_uniform"
            ? (std::log(value) - std::log(param.low)) / (std::log(param.high) - std::log(param.low))
            : (value - param.low) / (param.high - param.low);
  }
  return std::clamp(static_cast<int>(f * bins), 0, bins - 1);
}

double BinEdge(const SampledParam& param, int bins, int edge) {
  const double f = static_cast<double>(edge) / bins;
  if (param.distribution == "log_uniform") {
    return std::exp(std::log(param.low) + f * (std::log(param.high) - std::log(param.low)));
  }
  return param.low + f * (param.high - param.low);
}

std::string BinLabel(const SampledParam& param, int bins, int bin) {
  return FormatLevelNumber(BinEdge(param, bins, bin)) + "-" +
         FormatLevelNumber(BinEdge(param, bins, bin + 1));
}

}  // namespace

// Parameters of one condition (grid point x sample draw), in a fixed order.
json ConditionParams(const Experiment& experiment, int condition) {
  json params = json::object();
  const int samples = std::max(1, experiment.sample_count);
  int grid_index = condition / samples;
  // Mixed radix, last grid path varying fastest.
  for (size_t k = experiment.grid.size(); k-- > 0;) {
    const auto& [path, values] = experiment.grid[k];
    const int n = static_cast<int>(values.size());
    params[path] = values[grid_index % n];
    grid_index /= n;
  }
  for (size_t j = 0; j < experiment.sampled.size(); ++j) {
    const uint64_t key =
        MixSeed(MixSeed(MixSeed(experiment.sample_seed) + static_cast<uint64_t>(condition)) +
                static_cast<uint64_t>(j) + 1);
    params[experiment.sampled[j].path] = DrawSample(experiment.sampled[j], key);
  }
  return params;
}

json ConditionRenderOptions(const Experiment& experiment, const json& params) {
  json options = experiment.render;
  for (const auto& [path, value] : params.items()) {
    if (path.rfind('@', 0) == 0) {
      for (const auto& [key, v] : value.items()) {
        if (key != "label" && key != "x") SetJsonPath(options, key, v);
      }
    } else {
      SetJsonPath(options, path, value);
    }
  }
  return options;
}

uint64_t MixSeed(uint64_t value) {
  uint64_t z = value + 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

void SetJsonPath(json& root, const std::string& path, const json& value) {
  json* node = &root;
  size_t start = 0;
  while (true) {
    const size_t dot = path.find('.', start);
    const std::string key =
        path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (key.empty()) throw Error("parameter path '" + path + "' has an empty component");
    if (node->is_null()) *node = json::object();
    if (!node->is_object()) {
      throw Error("parameter path '" + path + "': '" + key + "' is inside a non-object value");
    }
    if (dot == std::string::npos) {
      (*node)[key] = value;
      return;
    }
    node = &(*node)[key];
    start = dot + 1;
  }
}

const json* FindJsonPath(const json& root, const std::string& path) {
  const json* node = &root;
  size_t start = 0;
  while (true) {
    const size_t dot = path.find('.', start);
    const std::string key =
        path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node->is_object() || !node->contains(key)) return nullptr;
    node = &(*node)[key];
    if (dot == std::string::npos) return node;
    start = dot + 1;
  }
}

int Experiment::ConditionCount() const {
  int count = 1;
  for (const auto& entry : grid) count *= static_cast<int>(entry.second.size());
  return count * std::max(1, sample_count);
}

int Experiment::SceneItemCount(int scene) const {
  return ConditionCount() * std::max(1, scenes.at(static_cast<size_t>(scene)).frames);
}

bool Experiment::HasSequenceMetrics() const {
  for (const HarnessMetricInfo& metric : metrics)
    if (metric.sequence) return true;
  return false;
}

namespace {
std::string ZeroPadded(int number, int width) {
  std::string text = std::to_string(number);
  text.insert(0, static_cast<size_t>(std::max(0, width - static_cast<int>(text.size()))), '0');
  return text;
}
}  // namespace

std::vector<ItemSpec> ExpandItems(const Experiment& e) {
  const int conditions = e.ConditionCount();
  const int width = std::max(4, static_cast<int>(std::to_string(conditions - 1).size()));
  const SampledParam* binned = BinnedLevel(e);
  std::vector<json> params(conditions);
  std::vector<std::string> labels(conditions);
  std::vector<int> bins(conditions, 0);
  for (int c = 0; c < conditions; ++c) {
    params[c] = ConditionParams(e, c);
    const json& level = params[c][e.level_path];
    if (binned != nullptr) {
      bins[c] = BinOf(*binned, e.level_bins, level.get<double>());
      labels[c] = BinLabel(*binned, e.level_bins, bins[c]);
    } else {
      labels[c] = LevelLabel(level);
    }
  }
  std::map<std::string, int> rank;
  for (const std::string& label : LevelLabels(e))
    rank.emplace(label, static_cast<int>(rank.size()));

  std::vector<ItemSpec> items;
  items.reserve(static_cast<size_t>(e.ItemCount()));
  for (int s = 0; s < static_cast<int>(e.scenes.size()); ++s) {
    // A sequence's frames are items, frame-major within a condition: item f of condition c is
    // "<scene>-c<c>-f<f>" and frames of one condition are consecutive (pairs meet early).
    const int frames = e.scenes[s].frames;
    const int frame_width = std::max(4, static_cast<int>(std::to_string(frames - 1).size()));
    for (int c = 0; c < conditions; ++c) {
      const uint64_t mixed =
          MixSeed(MixSeed(e.seed) ^ ((static_cast<uint64_t>(s) << 32) | static_cast<uint64_t>(c)));
      for (int f = (frames > 0 ? 0 : -1); f < frames; ++f) {
        ItemSpec item;
        item.index = static_cast<int>(items.size());
        item.scene_index = s;
        item.condition = c;
        item.id = e.scenes[s].name + "-c" + ZeroPadded(c, width);
        item.params = params[c];
        item.level = labels[c];
        const json& level = params[c][e.level_path];
        if (binned != nullptr) {
          item.level_value = 0.5 * (BinEdge(*binned, e.level_bins, bins[c]) +
                                    BinEdge(*binned, e.level_bins, bins[c] + 1));
        } else if (level.is_number()) {
          item.level_value = level.get<double>();
        } else if (level.is_object() && level.contains("x")) {
          item.level_value = level["x"].get<double>();
        } else {
          item.level_value = rank[labels[c]];
        }
        item.seed = mixed >> 33;
        item.sequence_seed = item.seed;
        if (f >= 0) {
          // Each frame its own sensor noise: a seed per frame, keyed by the condition's.
          item.frame = f;
          item.id += "-f" + ZeroPadded(f, frame_width);
          item.seed = MixSeed(mixed ^ MixSeed(static_cast<uint64_t>(f) + 1)) >> 33;
        }
        item.render_options = ConditionRenderOptions(e, item.params);
        if (!e.seed_path.empty()) SetJsonPath(item.render_options, e.seed_path, item.seed);
        if (!e.condition_render.empty()) item.render = e.condition_render[c];
        items.push_back(std::move(item));
      }
    }
  }
  return items;
}

std::vector<std::string> LevelLabels(const Experiment& e) {
  std::vector<std::string> labels;
  const SampledParam* binned = BinnedLevel(e);
  if (binned != nullptr) {
    std::vector<bool> used(e.level_bins, false);
    for (int c = 0; c < e.ConditionCount(); ++c) {
      used[BinOf(*binned, e.level_bins, ConditionParams(e, c)[e.level_path].get<double>())] = true;
    }
    for (int b = 0; b < e.level_bins; ++b) {
      if (used[b]) labels.push_back(BinLabel(*binned, e.level_bins, b));
    }
    return labels;
  }
  std::set<std::string> seen;
  for (int c = 0; c < e.ConditionCount(); ++c) {
    const std::string label = LevelLabel(ConditionParams(e, c)[e.level_path]);
    if (seen.insert(label).second) labels.push_back(label);
  }
  return labels;
}

}  // namespace turbid
