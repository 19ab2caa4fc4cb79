// Cameras the calibration tests share.
#pragma once

#include "calib/camera_model.h"

namespace lp::calib_test {

// 190 deg Kannala-Brandt fisheye on a 1280x960 sensor: the 95 deg ray lands 554 px from
// the centre (a circle cropped at top and bottom).
inline CameraModel kb190() {
  return {"LENSMODEL_KANNALA_BRANDT", {330, 331, 641.3, 478.6, 0.02, -0.01, 0.003, -0.0005}, 1280, 960};
}

}  // namespace lp::calib_test
