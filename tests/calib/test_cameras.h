// Cameras the calibration tests share.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/camera_model.h"

namespace lp::calib_test {

// 190 deg Kannala-Brandt fisheye on a 1280x960 sensor: the 95 deg ray lands 554 px from
// the centre (a circle cropped at top and bottom).
inline CameraModel kb190() {
  return {"LENSMODEL_KANNALA_BRANDT", {330, 331, 641.3, 478.6, 0.02, -0.01, 0.003, -0.0005}, 1280, 960};
}

// Detections as detect_boards gives them, from corners projected through `cam`: image i is
// named prefix + "view_<i>.png".
inline BoardDetections detections_of(const std::vector<std::vector<std::array<double, 2>>>& corners,
                                     const CameraModel& cam, const std::string& prefix = "") {
  BoardDetections d;
  for (size_t i = 0; i < corners.size(); ++i) {
    d.images.push_back(prefix + "view_" + std::to_string(i) + ".png");
    BoardDetection b;
    b.found = !corners[i].empty();
    b.corners = corners[i];
    b.method = "projected";
    d.per_image.push_back(b);
    d.found += b.found;
  }
  d.corners = corners;
  d.width = cam.width;
  d.height = cam.height;
  return d;
}

}  // namespace lp::calib_test
