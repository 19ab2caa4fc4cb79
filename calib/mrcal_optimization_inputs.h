// A calibration as mrcal's own tools read it: the `optimization_inputs` of a .cameramodel
// (mrcal/cameramodel.py), the arguments of mrcal.optimize() at the optimum. With them,
// mrcal.projection_uncertainty(), mrcal-show-projection-uncertainty,
// mrcal-show-residuals-board-observation and the other tools that re-evaluate a solve run
// on lightprobe's models. Only for models mrcal has (LENSMODEL_*): lightprobe's Ceres models
// (Kannala-Brandt, Mei) are not mrcal's, and get no .cameramodel at all.
//
// The dict is the one mrcal-calibrate-cameras stores for one camera and a chessboard: the
// camera is the reference frame (no extrinsics), one frame per view, observations_board
// (views x rows x cols x (x, y, weight)) with the corners lightprobe rejected as outliers at
// weight -1 (mrcal's mark), regularisation as the solve used it, no outlier rejection of its
// own (lightprobe's rejection is in the weights), the board warp as fitted (calobject_warp
// and do_optimize_calobject_warp; None and false for a flat board).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/calibration_problem.h"
#include "calib/camera_model.h"

namespace lp {

// The solve behind a calibrated model: the views it was fitted on, every corner of each
// (inliers weight 1, rejected corners -1) and each view's board pose.
struct SolveRecord {
  std::vector<int> views;        // image index of each view (BoardView::index)
  std::vector<BoardPose> poses;  // board -> camera: mrcal's frames_rt_toref (the camera is the reference)
  std::vector<std::vector<std::array<double, 3>>> observations;  // per view, cols * rows (x, y, weight)
  bool regularization = false;   // mrcal's regularisation was part of the cost (splined models)
  bool warp_fitted = false;      // the board warp was a parameter of the solve (mrcal's do_optimize_calobject_warp)
  BoardWarp warp{};              // its value, mrcal's calobject_warp
};
// The record of `fit` (poses aligned with `views`).
SolveRecord record_solve(const ViewSubset& views, const ModelFit& fit);

// mrcal's optimization_inputs of `model` solved as `solve` says, serialised as mrcal's
// Python does (numpy_archive.h): the text between b'...' in a .cameramodel. image_paths[i]:
// the file of image index i (mrcal's imagepaths). std::invalid_argument when the model is
// not an mrcal model or the record does not match the board.
std::string mrcal_optimization_inputs(const CameraModel& model, const BoardSpec& board, const SolveRecord& solve,
                                      const std::vector<std::string>& image_paths);

}  // namespace lp
