// Atomic file writes: every output is written to a temporary file beside its destination and
// renamed into place, so a crash or kill never leaves a half-written file under the final name.
#pragma once

#include <functional>
#include <string>

namespace turbid {

// Calls write(temp_path) and renames temp_path to path. Refuses (Error) when path exists and
// !overwrite. Removes the temporary file if write throws.
void AtomicWrite(const std::string& path, bool overwrite,
                 const std::function<void(const std::string& temp_path)>& write);

// For programs (the CLI calls it once at start-up; the library never installs handlers itself):
// on SIGINT, SIGTERM or SIGHUP, removes the temporary files of the AtomicWrite calls in flight,
// then dies of the same signal as it would have without the handler. Without it an interrupted
// write leaves its hidden ".NAME.tmpXXXX" file beside the destination (never a partial output
// under the final name either way). SIGKILL cannot be caught: its temporaries stay.
void RemoveTemporaryFilesOnSignal();

// Convenience: writes bytes atomically.
void AtomicWriteText(const std::string& path, const std::string& bytes, bool overwrite);

// Hex sha256 of a file's bytes (for sidecars' input hashes). Throws Error when unreadable.
std::string Sha256File(const std::string& path);
std::string Sha256Bytes(const std::string& bytes);

}  // namespace turbid
