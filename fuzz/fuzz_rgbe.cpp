// RGBE (.hdr) maps, through read_envmap: its checks, the layout inference and the pixel checks.
#include "core/error.h"
#include "core/image_io.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lp::fuzz::write_input("input.hdr", data, size);
  try {
    lp::read_envmap(path);
  } catch (const lp::InputError&) {
  }
  return 0;
}
