// Folder datasets (scenes/folder_dataset.h).
#include "scenes/folder_dataset.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <set>

#include "core/error.h"
#include "scenes/image_io.h"
#include "scenes/npy_io.h"

namespace turbid {
namespace fs = std::filesystem;
namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// stem -> path for the files in `folder` whose extension is in `extensions`.
std::map<std::string, std::string> StemsIn(const std::string& folder,
                                           const std::set<std::string>& extensions,
                                           const std::string& what) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw Error(folder, what + " folder not found");
  std::map<std::string, std::string> out;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    const fs::path& p = entry.path();
    const std::string name = p.filename().string();
    if (name.empty() || name[0] == '.' || !entry.is_regular_file(ec)) continue;
    if (!extensions.count(Lower(p.extension().string()))) continue;
    const std::string stem = p.stem().string();
    const auto [it, inserted] = out.emplace(stem, p.string());
    if (!inserted) {
      const std::string first = fs::path(it->second).filename().string();
      throw Error(folder, "two " + what + " files with stem '" + stem + "' (" +
                              std::min(first, name) + ", " + std::max(first, name) + ")");
    }
  }
  if (ec) throw Error(folder, "cannot list: " + ec.message());
  return out;
}

std::string Under(const std::string& root, const std::string& sub) {
  const fs::path p(sub);
  return p.is_absolute() ? p.string() : (fs::path(root) / p).lexically_normal().string();
}

// "a, b, c" with at most `limit` names, then "and N more".
std::string FirstNames(const std::vector<std::string>& names, size_t limit = 3) {
  std::string out;
  for (size_t i = 0; i < names.size() && i < limit; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > limit) out += " and " + std::to_string(names.size() - limit) + " more";
  return out;
}

}  // namespace

bool FolderDatasetOptions::Check(std::string* why) const {
  if (rgb_dir.empty() || depth_dir.empty()) {
    if (why) *why = "rgb and depth folders must be named";
    return false;
  }
  return true;
}

bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i]));
    const bool db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      size_t ei = i, ej = j;
      while (ei < a.size() && std::isdigit(static_cast<unsigned char>(a[ei]))) ++ei;
      while (ej < b.size() && std::isdigit(static_cast<unsigned char>(b[ej]))) ++ej;
      // Compare the digit runs as numbers: strip leading zeros, then length, then digits.
      size_t si = i, sj = j;
      while (si + 1 < ei && a[si] == '0') ++si;
      while (sj + 1 < ej && b[sj] == '0') ++sj;
      if (ei - si != ej - sj) return ei - si < ej - sj;
      const int c = a.compare(si, ei - si, b, sj, ej - sj);
      if (c != 0) return c < 0;
      if (ei - i != ej - j) return ei - i < ej - j;  // "7" before "007": fewer zeros first
      i = ei;
      j = ej;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

std::vector<FolderFrame> ListFolderFrames(const std::string& root,
                                          const FolderDatasetOptions& options) {
  ThrowIfInvalid(options, root);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) throw Error(root, "dataset folder not found");
  const std::string rgb_folder = Under(root, options.rgb_dir);
  const std::string depth_folder = Under(root, options.depth_dir);
  const auto rgb = StemsIn(rgb_folder, {".png", ".jpg", ".jpeg"}, "colour");
  const auto depth = StemsIn(depth_folder, {".png", ".exr", ".pfm", ".npy"}, "depth");
  std::vector<std::string> rgb_only, depth_only;
  for (const auto& [stem, path] : rgb)
    if (!depth.count(stem)) rgb_only.push_back(fs::path(path).filename().string());
  for (const auto& [stem, path] : depth)
    if (!rgb.count(stem)) depth_only.push_back(fs::path(path).filename().string());
  if (!rgb_only.empty())
    throw Error(rgb_folder, std::to_string(rgb_only.size()) + " colour file(s) without a depth file " +
                                "of the same stem in " + depth_folder + ": " + FirstNames(rgb_only));
  if (!depth_only.empty())
    throw Error(depth_folder, std::to_string(depth_only.size()) +
                                  " depth file(s) without a colour file of the same stem in " +
                                  rgb_folder + ": " + FirstNames(depth_only));
  if (rgb.empty())
    throw Error(root, "no frames (" + rgb_folder + " holds no .png/.jpg, " + depth_folder +
                          " no .png/.exr/.pfm/.npy)");
  std::vector<FolderFrame> frames;
  for (const auto& [stem, path] : rgb) frames.push_back({stem, path, depth.at(stem)});
  std::sort(frames.begin(), frames.end(),
            [](const FolderFrame& a, const FolderFrame& b) { return NaturalLess(a.stem, b.stem); });
  return frames;
}

RawDepthFile ReadRawDepthFile(const std::string& path) {
  RawDepthFile out;
  if (IsNpyFile(path)) {
    NpyArray array = ReadNpy(path);
    out.values = array.values;
    out.integer = array.integer;
    return out;
  }
  const ImageFormat format = DetectImageFormat(path);
  ReadImageOptions options;
  options.keep_raw = true;
  out.values = ReadImage(path, options);
  out.integer = format == ImageFormat::kPng || format == ImageFormat::kPnm ||
                format == ImageFormat::kJpeg;
  return out;
}

}  // namespace turbid
