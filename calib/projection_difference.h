// How far two models of one camera disagree, in pixels: mrcal's "projection difference",
// the measure of cross-validation (model_selection.h) and of `lightprobe calib compare`.
#pragma once

#include <cstdint>
#include <optional>
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

// b's rays at the grid pixels above, unprojected once for a model compared with many others
// (the leverage's leave-one-out refits against the chosen fit, the noise jackknife's refits
// against the other half): an OpenCV model's unprojection is an iterative solve per pixel in
// mrcal, and it was a third of a forced calibration's CPU. The difference is the same, bit for
// bit, as projection_difference(a, b, mask, step_px).
struct GridRays {
  std::vector<Pixel> pixels;             // the grid pixels where the mask is set, row by row
  std::vector<std::optional<Vec3>> rays;  // b's ray at each (none where b has none)
};
GridRays grid_rays(const CameraModel& b, const std::vector<uint8_t>& mask, int step_px);
ProjectionDiff projection_difference(const CameraModel& a, const CameraModel& b, const GridRays& b_rays,
                                     bool fit_rotation = true);
// The same with a's rays on the same grid too (grid_rays(a, mask, step_px)): the two
// unprojections of a split's halves run beside their refits, not after both (model_selection).
ProjectionDiff projection_difference(const GridRays& a_rays, const CameraModel& b, const GridRays& b_rays,
                                     bool fit_rotation = true);

}  // namespace lp
