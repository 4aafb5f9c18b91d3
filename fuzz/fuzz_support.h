// Shared pieces of the libFuzzer targets in fuzz/ (docs/reliability.md, "Fuzzing").
// A target's contract: any input either parses or ends in turbid::Error (the one-line message the
// CLI prints). Any other exception, a sanitizer report, a crash or a hang is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "core/error.h"
#include "core/json_io.h"

namespace turbid::fuzz {

// This process's own folder for the files a parser reads (under $TMPDIR, removed at exit), so
// that fuzzers running side by side never share a file and nothing lands in the repository.
const std::string& ScratchDir();
// ScratchDir() + "/" + name.
std::string ScratchPath(const std::string& name);
// Writes `bytes` to `path` (replacing it); aborts when it cannot (the fuzzer's own fault).
void WriteFile(const std::string& path, std::string_view bytes);

// Splits the input at the first occurrence of `separator`: (before, after); after is empty when
// the separator is absent.
std::pair<std::string_view, std::string_view> SplitAt(std::string_view input,
                                                      std::string_view separator);

// Runs `body`. turbid::Error is the expected answer to bad input; any other exception escaping the
// parser (a JSON library type error, cv::Exception, std::out_of_range, ...) is reported and aborts,
// because the CLI would print it without naming the file and the Python module would pass on a
// message that is not ours.
// With TURBID_FUZZ_VERBOSE set, each Error's message is printed (to see why a seed is refused).
bool Verbose();

template <typename Body>
void ExpectOnlyErrors(Body&& body) {
  try {
    body();
  } catch (const turbid::Error& e) {
    if (Verbose()) std::fprintf(stderr, "fuzz: Error: %s\n", e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz: a non-turbid::Error exception escaped: %s\n", e.what());
    std::abort();
  }
}

// The input as the commands read JSON (core/json_io.h: strict, depth-limited), or nullopt when
// they would refuse it with their "invalid JSON" line. The parse itself must end only in Error.
inline std::optional<nlohmann::json> ParseStrictJson(std::string_view text,
                                                     const std::string& source) {
  std::optional<nlohmann::json> json;
  ExpectOnlyErrors([&] { json = turbid::ParseJson(text, source); });
  return json;
}

}  // namespace turbid::fuzz
