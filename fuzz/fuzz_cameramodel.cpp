// mrcal .cameramodel text files through read_cameramodel, then a projection round trip
// through the model read (a model that parses must also be usable).
#include "calib/camera_model.h"
#include "core/error.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lp::fuzz::write_input("input.cameramodel", data, size);
  try {
    const lp::CameraModel model = lp::read_cameramodel(path);
    if (auto ray = lp::unproject(model, {0.5 * model.width, 0.5 * model.height})) lp::project(model, *ray);
  } catch (const lp::InputError&) {
  }
  return 0;
}
