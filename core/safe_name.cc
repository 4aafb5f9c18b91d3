#include "core/safe_name.h"

#include <cstdio>
#include <filesystem>

#include "core/error.h"

namespace turbid {

namespace fs = std::filesystem;

bool IsSafeFileComponent(const std::string& name, std::string* why) {
  const auto fail = [why](const char* problem) {
    *why = problem;
    return false;
  };
  if (name.empty()) return fail("is empty");
  if (name.size() > 200) return fail("is longer than 200 bytes");
  for (const char c : name) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '/' || c == '\\')
      return fail("holds a path separator ('/' or '\\'); give a plain name");
    if (byte < 0x20 || byte == 0x7f) return fail("holds a control character");
  }
  if (name == "." || name == "..") return fail("is '.' or '..'; give a plain name");
  if (name.front() == '.') return fail("starts with '.' (hidden names are turbid's temporaries)");
  return true;
}

const std::string& SafeFileComponent(std::string_view what, const std::string& name) {
  std::string why;
  if (!IsSafeFileComponent(name, &why)) {
    throw Error(std::string(what) + " '" + PrintableName(name) + "' " + why);
  }
  return name;
}

std::string FileNameKey(const std::string& name) {
  std::string key = name;
  for (char& c : key) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return key;
}

std::string PrintableName(const std::string& text) {
  std::string out;
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7f) {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\x%02x", byte);
      out += buffer;
    } else if (c == '\\') {
      out += "\\\\";
    } else {
      out += c;
    }
  }
  return out;
}

bool IsSymlink(const std::string& path) {
  std::error_code ec;
  return fs::symlink_status(path, ec).type() == fs::file_type::symlink;
}

void RefuseSymlink(const std::string& path, const std::string& doing) {
  if (IsSymlink(path)) {
    throw Error(
        path,
        "is a symbolic link; turbid " + doing +
            " only what it created, never through a link (remove the link, or use another --out)");
  }
}

}  // namespace turbid
