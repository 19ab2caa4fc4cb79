// Pictures of a geometric calibration: where the corners were (coverage), and how the
// fitted model misses them (residual vectors, magnified). Written as PNG.
#pragma once

#include <string>

#include "calib/geometric.h"

namespace lp {

struct CalibrationPlotOptions {
  int max_width_px = 1024;    // the picture is the image scaled down to this width
  double arrow_scale = 0;     // residual magnification; 0: the largest inlier arrow is 40 px
};

// Residual vectors (inliers blue-green by magnitude, outliers red) over the image frame,
// with the corners as dots.
void write_residual_plot(const std::string& path, const CalibrationResult& result,
                         const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                         const CalibrationPlotOptions& options = {});
// Inlier corners per cell (CalibrationResult::coverage) as a heat map, empty cells dark red,
// so poorly covered image corners show at a glance.
void write_coverage_plot(const std::string& path, const CalibrationResult& result,
                         const CalibrationPlotOptions& options = {});
// The headline projection uncertainty (CalibrationResult::uncertainty, rays at infinity) as
// a heat map over the image, log colour scale with a legend (px), cells where the model has
// no ray black; the covered area's outline is not drawn (see the coverage plot). InputError
// when the result has no uncertainty grid.
void write_uncertainty_plot(const std::string& path, const CalibrationResult& result,
                            const CalibrationPlotOptions& options = {});

}  // namespace lp
