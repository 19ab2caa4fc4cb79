// Errors in three tiers (STYLE.md): assert for bugs; InputError for bad input a user
// can fix (the CLI prints its one line and exits 2); any other exception is internal (exit 1).
#pragma once

#include <stdexcept>
#include <string>

namespace lp {

// A one-line message naming the file (or option) and the broken constraint,
// e.g. "scene.exr: pixel (12, 40) is NaN".
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace lp
