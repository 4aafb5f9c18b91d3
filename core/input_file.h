// Opening input files safely: every file turbid reads (images, depth maps, scene files, JSON,
// manifests, journals, tables, .mat and .npy files) is checked to be a regular file before it is
// opened, so that a FIFO (which blocks the open), /dev/zero (endless) or a folder named where a
// file belongs gives one line instead of a hang or a read until memory runs out. Symbolic links
// are followed: a link to a regular file is a regular file (docs/formats.md, "Input files").
#pragma once

#include <string>

namespace turbid {

// "" when `path` (after following symbolic links) is a regular file; otherwise the problem
// without the path: "file not found", "empty path" or "not a regular file". Does not open it.
std::string InputFileProblem(const std::string& path);

// Throws Error("<path>: <problem>") unless InputFileProblem(path) is empty.
void CheckInputFile(const std::string& path);

// The whole content of a regular file (CheckInputFile first). Throws Error for a file that cannot
// be opened or read.
std::string ReadInputFile(const std::string& path);

}  // namespace turbid
