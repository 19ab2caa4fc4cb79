// OpenCV FileStorage XML camera files (a .xml path) through read_opencv_yaml, the same
// reader as the YAML target; XML goes to OpenCV's own parser (calib/camera_model.h).
#include "calib/camera_model.h"
#include "core/error.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lp::fuzz::write_input("input.xml", data, size);
  try {
    const lp::CameraModel model = lp::read_opencv_yaml(path);
    if (auto ray = lp::unproject(model, {0.5 * model.width, 0.5 * model.height})) lp::project(model, *ray);
  } catch (const lp::InputError&) {
  }
  return 0;
}
