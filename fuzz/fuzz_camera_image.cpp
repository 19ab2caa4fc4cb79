// Camera images (PNG, JPEG, TIFF: OpenCV decodes) through read_camera_image's own checks
// (empty file, truncated JPEG, sample type, channel count). The extension does not matter:
// the decoder goes by the bytes.
#include "core/error.h"
#include "core/image_io.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lp::fuzz::write_input("input.png", data, size);
  try {
    lp::read_camera_image(path);
  } catch (const lp::InputError&) {
  }
  return 0;
}
