// Atomic file writes: every output is written to a temporary file beside its destination and renamed
// into place, so a crash or kill never leaves a half-written file under the final name.
#pragma once

#include <functional>
#include <string>

namespace turbid {

// Calls write(temp_path) and renames temp_path to path. Refuses (Error) when path exists and
// !overwrite. Removes the temporary file if write throws.
void AtomicWrite(const std::string& path, bool overwrite,
                 const std::function<void(const std::string& temp_path)>& write);

// Convenience: writes bytes atomically.
void AtomicWriteText(const std::string& path, const std::string& bytes, bool overwrite);

// Hex sha256 of a file's bytes (for sidecars' input hashes). Throws Error when unreadable.
std::string Sha256File(const std::string& path);
std::string Sha256Bytes(const std::string& bytes);

}  // namespace turbid
