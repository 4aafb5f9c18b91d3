#include "tools/manifest.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "scenes/error.h"
#include "scenes/input_file.h"
#include "scenes/json_io.h"
#include "tools/tables.h"

namespace turbid {
namespace fs = std::filesystem;

std::vector<ManifestRecord> ReadManifest(const std::string& path) {
  CheckInputFile(path);
  std::ifstream in(path);
  if (!in) throw Error(path, "cannot open manifest");
  std::vector<ManifestRecord> records;
  std::string line;
  const bool jsonl =
      fs::path(path).extension() == ".jsonl" || fs::path(path).extension() == ".json";
  if (jsonl) {
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      nlohmann::json row;
      try {
        row = ParseJson(line, path);
      } catch (const JsonError& e) {
        throw Error(path,
                    "line " + std::to_string(number) + " is not valid JSON (" + e.problem() + ")");
      }
      if (!row.is_object())
        throw Error(path, "line " + std::to_string(number) + " is not a JSON object");
      ManifestRecord record;
      for (auto it = row.begin(); it != row.end(); ++it)
        record[it.key()] = it->is_string() ? it->get<std::string>() : it->dump();
      records.push_back(record);
    }
    return records;
  }
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header.empty()) {
      header = SplitCsvLine(line);
      continue;
    }
    const std::vector<std::string> fields = SplitCsvLine(line);
    ManifestRecord record;
    for (size_t i = 0; i < header.size() && i < fields.size(); ++i) record[header[i]] = fields[i];
    records.push_back(record);
  }
  if (header.empty()) throw Error(path, "manifest is empty (expected a CSV header line)");
  return records;
}

}  // namespace turbid
