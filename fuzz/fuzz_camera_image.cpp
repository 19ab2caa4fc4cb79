// Camera images (PNG, JPEG, TIFF: OpenCV decodes) through read_camera_image's own checks
// (empty file, truncated JPEG, sample type, channel count). The extension does not matter:
// the decoder goes by the bytes.
#include "core/image_io.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return lp::fuzz::read_as_file("input.png", data, size, [](const std::string& path) { lp::read_camera_image(path); });
}
