// Chessboard detection for geometric calibration, built for fisheye and wide lenses.
//
// Strategy (first success wins; cheapest first, each stage's measured cost and recall in
// docs/calibration.md, "Board detection speed"). "Downscaled" is a copy whose long side is
// ~sb_long_side_px (never below ~sb_min_square_px per square); corners found there are
// mapped back and refined at full resolution by cv::cornerSubPix (window from the local
// square size; for SB, a move above max_refine_shift_px / scale keeps SB's position):
//   1. classic cv::findChessboardCorners with a global threshold (NORMALIZE_IMAGE |
//      FAST_CHECK), downscaled: 4-14 ms, finds straight and mildly curved boards;
//   2. cv::findChessboardCornersSB (EXHAUSTIVE, no ACCURACY), downscaled: the recall on
//      curved fisheye boards and steep views, 30-60 ms when found;
//   3. classic with ADAPTIVE_THRESH, downscaled (only when the copy is smaller);
//   4. fisheye rectification, only when the image shows a dark surround with a bright image
//      circle: local perspective views (fields rectified_fov_deg, looking along the axis) of
//      an approximate equidistant lens whose circle is rectified_half_field_deg from the
//      axis, SB on each, corners mapped back and refined at full resolution (move limit
//      scaled by the view's local magnification). Strongly curved boards filling a > 180
//      deg field (OCamCalib's Fisheye190deg: 3 -> 8 of 8 views);
//   5. SB at full resolution (only when the copy is smaller): small or far boards;
//   3 and 5 also run on every octave between the downscaled copy and full resolution
//   (intermediate_scales; 3 before 6, 5 before its full-resolution call): the finders are
//   sized in pixels, and a view found at 1032 px across can be lost at 4128;
//   6. classic with ADAPTIVE_THRESH at full resolution, last on images with a fisheye
//      circle (on curved boards there it can take seconds when its FAST_CHECK passes),
//      before 5 on the others (8-30 ms against SB's 70-240 ms when SB fails);
//   7. SB with CALIB_CB_ACCURACY at full resolution (OpenCV's most thorough call, 150-400
//      ms): the recall floor, reached only by views every other stage missed;
//   8. (optional) 1-6 again on a CLAHE-equalised image (dim or uneven lighting).
// When 1 and 2 fail, one more downscaled SB call looks for a board of any size; one larger
// than `board` (a wrong --board) ends the cascade at once with "found 9x6 inner corners,
// --board says 7x5" (the later stages would search for minutes and find nothing).
// BoardDetection::attempts lists the stages tried with their times.
// Square boards (cols == rows) add mrgingham (the mrcal authors' finder) between stages 5
// and 6: on a CLAHE-equalised copy as its CLI does, image pyramid levels tried
// automatically, corners refined at full resolution like the others (method "mrgingham").
// Corner order is row-major over the board (`cols` corners per row) and deterministic:
// corner 0 is the outer corner of the grid nearest the image origin (0, 0); of the grid
// re-orderings with that first corner (and the board's shape), the one whose first row runs
// most nearly along +x (square boards) is kept. So cols x rows and rows x cols detections of
// one view are transposes of each other. Pixel coordinates: OpenCV convention (pixel
// centres at integers). The library prints nothing; bad arguments throw InputError.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "core/image_io.h"

namespace lp {

struct BoardSpec {
  int cols = 9, rows = 6;  // inner corners per row / per column
  double square_mm = 30;
};

// A board that is not flat: mrcal's two-parameter flex (calobject_warp, mrcal.c and
// mrcal.ref_calibration_object), a parabola along each board axis with its peak deflection
// (mm, along the board's +z: away from a camera that faces the board's front) at the
// centre. Inner corner (r, c) sits at z = x2 * 4 xr (1 - xr) + y2 * 4 yr (1 - yr), with
// xr = c / (cols - 1) and yr = r / (rows - 1); {0, 0} is flat.
using BoardWarp = std::array<double, 2>;  // {x2, y2}, mrcal's order
// z (mm) of inner corner k = r * cols + c under `warp`.
inline double board_warp_z(const BoardSpec& b, int k, const BoardWarp& warp) {
  const double xr = double(k % b.cols) / (b.cols - 1), yr = double(k / b.cols) / (b.rows - 1);
  return warp[0] * 4 * xr * (1 - xr) + warp[1] * 4 * yr * (1 - yr);
}

struct DetectOptions {
  bool classic = true;        // stages 1, 3 and 6
  bool sb = true;             // stages 2, 5 and 7 (and 4, which uses SB)
  bool clahe = true;          // stage 8 (only when all others fail)
  bool refine_sb = true;      // cornerSubPix after SB
  double max_refine_shift_px = 1.0;  // at full resolution; scaled by 1 / scale after a
                                     // downscaled SB attempt
  // Stages 1-3 run on a copy downscaled so its long side is ~sb_long_side_px (<= 0: never),
  // but not so far that a square of a board spanning half the short side would fall below
  // sb_min_square_px; their corners are refined at full resolution.
  int sb_long_side_px = 640;
  double sb_min_square_px = 8;
  // Stage 4 (see above). The field guess hardly matters (90-100 deg all work on the
  // 190 deg set): SB tolerates the residual curvature of a wrong guess.
  bool rectified = true;
  std::vector<double> rectified_fov_deg = {120, 160};
  int rectified_size_px = 480;  // 640: same recall on our sets, ~1.4x the time
  double rectified_half_field_deg = 95;
  // mrgingham stage (square boards only; skipped otherwise). Alone: set sb, classic, clahe
  // false and mrgingham true.
  bool mrgingham = true;
  int mrgingham_pyramid_level = -1;  // < 0: mrgingham tries levels itself; 0: full resolution
};

// The scales between the downscaled copy's (`first_scale`) and full resolution that stages
// 3 and 5 also try: 2x, 4x, ... the first, up to 1/2 (from there full resolution is within
// an octave and tried anyway). Empty for images whose copy is already over 1/4 of full size
// (up to ~2560 px across): at 1920 px a level at 0.67 made a view without a board 40 %
// slower to give up on (its SB search there) and found nothing full resolution missed.
std::vector<double> intermediate_scales(double first_scale);

struct BoardDetection {
  bool found = false;
  std::vector<std::array<double, 2>> corners;  // row-major over the board, cols per row
  std::string method;   // "classic", "sb", "mrgingham", "sb-rectified", each maybe "+clahe"; "" when not found
  std::string reason;   // why nothing was found; empty when found
  // A board of another size that --board cannot be part of (larger in some direction),
  // seen after the cheap stages; the cascade stops there. 0 when none.
  int other_cols = 0, other_rows = 0;
  std::string attempts; // the stages tried, in order, each with its time ("sb@0.62 31 ms, ...")
  double seconds = 0;   // wall time of detect_board
  int refine_reverted = 0;       // SB corners whose cornerSubPix move exceeded the limit
  double refine_median_shift_px = 0;  // median move of the accepted refinements
};

// Throws InputError for an empty image or a board with fewer than 3 inner corners per side.
BoardDetection detect_board(const CameraImage& image, const BoardSpec& board,
                            const DetectOptions& options = {});

// Stage "detect" of a calibration: every image read (core/image_io.h read_camera_image) and
// its board detected, in parallel (each image independent, so the result does not depend on
// the order). on_image is called once per image as it finishes, from the worker threads.
// InputError: the first image (in the given order) that cannot be read, or one whose size
// differs from the first's (one camera, one resolution) other than by its EXIF Orientation
// (then its corners are turned into the frame most images have: `reoriented`).
struct BoardDetections {
  std::vector<std::string> images;                        // as given
  std::vector<BoardDetection> per_image;
  std::vector<std::vector<std::array<double, 2>>> corners;  // per image; empty: no board
  int width = 0, height = 0;  // the images' size
  int found = 0;              // images with the board
  int turned = 0;             // images turned by their EXIF Orientation (read as shown)
  // One sensor, shots turned differently (EXIF Orientation): the views not in the frame most
  // images have were turned into it (their corners; width and height are that frame's).
  int orientation = 1;        // the frame's EXIF Orientation
  int reoriented = 0;         // views turned into it
  std::vector<int> image_orientation;  // each image's EXIF Orientation as read (empty: all 1)
  double seconds = 0;         // wall time of the whole stage
};
BoardDetections detect_boards(const std::vector<std::string>& images, const BoardSpec& board,
                              const DetectOptions& options = {}, const std::function<void()>& on_image = {});

// One camera turned for some shots records it in each image's EXIF Orientation, and its
// images are read as shown. Where every image whose size is known (`shown[i]`, {0, 0}:
// unknown) has one stored size, the views not in the frame most images have (the first's on
// a tie) get their corners turned into it, in canonical order, and their `shown` size set
// to that frame's; d.orientation, d.reoriented and d.image_orientation say so.
void turn_views_into_one_frame(BoardDetections& d, std::vector<std::array<int, 2>>& shown,
                               const std::vector<int>& orientation, const BoardSpec& board);
// A view's corners in the frame d's views are in, taken back to image i's own as shown (what
// corners.vnl holds, as OpenCV and mrgingham read the image).
std::vector<std::array<double, 2>> corners_as_image_shows_them(const BoardDetections& d, size_t i);

// Put `corners` (row-major, cols per row) into the canonical order described above.
void canonicalize_corner_order(std::vector<std::array<double, 2>>& corners, int cols, int rows);

}  // namespace lp
