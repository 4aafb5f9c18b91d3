// Manifests that `turbid score` reads: a `turbid generate` manifest.csv / manifest.jsonl, or any
// CSV with a header line (docs/cli/score.md). Kept apart from the command so that the parser can
// be fuzzed (fuzz/manifest_fuzzer.cc).
#pragma once

#include <map>
#include <string>
#include <vector>

namespace turbid {

// One row: column name -> value (JSON values that are not strings are kept as their JSON text).
using ManifestRecord = std::map<std::string, std::string>;

// Reads every row. ".jsonl"/".json": one JSON object per non-blank line; otherwise CSV whose first
// line that is neither empty nor a '#' comment is the header (a row's fields beyond the header are
// dropped, missing ones absent). Throws Error("<path>: <problem>") for an unreadable file, a line
// that is not a JSON object, or a CSV without a header line.
std::vector<ManifestRecord> ReadManifest(const std::string& path);

}  // namespace turbid
