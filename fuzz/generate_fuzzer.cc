// `turbid generate` configs: ParseGenerateConfig (presets, grid, random draws) and the item
// expansion with its random draws and per-item render parameters.
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/fuzz_support.h"
#include "tools/harness/generate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace turbid;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::optional<nlohmann::json> parsed = fuzz::ParseStrictJson(text, "generate.json");
  if (!parsed) return 0;  // the command reports "invalid JSON" before parsing
  const nlohmann::json& json = *parsed;
  fuzz::ExpectOnlyErrors([&] {
    const GenerateConfig config = ParseGenerateConfig(json, fuzz::ScratchPath("generate.json"));
    // Names as the loaded scenes would have them; the bound keeps one input fast (the config's
    // grid x samples x scenes sets the item count), it is not a limit of generate.
    const double items = static_cast<double>(config.scene_specs.size()) *
                         static_cast<double>(config.combos.size()) * config.samples;
    if (items > 2000) return;
    std::vector<std::string> names;
    for (size_t i = 0; i < config.scene_specs.size(); ++i) names.push_back("s" + std::to_string(i));
    ExpandGenerateItems(config, names);
  });
  return 0;
}
