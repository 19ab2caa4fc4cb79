// Chessboard detection for geometric calibration, built for fisheye and wide lenses.
//
// Strategy (first success wins):
//   1. fast cv::findChessboardCornersSB (EXHAUSTIVE, no ACCURACY) on a copy downscaled to a
//      long side of ~sb_long_side_px (never below ~sb_min_square_px per square), corners mapped
//      back and refined at full resolution by cv::cornerSubPix (window from the local square
//      size; a move above max_refine_shift_px / scale keeps SB's position): 20-45 ms/image;
//   2. cv::findChessboardCornersSB (EXHAUSTIVE | ACCURACY) at full resolution, refined the same
//      way with the max_refine_shift_px limit: recall on curved fisheye boards, steep views;
//   3. classic cv::findChessboardCorners (ADAPTIVE_THRESH | NORMALIZE_IMAGE | FAST_CHECK)
//      refined by cornerSubPix: last because it can take seconds on fisheye views where the
//      FAST_CHECK passes (4.4 s on one synthetic 190 deg view);
//   4. fisheye rectification, only when the image shows a dark surround with a bright image
//      circle: local perspective views (fields rectified_fov_deg, looking along the axis) of
//      an approximate equidistant lens whose circle is rectified_half_field_deg from the
//      axis, SB on each, corners mapped back and refined at full resolution (move limit
//      scaled by the view's local magnification). Strongly curved boards filling a > 180
//      deg field (OCamCalib's Fisheye190deg: 3 -> 6 of 8 views);
//   5. (optional) 1-4 again on a CLAHE-equalised image (dim or uneven lighting).
// Square boards (cols == rows) add mrgingham (the mrcal authors' finder) between stages 2
// and 3: on a CLAHE-equalised copy as its CLI does, image pyramid levels tried
// automatically, corners refined at full resolution like the others (method "mrgingham").
// Corner order is row-major over the board (`cols` corners per row) and deterministic:
// corner 0 is the outer corner of the grid nearest the image origin (0, 0); of the grid
// re-orderings with that first corner (and the board's shape), the one whose first row runs
// most nearly along +x (square boards) is kept. So cols x rows and rows x cols detections of
// one view are transposes of each other. Pixel coordinates: OpenCV convention (pixel
// centres at integers). The library prints nothing; bad arguments throw InputError.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/image_io.h"

namespace lp {

struct BoardSpec {
  int cols = 9, rows = 6;  // inner corners per row / per column
  double square_mm = 30;
};

struct DetectOptions {
  bool classic = true;        // stage 1
  bool sb = true;             // stage 2
  bool clahe = true;          // stage 3 (only when 1 and 2 fail)
  bool refine_sb = true;      // cornerSubPix after SB
  double max_refine_shift_px = 1.0;  // at full resolution; scaled by 1 / scale after a
                                     // downscaled SB attempt
  // SB first runs on a copy downscaled so its long side is ~sb_long_side_px (<= 0: never),
  // but not so far that a square of a board spanning half the short side would fall below
  // sb_min_square_px; its corners are refined at full resolution. Full-resolution SB is the
  // fallback when the downscaled attempt fails.
  int sb_long_side_px = 640;
  double sb_min_square_px = 8;
  // Stage 4 (see above). The field guess hardly matters (90-100 deg all work on the
  // 190 deg set): SB tolerates the residual curvature of a wrong guess.
  bool rectified = true;
  std::vector<double> rectified_fov_deg = {120, 160};
  int rectified_size_px = 640;
  double rectified_half_field_deg = 95;
  // mrgingham stage (square boards only; skipped otherwise). Alone: set sb, classic, clahe
  // false and mrgingham true.
  bool mrgingham = true;
  int mrgingham_pyramid_level = -1;  // < 0: mrgingham tries levels itself; 0: full resolution
};

struct BoardDetection {
  bool found = false;
  std::vector<std::array<double, 2>> corners;  // row-major over the board, cols per row
  std::string method;   // "classic", "sb", "mrgingham", "sb-rectified", each maybe "+clahe"; "" when not found
  std::string reason;   // why nothing was found; empty when found
  double seconds = 0;   // wall time of detect_board
  int refine_reverted = 0;       // SB corners whose cornerSubPix move exceeded the limit
  double refine_median_shift_px = 0;  // median move of the accepted refinements
};

// Throws InputError for an empty image or a board with fewer than 3 inner corners per side.
BoardDetection detect_board(const CameraImage& image, const BoardSpec& board,
                            const DetectOptions& options = {});

// Put `corners` (row-major, cols per row) into the canonical order described above.
void canonicalize_corner_order(std::vector<std::array<double, 2>>& corners, int cols, int rows);

}  // namespace lp
