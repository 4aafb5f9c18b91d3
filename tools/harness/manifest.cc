#include "tools/harness/manifest.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/input_file.h"
#include "core/json_io.h"
#include "tools/harness/tables.h"

namespace turbid {
namespace fs = std::filesystem;
namespace {

std::string LineName(int number) { return "line " + std::to_string(number); }

// A label or path with a control character (a newline from a JSON "\n", a tab, ESC) would break
// the tables and plots made from it: refused with the line and the column.
void CheckNoControlCharacters(const std::string& path, int number, const std::string& key,
                              const std::string& value) {
  for (const std::string* text : {&key, &value})
    for (const char c : *text)
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
        throw Error(path, LineName(number) + ": column '" + key +
                              "' holds a control character (newline, tab, ...)");
}

}  // namespace

std::vector<ManifestRecord> ReadManifest(const std::string& path, std::vector<int>* line_numbers) {
  CheckInputFile(path);
  std::ifstream in(path);
  if (!in) throw Error(path, "cannot open manifest");
  std::vector<ManifestRecord> records;
  std::vector<int> numbers;
  std::string line;
  int number = 0;
  const bool jsonl =
      fs::path(path).extension() == ".jsonl" || fs::path(path).extension() == ".json";
  if (jsonl) {
    int first = 0;  // the line of the first row: every row has its keys
    while (std::getline(in, line)) {
      ++number;
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      nlohmann::json row;
      try {
        row = ParseJson(line, path);
      } catch (const JsonError& e) {
        throw Error(path, LineName(number) + " is not valid JSON (" + e.problem() + ")");
      }
      if (!row.is_object()) throw Error(path, LineName(number) + " is not a JSON object");
      ManifestRecord record;
      for (auto it = row.begin(); it != row.end(); ++it) {
        record[it.key()] = it->is_string() ? it->get<std::string>() : it->dump();
        CheckNoControlCharacters(path, number, it.key(), record[it.key()]);
      }
      if (!records.empty()) {
        // A row without a key of the first row would be scored without it (its reference).
        for (const auto& [key, value] : records.front())
          if (!record.count(key))
            throw Error(path, LineName(number) + " has no '" + key + "' (" + LineName(first) +
                                  " has; every row needs the same keys)");
        for (const auto& [key, value] : record)
          if (!records.front().count(key))
            throw Error(path, LineName(number) + " has '" + key + "', which " + LineName(first) +
                                  " has not (every row needs the same keys)");
      } else {
        first = number;
      }
      records.push_back(record);
      numbers.push_back(number);
    }
  } else {
    std::vector<std::string> header;
    while (std::getline(in, line)) {
      ++number;
      if (!line.empty() && line.back() == '\r') line.pop_back();  // CRLF files
      if (line.empty() || line[0] == '#') continue;
      if (header.empty()) {
        header = SplitCsvLine(line);
        for (const std::string& key : header) CheckNoControlCharacters(path, number, key, "");
        continue;
      }
      const std::vector<std::string> fields = SplitCsvLine(line);
      // A missing or extra field shifts or drops columns (a row scored without its reference).
      if (fields.size() != header.size())
        throw Error(path, LineName(number) + " has " + std::to_string(fields.size()) +
                              " fields, the header has " + std::to_string(header.size()));
      ManifestRecord record;
      for (size_t i = 0; i < header.size(); ++i) {
        CheckNoControlCharacters(path, number, header[i], fields[i]);
        record[header[i]] = fields[i];
      }
      records.push_back(record);
      numbers.push_back(number);
    }
    if (header.empty()) throw Error(path, "manifest is empty (expected a CSV header line)");
  }
  if (line_numbers != nullptr) *line_numbers = std::move(numbers);
  return records;
}

}  // namespace turbid
