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

// Reads every row. ".jsonl"/".json": one JSON object per non-blank line, every row with the keys
// of the first; otherwise CSV whose first line that is neither empty nor a '#' comment is the
// header, every row with as many fields as the header. Throws Error("<path>: <problem>") for an
// unreadable file, a line that is not a JSON object, a row with a missing or extra field (naming
// its line), a control character (newline, tab, ...) in a column name or value, or a CSV without a
// header line. `line_numbers`, when given, receives each row's line in the file (1-based).
std::vector<ManifestRecord> ReadManifest(const std::string& path,
                                         std::vector<int>* line_numbers = nullptr);

}  // namespace turbid
