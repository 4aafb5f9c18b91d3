// DIR/protocol.json: how a sweep's tables were made, in one file (issue 32 item 4) — the score
// domain and the camera coding it implies, each metric with its variant and domain, the ground
// truth, the resize policy, the scenes (the split) with their sources, every seed, the summary
// statistics and the versions of turbid and OpenCV. Enough to say "these tables follow protocol X"
// and to reproduce them (the experiment itself: experiment.json). Deterministic: written with the
// tables, identical bytes for any thread count and shard layout. Schema: docs/experiments.md,
// "protocol.json".
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "tools/harness/experiment.h"

namespace turbid {

// The protocol of an experiment as JSON (format "turbid-protocol/1").
nlohmann::json ProtocolJson(const Experiment& experiment);
// Writes DIR/protocol.json atomically.
void WriteProtocol(const Experiment& experiment, const std::string& dir);
// The protocol as a Markdown section (for summary.md's end and the report).
std::string ProtocolMarkdown(const Experiment& experiment);

}  // namespace turbid
