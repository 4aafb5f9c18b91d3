// Manifests as `turbid score --manifest` reads them (tools/harness/manifest.h): the first byte
// picks .csv or .jsonl, the rest is the file.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "tools/harness/manifest.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string path =
      turbid::fuzz::ScratchPath(data[0] % 2 ? "manifest.jsonl" : "manifest.csv");
  turbid::fuzz::WriteFile(path,
                          std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1));
  turbid::fuzz::ExpectOnlyErrors([&] { turbid::ReadManifest(path); });
  return 0;
}
