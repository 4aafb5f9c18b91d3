// Experiment files as `turbid sweep` reads them: ParseExperiment against the real registries
// (methods, metrics, render options, scene specs), the item expansion and level labels, and the
// resolved JSON's round trip (what a sweep saves as DIR/experiment.json and compares on resume
// and merge must read back to the same JSON). The input's first line, when it is not JSON, is also
// given to ParseShard (`--shard i/N`).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "tools/harness/experiment.h"
#include "tools/harness/harness_runner.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace turbid;
  static const HarnessCatalog catalog = RegistryCatalog();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::optional<nlohmann::json> parsed = fuzz::ParseStrictJson(text, "experiment.json");
  if (!parsed) {
    fuzz::ExpectOnlyErrors([&] { ParseShard(std::string(fuzz::SplitAt(text, "\n").first)); });
    return 0;  // LoadExperimentFile reports "invalid JSON" before parsing
  }
  const nlohmann::json& json = *parsed;
  fuzz::ExpectOnlyErrors([&] {
    const Experiment experiment =
        ParseExperiment(json, fuzz::ScratchPath("experiment.json"), catalog);
    // Expanding is linear in the item count, which the file sets (a grid's product); the bound
    // keeps one input fast, it is not a limit of the harness.
    if (experiment.ItemCount() <= 2000) {
      ExpandItems(experiment);
      LevelLabels(experiment);
    }
    const nlohmann::json resolved = experiment.ToJson();
    const nlohmann::json reread = ExperimentFromResolvedJson(resolved, "experiment.json").ToJson();
    if (reread != resolved) {
      std::fprintf(stderr, "fuzz: resolved experiment does not round-trip:\n%s\n%s\n",
                   resolved.dump().c_str(), reread.dump().c_str());
      std::abort();
    }
  });
  return 0;
}
