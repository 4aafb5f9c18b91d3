// Render sidecars as `turbid enhance --sidecar S.json` reads them: the encoding it records, and the
// methods that take true parameters from it (oracle, oracle_exact, full_matched, full_physical)
// enhancing a render of the 32x24 built-in scene the seeds were rendered from
// (`turbid render --scene seafloor --scale 0.05`).
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>

#include "enhancer/registry.h"
#include "fuzz/fuzz_support.h"
#include "scenes/builtin.h"
#include "simulator/render.h"
#include "tools/harness/file_encoding.h"

namespace {
using namespace turbid;

struct Fixture {
  Scene scene;
  cv::Mat image;
  Fixture() {
    BuiltinSceneOptions options;
    options.scale = 0.05;  // 32x24
    scene = MakeBuiltinScene("seafloor", options);
    image = Render(RenderOptions{}, scene).image;
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const Fixture fixture;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::optional<nlohmann::json> parsed = fuzz::ParseStrictJson(text, "sidecar.json");
  if (!parsed) return 0;  // ReadJsonFile reports "invalid JSON" before this
  const nlohmann::json& sidecar = *parsed;
  fuzz::ExpectOnlyErrors([&] { SidecarEncoding(sidecar); });
  std::optional<RenderRecord> record;
  fuzz::ExpectOnlyErrors([&] { record = RenderRecord::FromJson(sidecar, "sidecar.json"); });
  if (!record) return 0;
  // What it reads writes back and reads again to the same record.
  fuzz::ExpectOnlyErrors([&] { RenderRecord::FromJson(record->ToJson(), "again"); });
  EnhanceInput input;
  input.image = fixture.image;
  input.scene = &fixture.scene;
  input.sidecar = &*record;
  for (const char* method : {"oracle", "oracle_exact", "full_matched", "full_physical"})
    fuzz::ExpectOnlyErrors([&] { Enhance(method, nlohmann::json::object(), input); });
  return 0;
}
