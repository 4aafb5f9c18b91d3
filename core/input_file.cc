#include "core/input_file.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace turbid {

std::string InputFileProblem(const std::string& path) {
  if (path.empty()) return "empty path";
  struct stat info {};
  // stat follows symbolic links and never opens the file (a FIFO's open would block).
  if (::stat(path.c_str(), &info) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return "file not found";
    return std::string("cannot open for reading (") + std::strerror(errno) + ")";
  }
  if (!S_ISREG(info.st_mode)) return "not a regular file";
  return "";
}

void CheckInputFile(const std::string& path) {
  const std::string problem = InputFileProblem(path);
  if (problem.empty()) return;
  if (path.empty()) throw Error("empty file path (a file name is required)");
  throw Error(path, problem);
}

std::string ReadInputFile(const std::string& path) {
  CheckInputFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open for reading");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) throw Error(path, "read failed");
  return bytes.str();
}

}  // namespace turbid
