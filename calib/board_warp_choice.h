// Whether the board's flex (mrcal's calobject_warp, SolveOptions::board_warp) repays its two
// parameters on this set: the warp is a challenger to the flat board, and it is kept only
// where it wins the incumbent rule's comparison (model_selection.h challenge_over_splits)
// over balanced splits of the views, as a richer lens model must.
//
// Why a test and not "always on": on small, far boards a warp estimated from each half adds
// variance that a nearly flat board does not repay (the shared stereo set's halves agreed to
// 0.083 px flat and 0.163 px with the warp, docs/calibration.md "Board warp"), while on large
// boards close up it is the difference between a calibration and a misfit (rejected corners
// 37 -> 2 of 2240, halves 0.22 -> 0.04 px). The warp's own significance does not tell them
// apart: stereo's is 6 sigma from flat.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "calib/calibration_problem.h"
#include "calib/calibration_solve.h"
#include "calib/model_selection.h"

namespace lp {

struct BoardWarpChoiceOptions {
  // Balanced splits of the used views (balanced_view_splits); each costs two warm refits
  // of the reference model with the warp and two without. 4: t(0.975, 3) = 3.18 standard
  // errors, the selection's own test at its default; a set of at most
  // selection.small_set_views views gets selection.small_set_cv_splits, as the selection.
  int splits = 4;
  SelectionOptions selection;  // floor_px, outfit_factor, small_set_views, small_set_cv_splits
  // Fewer used views than this: not judged, the warp kept (mrcal's default). The splits'
  // halves would hold 2 views, too few to tell a flex from the lens: halves of 4 views of
  // the shared 190 deg set, whose whole set keeps the warp, went flat and agreed to 0.92 px
  // against 0.54 with it (docs/calibration.md).
  int min_views = 6;
  bool parallel = true;
};

struct BoardWarpChoice {
  // false: not asked (why empty), or not tested: fewer than min_views views, or a fit or a
  // split failed (why says which; the warp kept).
  bool decided = false;
  bool keep = true;      // the warp won: fitted in every solve of the calibration
  std::string model;     // the model both were fitted with (the outlier stage's reference)
  SplitValues warp, flat;
  std::vector<std::vector<int>> splits;  // the balanced splits both were refitted on
  SplitChallenge challenge;  // the warp challenging the flat board
  // The warp outfits the flat board (SelectionOptions::outfit_factor: its held-out RMS lower
  // by more than that factor on every split): a bent board's misfit is systematic, and a
  // few noisy splits cannot make a t test say so (5 views of a board bent by 3 mm: 4 of 4
  // splits 2.5 px better, t 2.8 < 3.18).
  bool outfits = false;
  // One line: what decided ("the warp repays its parameters over 4 splits: ..." or "the
  // warp does not repay ..."), or why nothing was decided.
  std::string why;
};

// `warped`: `type`'s fit of `used` with the warp (problem.solve.board_warp true). The flat
// fit is re-solved warm from it with the warp held at zero; each split's halves are refitted
// warm from each. `mask`, `step`: where the cross-validation compares the half-models
// (CandidateFits::mask, step). Progress stage "board warp", one step.
// `flat_fit`, when given, receives the flat fit of `used` (ok false when it failed).
BoardWarpChoice choose_board_warp(const CalibrationProblem& problem, const ViewSubset& used, LensType type,
                                  const ModelFit& warped, const std::vector<uint8_t>& mask, int step,
                                  const BoardWarpChoiceOptions& options = {}, const StageProgress& progress = {},
                                  ModelFit* flat_fit = nullptr);

}  // namespace lp
