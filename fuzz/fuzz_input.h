// What every fuzz target shares. A reader may succeed or throw lp::InputError (the CLI's
// exit 2); anything else escaping it (another exception, a sanitizer report, a signal)
// is a finding: the target lets it through and libFuzzer stops on it.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "core/error.h"

namespace lp::fuzz {

// A directory of this process's own under $TMPDIR (made once, removed at a normal exit):
// most readers take a path, so each input is written to a file there first.
inline const std::string& scratch_dir() {
  static const std::string dir = [] {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/lightprobe-fuzz-XXXXXX";
    if (!::mkdtemp(pattern.data())) throw std::runtime_error("fuzz: cannot make a scratch directory");
    static const std::string made = pattern;
    std::atexit([] { std::error_code ec; std::filesystem::remove_all(made, ec); });
    return pattern;
  }();
  return dir;
}

// Writes the input to scratch_dir()/name (replacing it) and returns the path.
inline std::string write_input(const std::string& name, const uint8_t* data, size_t size) {
  const std::string path = scratch_dir() + "/" + name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  if (!out) throw std::runtime_error("fuzz: cannot write " + path);
  return path;
}

// The whole of a target whose reader takes a path: the input written to
// scratch_dir()/name, handed to `read`, InputError the one failure allowed.
template <class Read>
int read_as_file(const char* name, const uint8_t* data, size_t size, Read&& read) {
  const std::string path = write_input(name, data, size);
  try {
    read(path);
  } catch (const lp::InputError&) {
  }
  return 0;
}

inline std::string as_text(const uint8_t* data, size_t size) { return std::string(reinterpret_cast<const char*>(data), size); }

}  // namespace lp::fuzz
