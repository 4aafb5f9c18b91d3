#include "tools/harness/protocol.h"

#include <opencv2/core/version.hpp>
#include <set>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "metrics/registry.h"
#include "tools/harness/statistics.h"
#include "turbid_version.h"

namespace turbid {
namespace {

using nlohmann::json;

// The metric's registry line (which published code it matches); "" for names the registry of
// this build does not know (a resolved experiment from another build, the tests' fakes).
std::string MetricVariant(const std::string& name) {
  try {
    return FindMetric(name).summary;
  } catch (const Error&) {
    return "";
  }
}

// The camera coding of the base render options, and whether a grid or sampled parameter changes
// it per condition.
json CameraJson(const Experiment& e) {
  json camera = json::object();
  if (const json* c = FindJsonPath(e.render_resolved, "camera"); c != nullptr && c->is_object()) {
    camera["bit_depth"] = c->value("bit_depth", json());
    camera["encoding"] = c->value("encoding", json());
  }
  bool varies = false;
  for (const auto& entry : e.grid) {
    varies |= entry.first.rfind("camera.", 0) == 0 || entry.first.rfind('@', 0) == 0;
  }
  for (const SampledParam& p : e.sampled) varies |= p.path.rfind("camera.", 0) == 0;
  camera["may_vary_by_condition"] = varies;
  return camera;
}

}  // namespace

json ProtocolJson(const Experiment& e) {
  json out = json::object();
  out["format"] = "turbid-protocol/1";
  out["experiment"] = e.name;
  out["score_domain"] = ScoreDomainName(e.score_domain);
  out["score_domain_meaning"] =
      e.score_domain == ScoreDomain::kEncoded
          ? "full-reference metrics compare the result and the ground truth as the item's camera "
            "writes them: clipped to [0, 1], coded with camera.encoding, quantised to "
            "camera.bit_depth, scored on the integer codes with data range 2^bits - 1 (a float "
            "camera: clipped linear values, range 1); no-reference metrics read linear light"
          : "every metric reads the linear-light float images ([0, 1]) as the libraries hold them";
  out["camera"] = CameraJson(e);
  json metrics = json::array();
  for (const HarnessMetricInfo& m : e.metrics) {
    metrics.push_back({{"name", m.name},
                       {"variant", MetricVariant(m.name)},
                       {"full_reference", m.needs_reference},
                       {"domain", MetricDomain(e.score_domain, m.needs_reference)},
                       {"higher_is_better", m.higher_is_better}});
  }
  out["metrics"] = metrics;
  out["ground_truth"] =
      e.ground_truth == "lit" ? "lit J = (E_A + E_L) rho, clipped to [0, 1]" : "clean rho";
  out["resize_policy"] =
      "none: built-in scenes are rendered at their 'scale' (the camera's intrinsics scaled, not "
      "an image resize), scene files at their own size; every method's output must have the "
      "render's size and is scored at it (another size is the method's error, never resized)";
  json scenes = json::array();
  for (const ExperimentScene& s : e.scenes) {
    const bool builtin = s.spec.rfind("builtin:", 0) == 0 || s.spec.find('/') == std::string::npos;
    scenes.push_back(
        {{"name", s.name},
         {"spec", s.spec},
         {"source", e.listed_items > 0 ? "dataset manifest"
                                       : (builtin ? "built-in (synthetic)" : "scene file")},
         {"scale", s.scale}});
  }
  out["split"] = {{"role", e.split.empty() ? json() : json(e.split)},
                  {"scenes", scenes},
                  {"items", e.ItemCount()}};
  out["seeds"] = {{"render", e.seed},
                  {"seed_path", e.seed_path},
                  {"samples", e.sample_count > 0 ? json(e.sample_seed) : json()},
                  {"rule",
                   "item seed = MixSeed(MixSeed(seed) ^ (scene << 32 | condition)) >> 33; "
                   "sampled values from (samples.seed, condition, parameter); "
                   "tools/harness/experiment_grid.cc"}};
  out["summary_statistics"] = {
      {"cell", "mean over the items of the level (a NaN = failed item is left out and counted)"},
      {"interval",
       {{"kind", "percentile bootstrap of the mean over items"},
        {"level", kConfidenceLevel},
        {"resamples", kBootstrapResamples},
        {"seed", kBootstrapSeed},
        {"quantiles", "type 7 (linear interpolation)"},
        {"cell_stream", "seed ^ FNV-1a(level, method, metric)"}}},
      {"best",
       {{"test",
         "two-sided Wilcoxon signed-rank, best mean vs runner-up mean over the "
         "same items (zero differences dropped, mid-ranks for ties; exact up to "
         "50 pairs, normal approximation with tie correction beyond)"},
        {"alpha", 0.05},
        {"otherwise", "tied"},
        {"never_best", e.best_excludes}}}};
  out["versions"] = {{"turbid", TURBID_VERSION}, {"opencv", CV_VERSION}, {"protocol", 1}};
  return out;
}

void WriteProtocol(const Experiment& experiment, const std::string& dir) {
  AtomicWriteText(dir + "/protocol.json", ProtocolJson(experiment).dump(2) + "\n", true);
}

std::string ProtocolMarkdown(const Experiment& e) {
  const json p = ProtocolJson(e);
  std::ostringstream md;
  md << "\n## Protocol\n\n"
     << "- score domain: **" << p["score_domain"].get<std::string>() << "** — "
     << p["score_domain_meaning"].get<std::string>() << "\n";
  const json& camera = p["camera"];
  if (camera.contains("bit_depth")) {
    md << "- camera (base render options): " << camera["encoding"].dump() << ", "
       << camera["bit_depth"].dump() << " bit"
       << (camera["may_vary_by_condition"].get<bool>() ? " (a swept parameter may change it)" : "")
       << "\n";
  }
  md << "- metrics:";
  for (const json& m : p["metrics"]) {
    md << " " << m["name"].get<std::string>() << " [" << m["domain"].get<std::string>() << "]";
  }
  md << "\n- ground truth: " << p["ground_truth"].get<std::string>() << "\n"
     << "- resize policy: " << p["resize_policy"].get<std::string>() << "\n"
     << "- split"
     << (p["split"]["role"].is_null() ? "" : " (" + p["split"]["role"].get<std::string>() + ")")
     << ": " << p["split"]["items"].get<int>() << " items over";
  for (const json& s : p["split"]["scenes"]) {
    md << " " << s["name"].get<std::string>() << " (" << s["source"].get<std::string>() << ")";
  }
  md << "\n- seeds: render " << p["seeds"]["render"].dump();
  if (!p["seeds"]["samples"].is_null()) md << ", samples " << p["seeds"]["samples"].dump();
  md << "\n- versions: turbid " << TURBID_VERSION << ", OpenCV " << CV_VERSION
     << "; the whole protocol: protocol.json\n";
  return md.str();
}

}  // namespace turbid
