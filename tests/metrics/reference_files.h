// Locating /work/shared/reference-style folders from tests: $TURBID_REFERENCE, else
// "$TURBID_DATA/../reference". Reference values are not data, but they live beside it.
#pragma once

#include <optional>
#include <string>

namespace turbid::testing {

// The metrics reference folder (.../reference/metrics), or nullopt when it cannot be found.
std::optional<std::string> MetricsReferenceDir();

}  // namespace turbid::testing

// Skips the current test when the metrics reference folder is not available.
#define TURBID_REQUIRE_METRICS_REFERENCE(var)                                             \
  const auto var##_opt = ::turbid::testing::MetricsReferenceDir();                         \
  if (!var##_opt)                                                                          \
    GTEST_SKIP() << "metrics reference values not found: set TURBID_REFERENCE or "         \
                    "TURBID_DATA (reference = $TURBID_DATA/../reference); skipping";       \
  const std::string var = *var##_opt
