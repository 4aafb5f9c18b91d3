// A fake catalog and item runner for the harness tests: the sweep engine, tables, shards and
// regression check are tested without the simulator, enhancer and metrics.
#pragma once

#include <atomic>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>

#include "core/error.h"
#include "tools/harness/experiment.h"
#include "tools/harness/sweep.h"
#include "tools/harness/tables.h"

namespace turbid::testing {

// Methods: none (identity), oracle, fake_a (param gain), fake_b. Metrics: up (higher is better),
// down (lower is better). Render options: {"water": {"beta": [0, 10], "type": str}, "seed": int}.
inline HarnessCatalog FakeCatalog() {
  HarnessCatalog catalog;
  catalog.check_method = [](const std::string& name, const nlohmann::json& params) {
    static const std::set<std::string> known = {"oracle", "fake_a", "fake_b"};
    if (!known.count(name)) throw Error("unknown method '" + name + "'");
    for (const auto& [key, value] : params.items()) {
      if (name != "fake_a" || key != "gain") {
        throw Error("method '" + name + "' has no parameter '" + key + "'");
      }
    }
  };
  catalog.find_metric = [](const std::string& name) {
    if (name == "up") return HarnessMetricInfo{"up", true, true, false, false};
    if (name == "down") return HarnessMetricInfo{"down", false, true, false, false};
    if (name == "nr") return HarnessMetricInfo{"nr", true, false, false, false};
    throw Error("unknown metric '" + name + "'");
  };
  catalog.resolve_render = [](const nlohmann::json& options) {
    nlohmann::json out = {{"water", {{"beta", 0.7}, {"type", "custom"}}}, {"seed", 0}};
    for (const auto& [key, value] : options.items()) {
      if (key == "seed") {
        out["seed"] = value;
      } else if (key == "water") {
        for (const auto& [k, v] : value.items()) {
          if (k == "beta") {
            if (!v.is_number() || v.get<double>() < 0 || v.get<double>() > 10) {
              throw Error("water.beta must be in [0, 10]");
            }
          } else if (k != "type") {
            throw Error("unknown key 'water." + k + "'");
          }
          out["water"][k] = v;
        }
      } else {
        throw Error("unknown key '" + key + "'");
      }
    }
    return ResolvedRender{out, nullptr};
  };
  catalog.check_scene = [](const std::string& spec) {
    if (spec != "builtin:a" && spec != "builtin:b" && spec != "a" && spec != "b") {
      throw Error("unknown scene '" + spec + "'");
    }
  };
  catalog.default_seed_path = "seed";
  return catalog;
}

inline nlohmann::json FakeExperimentJson() {
  return nlohmann::json::parse(R"({
    "name": "fake",
    "seed": 7,
    "scenes": ["builtin:a", {"spec": "builtin:b", "name": "b"}],
    "grid": {"water.beta": [0.1, 0.5, 1.0, 2.0]},
    "samples": {"count": 3, "seed": 11, "params": {"water.type": {"choice": ["x", "y"]}}},
    "methods": ["fake_a", {"name": "fake_a", "label": "fake_a2", "params": {"gain": 2}}, "fake_b"],
    "metrics": ["up", "down", "nr"]
  })");
}

// Deterministic results from the item's parameters; `perturb` lowers "up" of fake_a (a
// regression); `delay_ms` slows every item down (for the kill test).
struct FakeRunner {
  const Experiment* experiment = nullptr;
  double perturb = 0.0;
  int delay_ms = 0;
  std::atomic<int>* calls = nullptr;

  ItemResult operator()(const ItemSpec& item) const {
    if (calls != nullptr) ++*calls;
    if (delay_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    const double beta = item.params["water.beta"].get<double>();
    ItemResult result;
    result.width = item.scene_index == 0 ? 64 : 32;
    result.height = 48;
    result.render_ms = 1.0 + (item.index % 5);
    result.reference_metrics["nr"] = 3.0 + item.scene_index;
    for (size_t m = 0; m < experiment->methods.size(); ++m) {
      MethodResult row;
      row.label = experiment->methods[m].label;
      const double quality = std::exp(-beta) * (1.0 + 0.1 * static_cast<double>(m)) +
                             static_cast<double>(item.seed % 1000) * 1e-6;
      row.metrics["up"] = quality - (row.label == "fake_a" ? perturb : 0.0);
      row.metrics["down"] = 1.0 - quality;
      row.metrics["nr"] = row.label == "fake_b" && beta > 1.5 ? std::nan("") : quality * 2;
      if (row.label == "fake_b" && beta > 1.5) row.error = "fake failure";
      // Timing varies run to run on purpose: it must never reach the deterministic tables.
      row.time_ms =
          static_cast<double>(std::chrono::steady_clock::now().time_since_epoch().count() % 1000);
      result.methods.push_back(row);
    }
    return result;
  }
};

}  // namespace turbid::testing
