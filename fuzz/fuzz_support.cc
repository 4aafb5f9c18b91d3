#include "fuzz/fuzz_support.h"

#include <filesystem>
#include <fstream>
#include <system_error>

namespace turbid::fuzz {
namespace fs = std::filesystem;

namespace {

struct Scratch {
  std::string path;
  Scratch() {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/turbid_fuzz_XXXXXX";
    if (!mkdtemp(pattern.data())) {
      std::perror("fuzz: mkdtemp");
      std::abort();
    }
    path = pattern;
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

}  // namespace

bool Verbose() {
  static const bool verbose = std::getenv("TURBID_FUZZ_VERBOSE") != nullptr;
  return verbose;
}

const std::string& ScratchDir() {
  static const Scratch scratch;
  return scratch.path;
}

std::string ScratchPath(const std::string& name) { return ScratchDir() + "/" + name; }

void WriteFile(const std::string& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
}

std::pair<std::string_view, std::string_view> SplitAt(std::string_view input,
                                                      std::string_view separator) {
  const size_t at = input.find(separator);
  if (at == std::string_view::npos) return {input, {}};
  return {input.substr(0, at), input.substr(at + separator.size())};
}

}  // namespace turbid::fuzz
