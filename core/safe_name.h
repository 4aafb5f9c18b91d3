// File names derived from data (scene names, frame keys, item ids, method labels): every output
// path that holds one is built from a single checked component, so data can never steer a write
// outside the output folder or make two outputs one file. Filesystem helpers for clean-up that
// must never follow symbolic links.
#pragma once

#include <string>
#include <string_view>

namespace turbid {

// Whether `name` can be used as one file or folder name inside an output folder: 1-200 bytes, no
// path separator ('/' or '\'), no NUL or other control character, not "." or "..", and not
// starting with '.' (hidden names are turbid's temporaries and lock). *why says what is wrong.
bool IsSafeFileComponent(const std::string& name, std::string* why);

// Returns `name` when IsSafeFileComponent; otherwise throws Error("<what> '<name>': <why>") with
// control characters in the name shown as \xNN, e.g. SafeFileComponent("scene name", name).
const std::string& SafeFileComponent(std::string_view what, const std::string& name);

// The key under which two names are the same file on a case-insensitive file system (macOS, Windows
// shares): ASCII lower case. Use it for the collision checks of names that become files.
std::string FileNameKey(const std::string& name);

// `text` with control characters (and backslashes) written as \xNN / \\, for messages.
std::string PrintableName(const std::string& text);

// Whether `path` itself is a symbolic link (lstat; false when it does not exist).
bool IsSymlink(const std::string& path);

// Throws Error("<path>: is a symbolic link; turbid <doing> only what it created, never through a
// link (...)") when `path` is a symbolic link. For the files and folders turbid creates and later
// cleans or writes into.
void RefuseSymlink(const std::string& path, const std::string& doing);

}  // namespace turbid
