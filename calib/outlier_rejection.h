// Stage "reject outliers" of a geometric calibration: corners a reference model misses by
// far more than the detector's noise are marked outliers, and views that lose most of their
// corners are left out, before the candidates are solved (model_selection.h).
//
// One reference model, chosen in the first round and kept: the requested model (rational,
// then pinhole, when it cannot be fitted); else whichever of `references` (Kannala-Brandt:
// narrow to > 180 deg lenses, Mei: catadioptric, rational: perspective; one per lens
// family) fits every corner with the lowest RMS (earlier in the list on a tie: within
// `reference_tie`), pinhole when
// none can be fitted. A reference that cannot fit the lens at all (Kannala-Brandt on a
// mirror camera) would call good corners outliers and throw whole views away.
// Each round refits the reference on the views left and recomputes every corner's flag from
// scratch (so corners a gross outlier dragged off come back once it is gone): outlier when
// |residual| > max(k * sigma, floor_px), sigma = 1.4826 * MAD of the residual components.
// Rounds stop when nothing changes. With Kannala-Brandt as the reference, later rounds
// re-solve warm from the previous round's fit: no OpenCV seed, no re-posing, the same minimum
// (within 1.5e-4 px of cold solves on the three KB real sets). So do Mei's rounds where its
// xi is pinned: Mei seeded from Kannala-Brandt (a narrow lens), or corners seen beyond 45 deg
// under its first fit (mirrors, wide lenses; since stop 41): the same corners flagged on every
// shared set. Not the others: a Mei seeded by cv::omnidir on a narrow lens (its xi/focal
// valley: on Ladybug, when it was seeded so, warm rounds moved Mei by 0.17 px RMS and
// rejected other corners) and the rational model (its free extrapolation) re-solve from
// scratch.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "calib/calibration_problem.h"
#include "calib/lens_model.h"

namespace lp {

struct OutlierOptions {
  // Outlier when |residual| > k * sigma, never below floor_px (chessboard corners are good
  // to ~0.1 px: below that a noise-free set would lose good corners); at most `rounds`.
  double k = 4.0;
  double floor_px = 0.25;
  int rounds = 5;
  // The reference is chosen on at most this many views, evenly spaced, when there are more:
  // on 63 views fitting all three references cost ~20 s, and the choice only needs to tell
  // the lens family apart.
  int reference_views = 16;
  // A view loses its board when more than this fraction of its corners are outliers (or
  // fewer than 4 are left).
  double max_view_outlier_fraction = 0.5;
  // The requested model (calibrate's `model`): the reference, no choice.
  std::optional<LensType> model;
  // The candidates for the reference, one per lens family, in order of preference on a tie.
  std::vector<LensType> references = {LensType::KannalaBrandt, LensType::OmnidirMei, LensType::OpenCV8};
  // A tie: a later reference's RMS on the sample lower by less than this fraction. Two
  // references that fit within 1 % flag the same corners (the threshold is 4 sigma of the
  // residuals), and the earlier one re-solves warm: on fisheye1 Mei (0.3718 px) beat
  // Kannala-Brandt (0.3724) by 0.16 % and its cold rounds were ~40 % of the selection's CPU.
  double reference_tie = 0.01;
  // A perspective reference (the rational model) is not fitted where the better of the wide
  // ones fits the sample within perspective_fit_rms_px and sees a corner beyond this many
  // degrees off its axis (kPerspectiveFieldLimitDeg, lens_model.h: it cannot image it;
  // on the shared mirrors its fit was up to 0.5 s of CPU, the stage's slowest job, for a
  // 2.1-4.8 px misfit). Infinity: always fitted.
  double perspective_field_limit_deg = kPerspectiveFieldLimitDeg;
  double perspective_fit_rms_px = 1.5;  // SelectionOptions::fit_max_rms_px
  // The references fitted on every core (calib/parallel_jobs.h); the same choice.
  bool parallel = true;
};

struct OutlierReport {
  LensType reference = LensType::Pinhole;
  int rounds = 0;
  double sigma_px = 0, threshold_px = 0;  // of the last round
  std::vector<char> view_used;            // per view as passed in
  std::vector<std::string> why;           // per view: "" or why it lost its board
  int corners_rejected = 0;               // outlier corners of the views left
  // The reference's fit in the last round, on last_views; refit_needed when the inlier flags
  // changed after it was fitted (rounds ran out).
  std::optional<ModelFit> last_fit;
  ViewSubset last_views;
  bool refit_needed = false;
  // Whether the reference's rounds after the first, and its fit on the views left, re-solve
  // warm from the last round's fit (see above; decided on the first round's fit).
  bool reference_warm = false;
  // How every Mei fit of this calibration is seeded (SolveOptions::mei_from_kannala_brandt):
  // decided here, from Kannala-Brandt's fit of the reference sample; the stages after this
  // one solve with it too (calibrate()).
  bool mei_from_kannala_brandt = false;
  // Every reference's fit of the reference sample that was made (before any corner was
  // flagged), and the plumb_bob fit the rational one started from (rational_from_plumb_bob);
  // the sample's views. Empty when the references were not fitted on a sample (a requested
  // model).
  std::vector<std::pair<LensType, ModelFit>> sample_fits;
  ViewSubset sample_views;
};

// Updates the inlier flags of `views` (every view with a board, as make_board_views gives
// them). Progress stage "outlier rejection", one step per round. InputError when no model
// can be fitted to the corners or fewer than 4 views are left.
OutlierReport reject_outliers(const CalibrationProblem& problem, std::vector<BoardView>& views,
                              const OutlierOptions& options = {}, const StageProgress& progress = {});

// The views `used` flags (skipping index `skip`), in order.
ViewSubset used_views(const std::vector<BoardView>& views, const std::vector<char>& used, int skip = -1);

// The reference's fit on `used` (the views left) where the last round's can stand for it:
// that fit when nothing changed after it, a warm re-solve for Kannala-Brandt and for Mei
// seeded from it (SolveOptions::mei_from_kannala_brandt); nullopt otherwise (the candidate
// stage solves it cold).
std::optional<ModelFit> reference_fit(const CalibrationProblem& problem, const OutlierReport& report,
                                      const ViewSubset& used);

// The fits of the reference sample (OutlierReport::sample_fits) re-solved warm on `used`,
// on every core, when the sample held exactly those views (at most
// OutlierOptions::reference_views, none dropped): each one whose RMS on the sample's inlier
// corners is at most max_rms_px, except the reference (reference_fit carries that one). The candidate stage's
// cold solves would repeat the seeds (cv::fisheye, the unit-xi search, cv::calibrateCamera and
// the rational model's second start from plumb_bob: 0.2 s of CPU on 16 views of a 190 deg
// lens) to reach the same minima, on the inlier corners and with the board warp the stage
// decided. Where a model cannot fit the lens (a mirror), a warm start lands elsewhere than the
// cold one: those keep the cold solve.
std::vector<std::pair<LensType, ModelFit>> fits_from_sample(const CalibrationProblem& problem,
                                                            const OutlierReport& report, const ViewSubset& used,
                                                            double max_rms_px, bool parallel = true);

}  // namespace lp
