// Stage "solve" of a geometric calibration: each candidate model fitted to a set of views
// from its seed (calibration_seed.h), every inlier corner in one joint least-squares solve
// of the intrinsics and all board poses.
//
//   Kannala-Brandt, Mei   Ceres (dense Schur, one thread) with camera_model.cpp's
//                         projection (theta from atan2, so rays beyond 90 deg work);
//   pinhole, plumb_bob, rational
//                         mrcal's solver from the rounded cv::calibrateCamera seed; OpenCV's
//                         own solution is kept when mrcal fails or does not improve it;
//   stereographic, splined
//                         mrcal (splined with its regularisation).
// The result is a deterministic function of the corners: the same views always give
// bit-identical intrinsics.
#pragma once

#include <condition_variable>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "calib/calibration_problem.h"
#include "calib/calibration_seed.h"
#include "calib/lens_model.h"

namespace lp {

// Ceres joint solve of a Kannala-Brandt or Mei fit from `seed` (poses aligned with `views`),
// the board warp with it (SolveOptions::board_warp); the seed when the solve fails or does
// not lower the cost.
ModelFit refine_kannala_brandt(const CalibrationProblem& problem, const ViewSubset& views, const ModelFit& seed);
ModelFit refine_mei(const CalibrationProblem& problem, const ViewSubset& views, const ModelFit& seed);
// mrcal's solve of model `lensmodel` from the intrinsics, poses and board warp given (the
// warp is fitted by mrcal's calobject_warp term with SolveOptions::board_warp, else flat; no
// outlier rejection: outliers come in ignored); not ok with mrcal's reason when it fails.
ModelFit solve_mrcal(const CalibrationProblem& problem, const ViewSubset& views, const std::string& lensmodel,
                     std::vector<double> intrinsics, const std::vector<BoardPose>& poses, bool regularization,
                     const BoardWarp& warp = {});

// The fit of candidate `type` from its seed (seed_candidate's fit), as CandidateSolver solves
// it: Ceres for Kannala-Brandt and Mei, mrcal for the others (the OpenCV fit polished).
ModelFit refine_seed(const CalibrationProblem& problem, const ViewSubset& views, LensType type, const ModelFit& seed);

// Every candidate of one set of views, each solved once, on demand: a candidate's seed may
// need another's solve (stereographic from Kannala-Brandt), which is then shared.
// Thread-safe: several threads may ask for candidates at once (the selection solves them in
// parallel); each fit is solved by one thread, and a thread that asks for a fit another is
// solving waits for it. A fit, once made, is never replaced (references stay valid), and is
// the same whichever thread made it: every solve is a function of the views alone.
class CandidateSolver {
 public:
  CandidateSolver(const CalibrationProblem& problem, ViewSubset views, SeedOptions seed = {})
      : problem_(problem), views_(std::move(views)), seed_(seed) {}
  const ViewSubset& views() const { return views_; }
  // The solved fit of candidate `type` (not ok, with the reason, when it cannot be fitted or
  // cannot image some inlier corner).
  const ModelFit& get(LensType type);
  // A fit of `type` on these views made elsewhere (warm-started): used instead of solving
  // (ignored when that candidate was solved already).
  const ModelFit& adopt(LensType type, ModelFit fit);
  // The fit of `type` when it has been solved or adopted already (nullptr otherwise); does
  // not solve it.
  const ModelFit* solved(LensType type);
  // The fits already made by `sample_solver`, on a sample of these views of the same problem:
  // a solve that seeds on a sample (SeedOptions::sample_views) takes them when its sample is
  // those views, instead of solving it again (the outlier stage's reference choice and its
  // first round, and the selection's screening sample to the full fits: on 32 synthetic views
  // Kannala-Brandt's 16-view fit, 0.17 s, twice in a row). Call while no other thread uses
  // this solver.
  void reuse_sample_fits(CandidateSolver& sample_solver);
  // Puts `fit` in place of the solved fit of `type` (a better one found later). Call while no
  // other thread uses this solver: references to the old fit become the new one's.
  void replace(LensType type, ModelFit fit);

 private:
  ModelFit solve(LensType type);
  ModelFit solve_seeded(LensType type, const CalibrationProblem& pr);  // solve() with pr's settings
  const CalibrationProblem& problem_;
  ViewSubset views_;
  SeedOptions seed_;
  std::mutex mutex_;
  std::condition_variable solved_;
  std::set<LensType> solving_;  // being solved by some thread
  std::map<LensType, ModelFit> cache_;
  ViewSubset sample_views_;                    // reuse_sample_fits' views
  std::map<LensType, ModelFit> sample_fits_;   // and their fits
};

// The selection and the outlier stage's reference choice do not fit perspective models
// where a wide-angle fit sees the corners beyond kPerspectiveFieldLimitDeg (lens_model.h).

// The widest angle off the axis at which the better of the solver's Kannala-Brandt and Mei
// fits (the lower RMS, when it is at most max_rms_px) sees a used corner, with that fit's
// candidate; NaN when neither fits. Solves the two fits when they are not solved yet:
// callers ask only where they fit these models anyway.
struct WideField {
  double deg = std::numeric_limits<double>::quiet_NaN();
  LensType seen_by = LensType::KannalaBrandt;
};
WideField wide_fit_field(const CalibrationProblem& problem, CandidateSolver& solver, double max_rms_px);

// The rational model (OpenCV8) also solved from plumb_bob's fit (k4 = k5 = k6 = 0: the same
// projection), and the better of the two fits kept.
// cv::calibrateCamera's rational fit from scratch can stop far off on a wide lens: an audit's
// synthetic 125 deg rational lenses left it at 5.7 px RMS on every view (screened out), or
// fitted its halves at 7.5 px held out, and a worse family was chosen, 2-17 px from the
// truth. Started from plumb_bob's fit it ends no worse than plumb_bob.
ModelFit rational_from_plumb_bob(const CalibrationProblem& problem, const ViewSubset& views, ModelFit rational,
                                 const ModelFit& plumb_bob);

// The rational model also solved from Kannala-Brandt's fit (`wide`): its radial profile
// theta -> r_d over the corners' field rewritten as the rational model's r_u -> r_d
// (r_u = tan theta; linear least squares in k1..k6, p1 = p2 = 0; the same core and poses),
// then refined by mrcal; the better of that and `rational` kept. Only where the corners reach
// beyond kRationalFromWideProfileFieldDeg under `wide` (and within 88 deg, where tan theta
// stays finite). The other starts begin from no distortion or from plumb_bob's fit, and on a
// wide rational lens (6000x3376, corners to 75 deg, k4 = 1.1) both stopped at 0.41 px RMS on
// every view; from Kannala-Brandt's profile it fits at the noise, 0.028 px. CandidateSolver
// and the outlier stage's rational reference both use it.
constexpr double kRationalFromWideProfileFieldDeg = 60;
ModelFit rational_from_wide_profile(const CalibrationProblem& problem, const ViewSubset& views, ModelFit rational,
                                   const ModelFit& wide);

// `f` (a fit of `type` on `views`) with the views stuck in the wrong one of a planar board's
// two poses posed again and every view refitted warm, where that fits better; else `f`.
// CandidateSolver applies it to every solve; a fit carried from another stage needs it too.
ModelFit repose_stuck_views(const CalibrationProblem& problem, const ViewSubset& views, LensType type,
                            const ModelFit& f);

// The fit of candidate `type` on `views` warm-started from `from`, a fit on a superset of
// them (`poses`: from's poses of `views`, aligned): the jackknife's leave-one-out fits and
// the repeated splits converge to the same minimum as a cold start, in a fraction of the
// time. Falls back to a cold solve.
ModelFit warm_refit(const CalibrationProblem& problem, const ViewSubset& views, LensType type, const ModelFit& from,
                    const std::vector<BoardPose>& poses);

}  // namespace lp
