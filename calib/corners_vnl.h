// Detected chessboard corners in mrcal's corners.vnl, so that detection and solving can be
// run (and compared) apart: what mrgingham prints and mrcal-calibrate-cameras --corners-cache
// reads (mrcal/calibration.py compute_chessboard_corners). A vnlog: the header
// "# filename x y level", then one row per corner of a view, row-major over the board with
// cols corners per row (calib/board_detect.h's order, mrcal's observations_board), and one
// row "filename - - -" for a view without a board. A corner's level is mrgingham's
// decimation level (mrcal weighs it 2^-level); '-' or a negative level marks a corner that
// was not detected.
#pragma once

#include <string>
#include <vector>

#include "calib/board_detect.h"

namespace lp {

// Writes every image of `detections` in order, atomically, corners with %.17g (a file read
// back gives bit-identical corners) at level 0 (lightprobe refines every corner at full
// resolution). InputError naming the image when its name is empty, holds whitespace or
// starts with '#' (the vnlog could not be read back).
void write_corners_vnl(const std::string& path, const BoardDetections& detections);

struct CornersFile {
  // One image per view in the file's order: its name as written, its corners (method
  // "corners.vnl"), or no board (reason says why). width, height: the image size.
  BoardDetections detections;
  // One line each: views left out (lightprobe solves whole boards only) and corners whose
  // level would weigh them below 1 in mrcal (lightprobe weighs every corner alike).
  std::vector<std::string> notes;
};

// Reads a corners.vnl for `board`, each view's corners put in the detector's order
// (canonicalize_corner_order): another tool's labelling of the grid (mrgingham's, a
// renderer's) is the same board in another pose, but the solves start from poses that
// depend on it, and on a wide rational lens one labelling left the outlier stage's rounds in
// other minima (tests/calib/corners_vnl_test.cpp). The image size is (width, height) when given, else that
// of the first image the file names that exists: as written when absolute or found from the
// working directory, else beside the file (mrcal's rule); the images need not exist
// otherwise. InputError in one line naming the file (and line): a row that is not
// "filename x y [level]" with numbers or '-', a view whose rows are not cols x rows (or the
// one row of a view without a board), a file name in two separate runs of rows, no row at
// all, an unknown image size.
// width, height: 0 for unknown, else positive whole numbers within core/limits.h
// (InputError "--imagersize ...": the flag they come from).
CornersFile read_corners_vnl(const std::string& path, const BoardSpec& board, double width = 0, double height = 0);

}  // namespace lp
