// Names the file an operation works on when it runs out of memory or OpenCV refuses it: the CLI
// dispatcher (tools/cli/cli.cc) catches std::bad_alloc and cv::Exception too, but can name only the
// command that was running.
#pragma once

#include <new>
#include <opencv2/core.hpp>
#include <string>

#include "core/error.h"

namespace turbid {

// OpenCV's what() spans lines and names OpenCV's own source file; this keeps the function and
// the check that failed, on one line.
inline std::string OpenCvProblem(const cv::Exception& e) {
  std::string text =
      "OpenCV error in " + (e.func.empty() ? std::string("an operation") : e.func) + ": " + e.err;
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

// OpenCV's allocation failure (cv::Error::StsNoMem, "Failed to allocate N bytes").
inline bool IsOpenCvOutOfMemory(const cv::Exception& e) { return e.code == cv::Error::StsNoMem; }

// Runs `work` (which works on `path`); std::bad_alloc (and OpenCV's allocation failure) and
// cv::Exception leave it as Error("<path>: out of memory while <doing>") and
// Error("<path>: <doing>: OpenCV error in <function>: <check>").
template <typename Work>
decltype(auto) WithFileContext(const std::string& path, const std::string& doing, Work&& work) {
  try {
    return work();
  } catch (const std::bad_alloc&) {
    throw Error(path, "out of memory while " + doing);
  } catch (const cv::Exception& e) {
    if (IsOpenCvOutOfMemory(e)) throw Error(path, "out of memory while " + doing);
    throw Error(path, doing + ": " + OpenCvProblem(e));
  }
}

}  // namespace turbid
