#include "tests/metrics/reference_files.h"

#include <cstdlib>
#include <filesystem>

namespace turbid::testing {

std::optional<std::string> MetricsReferenceDir() {
  namespace fs = std::filesystem;
  std::string root;
  if (const char* ref = std::getenv("TURBID_REFERENCE"); ref != nullptr && *ref != '\0') {
    root = ref;
  } else if (const char* data = std::getenv("TURBID_DATA"); data != nullptr && *data != '\0') {
    root = (fs::path(data) / ".." / "reference").string();
  } else {
    return std::nullopt;
  }
  const fs::path dir = fs::path(root) / "metrics";
  std::error_code ec;
  if (!fs::is_regular_file(dir / "expected.json", ec)) return std::nullopt;
  return dir.string();
}

}  // namespace turbid::testing
