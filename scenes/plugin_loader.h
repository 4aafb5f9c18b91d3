// Finding and opening turbid's on-demand plugins (turbid_oiio.so, turbid_hdf5.so): shared libraries
// built from this tree that hold the code needing a heavy library, opened with dlopen only when a
// file needs them so that no other run loads that library (docs/architecture.md, "Linking").
#pragma once

#include <string>

namespace turbid::plugins {

// Looks for `file_name` beside the binary holding this code (the turbid executable, the Python
// extension), beside the running executable, then in the build tree; opens the first one found and
// returns its symbol `symbol`. On failure returns nullptr with a one-line reason in *why: "the
// <description> plugin <file_name> was not found (looked in ...)", "cannot load <file> (...)" or
// "<file> has no <symbol>". The outcome is remembered per file and symbol. Thread-safe.
void* LoadPluginSymbol(const std::string& file_name, const std::string& symbol,
                       const std::string& description, std::string* why);

}  // namespace turbid::plugins
