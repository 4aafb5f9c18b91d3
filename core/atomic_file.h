// Atomic file writes: every output is written to a temporary file beside its destination and
// renamed into place, so a crash or kill never leaves a half-written file under the final name.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace turbid {

// Calls write(temp_path) and renames temp_path to path. Refuses (Error) when path exists and
// !overwrite. Removes the temporary file if write throws.
void AtomicWrite(const std::string& path, bool overwrite,
                 const std::function<void(const std::string& temp_path)>& write);

// For programs (the CLI calls it once at start-up; the library never installs handlers itself):
// on SIGINT, SIGTERM or SIGHUP, removes the temporary files of the AtomicWrite calls in flight,
// then dies of the same signal as it would have without the handler. Without it an interrupted
// write leaves its hidden ".NAME.tmpXXXX" file beside the destination (never a partial output
// under the final name either way). SIGKILL cannot be caught: its temporaries stay until the next
// sweep, merge or generate into that folder removes them (RemoveStaleTemporaries).
// It also ignores SIGXFSZ, so that a write past a file-size limit (ulimit -f) fails with EFBIG
// and one clear error instead of killing the program with a core dump.
void RemoveTemporaryFilesOnSignal();

// Writes bytes atomically, with checked write(), fsync() and close() calls: a full disk, a quota,
// a file-size limit or an I/O error throws OutputError("<path>: cannot write: <reason> (after N of
// M bytes; nothing was written under this name)") and removes the temporary. Image writers encode
// into memory and call this, so every output goes through the same checks. A failure to create,
// rename or find the folder of the file is an OutputError too.
void AtomicWriteText(const std::string& path, const std::string& bytes, bool overwrite);

// Whether writers fsync() a file before renaming it into place (and the journal after each line):
// yes unless the environment sets TURBID_FSYNC=0 (for a file system where fsync is slow; the
// errors it would report late are then only seen when close() reports them).
bool FsyncOutputs();

// True for the names AtomicWrite gives its temporaries: ".NAME.tmpHEX" or ".NAME.tmpHEX.EXT"
// where NAME ends with .EXT.
bool IsTemporaryName(const std::string& file_name);

// Removes the temporaries that killed writers left in `folder` (and, when `recursive`, in its
// subfolders); returns how many. Only for a folder the caller holds a FolderLock on: a live
// writer's temporary would be removed from under it. `skip` names entries (files or folders,
// relative to `folder`) to leave alone: outputs written without the lock, e.g. by `turbid report`.
int RemoveStaleTemporaries(const std::string& folder, bool recursive,
                           const std::vector<std::string>& skip = {});

// An exclusive advisory lock (flock) on FOLDER/.turbid.lock for as long as the object lives: the
// writers of a result folder (sweep, merge, generate) take it so that two runs never write one
// folder at once, and so that the holder may remove the temporaries of killed earlier runs. The
// kernel releases it when the process dies, so kill -9 leaves no stale lock. Creates the folder.
// Throws Error naming `what` ("sweep or merge", "generate") when another process holds it.
class FolderLock {
 public:
  FolderLock(const std::string& folder, const std::string& what);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_ = -1;
};

// Hex sha256 of a file's bytes (for sidecars' input hashes). Throws Error when unreadable.
std::string Sha256File(const std::string& path);
std::string Sha256Bytes(const std::string& bytes);

}  // namespace turbid
