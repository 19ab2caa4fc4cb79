// mrcal's corners.vnl (calib geometric --corners-in) through read_corners_vnl with the image
// size given (no image is opened), then written back as --corners-out writes it.
#include "calib/corners_vnl.h"
#include "core/error.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lp::fuzz::write_input("corners.vnl", data, size);
  try {
    const lp::CornersFile f = lp::read_corners_vnl(path, lp::BoardSpec{3, 2, 10}, 640, 480);
    lp::write_corners_vnl(lp::fuzz::scratch_dir() + "/out.vnl", f.detections);
  } catch (const lp::InputError&) {
  }
  return 0;
}
