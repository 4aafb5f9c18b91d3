// Render parameters as `turbid render --params P.json --set K=V ...` reads them. The input is the
// parameters JSON, optionally followed by a NUL byte and `--set` assignments, one per line.
// ApplyRenderSet, RenderOptionsFromJson, the JSON round trip of the accepted options (the sidecar's
// "options" must read back to the same options), then the plan and a render of a 32x24 built-in
// scene: every accepted parameter set must render without a sanitizer report.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "fuzz/fuzz_support.h"
#include "scenes/builtin.h"
#include "simulator/render.h"
#include "tools/harness/generate.h"

namespace {
using namespace turbid;

const Renderer& TinyRenderer() {
  static const std::unique_ptr<Renderer> renderer = [] {
    BuiltinSceneOptions options;
    options.scale = 0.05;  // 32x24
    return std::make_unique<Renderer>(MakeBuiltinScene("seafloor", options));
  }();
  return *renderer;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const auto parts = fuzz::SplitAt(input, std::string_view("\0", 1));
  const std::string_view sets = parts.second;
  std::optional<nlohmann::json> parsed = fuzz::ParseStrictJson(parts.first, "params.json");
  if (!parsed) return 0;               // `turbid render` reports "invalid JSON" before this
  if (!parsed->is_object()) return 0;  // and "parameters must be a JSON object"
  nlohmann::json params = std::move(*parsed);
  fuzz::ExpectOnlyErrors([&] {
    std::string_view rest = sets;
    while (!rest.empty()) {
      const auto [line, next] = fuzz::SplitAt(rest, "\n");
      if (!line.empty()) ApplyRenderSet(params, std::string(line));
      rest = next;
    }
    const RenderOptions options = RenderOptionsFromJson(params);
    const nlohmann::json written = RenderOptionsToJson(options);
    const nlohmann::json reread = RenderOptionsToJson(RenderOptionsFromJson(written));
    if (reread != written) {
      std::fprintf(stderr, "fuzz: options JSON does not round-trip:\n%s\n%s\n",
                   written.dump().c_str(), reread.dump().c_str());
      std::abort();
    }
    TinyRenderer().Plan(options);
    TinyRenderer().Render(options);
  });
  return 0;
}
