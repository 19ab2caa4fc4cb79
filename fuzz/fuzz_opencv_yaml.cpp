// OpenCV FileStorage YAML camera files through read_opencv_yaml (the camera model) and
// read_fisheye_yaml (the probe's fisheye model), then a projection through the model read.
#include "calib/camera_model.h"
#include "core/error.h"
#include "fuzz/fuzz_input.h"
#include "probe/fisheye.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lp::fuzz::write_input("input.yaml", data, size);
  try {
    const lp::CameraModel model = lp::read_opencv_yaml(path);
    if (auto ray = lp::unproject(model, {0.5 * model.width, 0.5 * model.height})) lp::project(model, *ray);
  } catch (const lp::InputError&) {
  }
  try {
    lp::read_fisheye_yaml(path);
  } catch (const lp::InputError&) {
  }
  return 0;
}
