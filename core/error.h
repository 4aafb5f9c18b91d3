// Errors raised for bad data, bad files and bad options. The CLI dispatcher catches `Error` once,
// prints its one-line message and exits non-zero; the library never calls exit().
#pragma once

#include <stdexcept>
#include <string>

namespace turbid {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
  // "<file>: <problem>", the shape every file-related message takes.
  Error(const std::string& file, const std::string& problem)
      : std::runtime_error(file + ": " + problem) {}
};

// A failure of one of turbid's own output writes (a file, image, map, thumbnail, journal line or
// table could not be created, written, flushed, closed or renamed into place: a full disk, a
// quota, a file-size limit, an I/O error, a missing permission). Not a failure of the data or of
// a method: the sweep does not record it as a method failure but stops (what is journaled is
// complete), so that a plain rerun after freeing space finishes the work. The message names the
// file and the reason (strerror).
class OutputError : public Error {
 public:
  using Error::Error;
};

// Throws Error(why) when `check` fails; used to turn an Options::Check failure into an exception.
template <typename Options>
void ThrowIfInvalid(const Options& options, const std::string& context) {
  std::string why;
  if (!options.Check(&why)) throw Error(context + ": " + why);
}

}  // namespace turbid
