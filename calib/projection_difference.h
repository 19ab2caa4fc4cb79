// How far two models of one camera disagree, in pixels: mrcal's "projection difference",
// the measure of cross-validation (model_selection.h) and of `lightprobe calib compare`.
#pragma once

#include <cstdint>
#include <vector>

#include "calib/camera_model.h"

namespace lp {

// Pixels on a grid of `step_px` where mask (width*height, row-major, nonzero = use; empty =
// whole image) is set and both models have a ray: unproject with a, rotate by the
// best-fitting rotation between the camera frames (or identity when !fit_rotation), project
// with b. Same image size expected.
struct ProjectionDiff {
  double rms_px = 0, median_px = 0, max_px = 0;
  int samples = 0;
};
ProjectionDiff projection_difference(const CameraModel& a, const CameraModel& b, const std::vector<uint8_t>& mask,
                                     int step_px, bool fit_rotation = true);

}  // namespace lp
