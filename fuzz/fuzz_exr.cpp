// OpenEXR maps: the header (size, channels, lightprobe.* attributes), then the pixels, through read_envmap: its checks, the layout inference and the pixel checks.
#include "core/image_io.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return lp::fuzz::read_as_file("input.exr", data, size, [](const std::string& path) { lp::read_envmap(path); });
}
