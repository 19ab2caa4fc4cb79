// Thin wrapper around mrcal 2.2's C solver (mrcal_optimize) for one stationary camera
// observing a moving chessboard (lens_model.cpp and camera_model.cpp call mrcal's lens-model
// and projection functions themselves). mrcal's C API does no seeding: the caller passes a
// complete initial guess (intrinsics + board poses), so the result is a deterministic
// function of it.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace lp {

struct MrcalProblem {
  std::string lensmodel;                 // full mrcal name (calib/lens_model.h)
  std::vector<double> intrinsics_seed;   // mrcal_lensmodel_num_params values
  // Board -> camera pose per view (Rodrigues r, then t), the seed; updated on output.
  std::vector<std::array<double, 6>> poses_seed;
  // Per view: cols*rows observations (x, y, weight); weight < 0 marks an ignored corner.
  std::vector<std::vector<std::array<double, 3>>> observations;
  int width = 0, height = 0;
  int cols = 0, rows = 0;  // inner corners; corner i = r * cols + c at (c, r) * spacing
  double spacing = 1;
  bool optimize_intrinsics = true;
  bool regularization = false;  // mrcal's regularisation (wanted for splined models)
  // Fit the board's flex (mrcal's calobject_warp: {x2, y2}, calib/board_detect.h BoardWarp)
  // from warp_seed; else the board is flat.
  bool optimize_warp = false;
  std::array<double, 2> warp_seed{};
};

struct MrcalSolution {
  bool ok = false;
  std::string error;
  std::vector<double> intrinsics;
  std::vector<std::array<double, 6>> poses;
  std::array<double, 2> warp{};  // the fitted calobject_warp ({0, 0} unless optimize_warp)
  double rms_px = 0;
};

// Runs mrcal_optimize (no outlier rejection of its own: ignored corners come in with
// weight < 0). Never prints on purpose (mrcal itself may complain on stderr on failure).
MrcalSolution mrcal_solve(const MrcalProblem& problem);

// Number of intrinsics of a configured mrcal model name; -1 when mrcal does not know it
// (mrcal's own answer: calib/lens_model.h's table is checked against it).
int mrcal_model_param_count(const std::string& lensmodel);

}  // namespace lp
