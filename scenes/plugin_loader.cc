#include "scenes/plugin_loader.h"

#include <dlfcn.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

namespace turbid::plugins {
namespace fs = std::filesystem;

namespace {

std::string DirectoryOf(const std::string& file) {
  std::error_code ec;
  const fs::path resolved = fs::weakly_canonical(file, ec);
  return (ec ? fs::path(file) : resolved).parent_path().string();
}

struct Outcome {
  void* symbol = nullptr;
  std::string failure;
};

Outcome Load(const std::string& file_name, const std::string& symbol,
             const std::string& description) {
  std::vector<std::string> folders;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&LoadPluginSymbol), &info) && info.dli_fname &&
      *info.dli_fname)
    folders.push_back(DirectoryOf(info.dli_fname));
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) folders.push_back(exe.parent_path().string());
  folders.push_back(TURBID_PLUGIN_BUILD_DIR);
  std::string tried;
  for (size_t i = 0; i < folders.size(); ++i) {
    const std::string& folder = folders[i];
    if (std::find(folders.begin(), folders.begin() + static_cast<long>(i), folder) !=
        folders.begin() + static_cast<long>(i))
      continue;  // the same folder reached twice (the executable holds this code)
    const std::string candidate = (fs::path(folder) / file_name).string();
    if (!fs::exists(candidate, ec)) {
      tried += (tried.empty() ? "" : ", ") + folder;
      continue;
    }
    void* handle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* message = dlerror();
      return {nullptr,
              "cannot load " + candidate + " (" + (message ? message : "unknown error") + ")"};
    }
    void* found = dlsym(handle, symbol.c_str());
    if (!found) return {nullptr, candidate + " has no " + symbol};
    return {found, ""};
  }
  return {nullptr, "the " + description + " plugin " + file_name + " was not found (looked in " +
                       tried + ")"};
}

}  // namespace

void* LoadPluginSymbol(const std::string& file_name, const std::string& symbol,
                       const std::string& description, std::string* why) {
  static std::mutex mutex;
  static std::map<std::pair<std::string, std::string>, Outcome> outcomes;
  std::lock_guard<std::mutex> lock(mutex);
  const auto key = std::make_pair(file_name, symbol);
  auto it = outcomes.find(key);
  if (it == outcomes.end()) it = outcomes.emplace(key, Load(file_name, symbol, description)).first;
  *why = it->second.failure;
  return it->second.symbol;
}

}  // namespace turbid::plugins
