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

// Throws Error(why) when `check` fails; used to turn an Options::Check failure into an exception.
template <typename Options>
void ThrowIfInvalid(const Options& options, const std::string& context) {
  std::string why;
  if (!options.Check(&why)) throw Error(context + ": " + why);
}

}  // namespace turbid
