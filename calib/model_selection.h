// Stages "solve candidates" and "cross-validate and select" of a geometric calibration.
//
// Every candidate is solved (calibration_solve.h) on the views left after outlier rejection
// and on each odd/even half of them, except those screened out as unable to fit the lens
// (CandidateOptions: one short solve on a sample, then the fit of every view), the
// independent solves on every core. Accuracy is cross-validation: the two half-models
// compared over the area the boards covered (unproject with A, best rotation between the
// two camera frames, project with B): the pixel disagreement is what a user can expect from
// recalibrating (mrcal's "projection difference"). The held-out RMS is each half's model on
// the other half's corners, poses re-solved.
//
// The model chosen (SelectionRule::Incumbent, the default) is the simplest candidate of the
// lens's own family (SelectionOptions::perspective_field_deg) unless another beats it beyond
// the noise of the comparison, measured on the same balanced splits of the views: each
// split's halves are refitted and give a held-out RMS (each half's model on the other half's
// corners) and a cross-validation; a candidate beats another when one of the two is better
// on most splits and on average by more than a Student t quantile times the standard error of
// the paired differences over the splits, and the other is not significantly worse. The pick
// is the first candidate, in that order, that no later candidate beats (not the last winner
// of a chain of challenges, which depended on their order). Deciding on the spread of the
// difference over resamples, and keeping the simpler model on a near tie, makes the choice
// hold on other subsets of the views (issue 21: the rule of before, the fewest parameters
// among those within a fixed multiple of one jackknife noise of the best, chose Mei on one
// half of a fisheye set and Kannala-Brandt on the other). SelectionRule::SimplestWithinNoise
// is that rule, still computed and reported beside.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "calib/calibration_problem.h"
#include "calib/calibration_solve.h"
#include "calib/lens_model.h"

namespace lp {

struct ModelCandidate {
  std::string name;       // candidate name as in CalibrateOptions::candidates (lens_model.h)
  std::string lensmodel;  // camera_model.h name of the fitted model
  std::string solver;     // how its full fit was obtained (ModelFit::solver: the seed, then the refinement)
  int params = 0;         // free intrinsics
  bool ok = false;
  std::string error;      // why the fit failed (when !ok)
  // Not ok because its fit of every used view misses the corners (rms_px above
  // CandidateOptions::screen_rms_px): the halves were not fitted, nothing below rms_px is.
  bool screened = false;
  double rms_px = 0;                 // reprojection RMS (per corner, 2-D) of the full fit
  // One half's intrinsics on the other half's corners (poses re-solved with intrinsics
  // fixed: PnP on the unprojected rays, then pixel refinement), both ways; inf when some
  // view cannot be posed under the model (e.g. a pinhole model and rays near 90 deg).
  double heldout_rms_px = 0;
  double cross_validation_px = 0;    // RMS odd-vs-even projection difference, covered area
  double cross_validation_median_px = 0;
  // The cross-validation of each balanced split (CalibrateOptions::cv_splits; the first is
  // the odd/even one above) and their RMS, which ranks the candidates. Empty / NaN when the
  // candidate was screened out (see SelectionOptions::screen_factor) or cv_splits = 1; inf
  // when a half of some split could not be fitted.
  std::vector<double> cross_validation_splits_px;
  double cross_validation_repeated_px = std::numeric_limits<double>::quiet_NaN();
  // The held-out RMS of each of those splits (the first = heldout_rms_px), the statistic the
  // incumbent rule compares; and on how many splits this candidate had the lowest held-out
  // RMS of the candidates with every split (a vote over resamples, reported).
  std::vector<double> heldout_splits_px;
  int split_wins = 0;
  // Its splits were raced (SelectionOptions::race_dear_candidates) and stopped once it could
  // no longer change the pick: the splits above hold only the first ones, and
  // cross_validation_repeated_px is NaN.
  bool raced_out = false;
  // Left out of the incumbent rule: another candidate fitted the held-out corners better by
  // more than SelectionOptions::outfit_factor on every split, and repeated no worse on at
  // least half of them.
  bool outfitted = false;
  // Its comparison with the pick (SelectionRule::Incumbent): mean over splits of the pick's
  // held-out RMS minus its own (> 0: it fits the other halves' corners better) and the
  // standard error of that mean from the splits' spread; NaN for the pick itself and when
  // not every split was fitted.
  double challenge_gain_px = std::numeric_limits<double>::quiet_NaN();
  double challenge_se_px = std::numeric_limits<double>::quiet_NaN();
  // The same for the cross-validation (the pick's minus its own, per split).
  double challenge_cv_gain_px = std::numeric_limits<double>::quiet_NaN();
  double challenge_cv_se_px = std::numeric_limits<double>::quiet_NaN();
  bool within_noise = false;  // cv and held-out RMS within the noise of the best's (see options)
  // mrcal-style linearised projection uncertainty of this candidate's full fit (a ray at
  // infinity, rotation fitted out): the RMS 2-D sigma over the area the boards covered, and
  // the cross-validation it forecasts (2x that). NaN when not computed (options.uncertainty
  // off, splined models, singular normal equations). Reported beside the cross-validation;
  // it does not take part in the pick (it is 1.4-3.3x optimistic on real corners).
  double linear_sigma_px = std::numeric_limits<double>::quiet_NaN();
  double linear_forecast_cv_px = std::numeric_limits<double>::quiet_NaN();
  CameraModel model;
};

// A split's cross-validation and held-out RMS (split_validations below: each half's model on
// the other half's corners, poses re-solved; RMS of both ways); both inf when the
// cross-validation is.
struct SplitValidation {
  double cross_validation_px, heldout_rms_px;
};

// Split validations of one candidate already made on these fits' used views, from the full
// fit the candidate stage holds for it: the board warp's decision (calib/board_warp_choice.h)
// refits the reference model on the selection's own splits. repeat_over_splits takes them
// instead of refitting where its splits are these (the same solves give the same numbers).
struct KnownSplits {
  LensType type = LensType::Pinhole;
  std::vector<std::vector<int>> splits;  // as balanced_view_splits gives them
  std::vector<SplitValidation> values;   // per split
};

// The fits the stages after outlier rejection share: every candidate solved on the used
// views and on each odd/even half (on demand, once), and the area they are compared over.
struct CandidateFits {
  CandidateFits(const CalibrationProblem& problem, ViewSubset used_views);
  ViewSubset used, half[2];      // half[i % 2] holds used[i]
  std::vector<uint8_t> mask;     // coverage_mask of the used views
  int step = 2;                  // auto_step
  CandidateSolver full, halves[2];
  std::optional<KnownSplits> known_splits;
};

// What the candidate stage solves, and how.
struct CandidateOptions {
  // Screening: a candidate whose fit of every used view has a reprojection RMS above this
  // is not fitted on the halves (it is reported with its RMS, not ok, `screened`). It could
  // not be chosen: the incumbent rule takes only candidates within
  // SelectionOptions::fit_max_rms_px (the default here), and the halves of such a model
  // are most of its cost (pinhole, plumb_bob and OpenCV8 on fisheyes and mirrors, Kannala-
  // Brandt on mirrors). Not applied when no candidate is within it (no model fits: the least
  // bad one is still ranked on its halves). Infinity: every candidate's halves.
  double screen_rms_px = 1.5;
  // With at least twice sample_views used views, each candidate is first solved on
  // sample_views of them, evenly spaced (one short solve each, whose cost does not grow with
  // the views), and one whose RMS there is above sample_margin x screen_rms_px is not fitted
  // on every view at all (reported with that RMS, `screened`). A model's misfit of a lens
  // is in every view alike: the sample's RMS was within 0.6-14 % of every view's for the
  // models screened so far (KaidanOmni 16 of 17 views: pinhole 9.10 / 10.58 px, OpenCV8
  // 4.36 / 4.44; 190 deg synthetic, 16 of 64: pinhole 4.77 / 4.75, stereographic 3.70 /
  // 3.65), so the margin of 2 leaves room for a solve that lands worse on fewer views. Not
  // applied when no candidate is within screen_rms_px on the sample; a candidate that
  // cannot be fitted on the sample is still fitted on every view.
  int sample_views = 16;
  double sample_margin = 2.0;
  // A smaller set is screened the same way on its odd half (used[1], used[3], ...) when that
  // half holds at least min_half_sample_views views: those cold fits are the halves' own, so
  // a candidate that is kept costs nothing more, and one that is screened out costs the fit
  // of half the views instead of all of them (MiniOmni, 15 views: the rational model, the
  // spline and Kannala-Brandt, 6-8 px off). 0: only large sets are screened on a sample.
  int min_half_sample_views = 4;
  // On that sample, perspective candidates are not fitted at all where the better wide-angle
  // fit of it (Kannala-Brandt or Mei, within screen_rms_px) sees a corner beyond this many
  // degrees off its axis (kPerspectiveFieldLimitDeg, lens_model.h: they cannot image
  // it); reported `screened` with that field, RMS NaN. Only where Kannala-Brandt and Mei are
  // candidates too (fitted on the sample anyway). Infinity: off.
  double perspective_field_limit_deg = kPerspectiveFieldLimitDeg;
  // Solve the candidates (and their halves) on every core (calib/parallel_jobs.h); the
  // table is the same either way.
  bool parallel = true;
};

// Stage "solve candidates": one table row per candidate, in the order given (full fit,
// halves, odd/even cross-validation, held-out RMS). Progress stage "candidates" (three
// steps: the sample, the full fits, the halves).
std::vector<ModelCandidate> solve_candidates(const CalibrationProblem& problem, CandidateFits& fits,
                                             const std::vector<LensType>& candidates,
                                             const CandidateOptions& options = {},
                                             const StageProgress& progress = {});

enum class SelectionRule {
  Incumbent,            // the simplest unless beaten beyond the splits' noise (see the top)
  SimplestWithinNoise,  // fewest parameters within k x the jackknife noise of the best
};

struct SelectionOptions {
  SelectionRule rule = SelectionRule::Incumbent;
  // Incumbent rule: a challenger must beat the incumbent's held-out RMS on more than half
  // of the splits and on average by more than t(0.975, splits - 1) standard errors of the
  // paired difference (sd over the splits / sqrt(splits)): 3.18 at 4 splits, where a fixed
  // k = 2 on a spread from 4 values would let one lucky set of splits switch the family. Its
  // cross-validation may not exceed the incumbent's by more than the same multiple of its
  // own paired standard error (+ floor_px): a richer model that fits the corners better
  // but is less repeatable is not taken. Needs min_rule_splits splits with every value
  // finite for some eligible candidate, else SimplestWithinNoise decides (4 views have 3
  // distinct balanced splits; 2 or 3 views cannot be split into halves of 2).
  int min_rule_splits = 3;
  // A candidate whose held-out RMS is above outfit_factor × another candidate's on every
  // split, where that other's cross-validation is no worse on at least half of the splits,
  // takes no part (ModelCandidate::outfitted): its misfit is systematic, whatever the
  // splits' spread. The paired t test cannot say so with 3 splits (t = 4.3) or when one
  // split of the better model diverged (a 2-view Kannala-Brandt carried beyond the field it
  // saw: 302 571 px on one split, 0.9-1.2 px on the others), and a stereographic model
  // 1.2-2.2x worse than the best on each split of a half of the shared 190 deg set stood as
  // the pick, 17 px from the other half's choice (docs/calibration.md). Against the best of
  // each split instead of one candidate, the least of six noisy values outfitted plumb_bob on
  // the stereo set's half; without the cross-validation condition, a Mei that fits the
  // 190 deg set's held-out corners 2-3x better but repeats worse outfitted Kannala-Brandt
  // (the two Mei halves 2.2 px apart, Kannala-Brandt's 0.15). < 1 = off.
  double outfit_factor = 1.2;
  // Which family the incumbent comes from: when every used corner is seen within
  // perspective_field_deg of the axis (through the eligible candidate with the lowest
  // held-out RMS), the perspective family (pinhole < plumb_bob < OpenCV8) comes first, else
  // the wide-angle ones (stereographic < Kannala-Brandt < Mei < splined). A parameter count
  // does not rank an 8-parameter Kannala-Brandt against a 9-parameter plumb_bob: on the
  // stereo set (corners within 35 deg) their halves' splits cannot tell them apart, yet
  // Kannala-Brandt's two halves disagree by 0.67 px and plumb_bob's by 0.08 (its angle
  // polynomial is nearly degenerate on a narrow field). 60: a plumb_bob lens of 94 deg
  // across is seen to ~55 deg in its image corners; fisheyes' boards reach beyond.
  double perspective_field_deg = 60;

  // A candidate "fits" when its reprojection RMS is at most fit_max_rms_px and its
  // cross-validation at most fit_max_cross_validation_px; SelectionReport::no_model_fits
  // when none does. Chessboard corners are good to a few tenths of a pixel, so a model that
  // misses them by 1.5 px RMS (or whose two halves disagree by 5 px) is the wrong lens model,
  // not a noisy calibration.
  double fit_max_rms_px = 1.5;
  double fit_max_cross_validation_px = 5.0;
  // The candidate with the fewest parameters among those with
  // cv - cv_best <= k * noise + floor_px, where noise is the jackknife standard error of the
  // best (lowest) cross-validation (one warm refit of a half per view). k = 2: a model whose
  // cross-validation differs from the best's by less than two standard errors of such a
  // measurement cannot be told apart from it by these views. (The standard error of the
  // paired difference was tried first: a wrong model's cross-validation jumps so much when a
  // view is left out that its own spread made a 1.5 px pinhole "within noise" of a 0.1 px
  // rational fit.) The floor only matters for noise-free corners. Candidates with
  // cross-validation above fit_max_cross_validation_px never qualify, nor those whose
  // held-out RMS exceeds the best's by more than k / sqrt(residual components) (relative):
  // it is the precise statistic, and with few views the cross-validation's spread is too wide
  // to reject a stereographic model 1.3 px off on a 190 deg lens (0.31 px for the best). (The
  // full fit's RMS was used before: it falls with every parameter, so a 100-parameter spline
  // as the best disqualified every other model.)
  double k = 2.0;
  double floor_px = 0.005;
  // The cross-validation that ranks the candidates: repeated over cv_splits balanced splits
  // of the views (odd/even, then cv_splits - 1 pseudo-random ones from a fixed seed, none
  // repeated; each half refitted warm from the candidate's full fit), RMS over the splits.
  // One split is one noisy draw (its value for one setup scattered 0.18-0.77 px over four
  // noise draws); the mean of 4 was predicted within 0.69-1.35x by the jackknife on seven
  // real sets (docs/calibration.md). 4: the repeated value the forecasts were checked
  // against, at 3 extra splits' cost. 1 = the odd/even split alone. Each extra split costs
  // two warm refits per candidate that is not screened out: failed, odd/even
  // cross-validation above fit_max_cross_validation_px, or above screen_factor x the best
  // odd/even one (a single split scatters by ~2x, so 10x is hopeless, not noise).
  int cv_splits = 4;
  // A set of at most small_set_views views is split small_set_cv_splits times instead (when
  // cv_splits > 1; a set of 4 views has only 3 distinct splits): its refits are cheap, and its
  // differences are the noisiest, so the rule's t quantile matters most there (t(0.975, 3) =
  // 3.18, t(0.975, 7) = 2.36). Measured on six pairs of halves of each shared set (halves of
  // 4-9 views): VMRImage 1.26 -> 1.00x the best fixed family (a half that kept Kannala-Brandt
  // beside the other's Mei now picks Mei, which fits every split better), no other set's mean
  // moved (docs/calibration.md).
  int small_set_views = 12;
  int small_set_cv_splits = 8;
  double screen_factor = 10.0;
  // Race the richest model of each family (the rational model and the spline, whose split
  // refits cost 5-20x the others') through the repeated splits under the incumbent rule: it
  // is refitted on one split beyond odd/even first, and on the rest only while, on the
  // splits it has, it could still be better than the pick on most of them, or comes before
  // it, or could outfit a candidate. The pick is then the same as with every split of it
  // (ModelCandidate::raced_out); the rows it leaves short show only their first splits.
  bool race_dear_candidates = true;
  // The tolerance's noise: false = the jackknife standard error of the best candidate's
  // odd/even cross-validation, a conservative bound for the K-split mean; true = the spread
  // of the best's K per-split values / sqrt(K). See docs/calibration.md for the measurement
  // that chose.
  bool noise_from_splits = false;
  // false when the model is forced (one candidate): no noise jackknife (cv_noise_px NaN).
  bool measure_noise = true;
  // The repeated splits' and the noise jackknife's refits on every core (the numbers are the
  // same either way).
  bool parallel = true;
};

struct SelectionReport {
  size_t selected = 0;  // index into the table
  // The rule that decided: "incumbent" or "simplest within noise" (asked for, or too few
  // splits for the incumbent rule); and what the simplest-within-noise rule would pick.
  std::string rule;
  size_t simplest_within_noise = 0;
  double field_deg = std::numeric_limits<double>::quiet_NaN();  // see SelectionOptions::perspective_field_deg
  bool perspective_first = false;  // field_deg <= perspective_field_deg: the incumbent's family
  // What ranked the candidates: "repeated" (RMS over cv_splits splits) or "odd/even" (cv_splits
  // = 1, or no candidate survived the screening with every split fitted).
  std::string selected_on;
  int cv_splits = 1;
  std::vector<std::vector<int>> splits;  // the balanced splits of the used views
  // Jackknife standard error of the best candidate's odd/even cross-validation; NaN when not
  // measured or with fewer than 3 refits per half.
  double cv_noise_px = std::numeric_limits<double>::quiet_NaN();
  // Standard error of the best candidate's K-split mean from the spread of its per-split
  // values (sample SD / sqrt(K)); NaN with fewer than 2 splits.
  double cv_split_noise_px = std::numeric_limits<double>::quiet_NaN();
  // The tolerance applied: cv <= cv_best + k * noise_px (+ floor).
  double noise_px = 0, k = 0;
  bool noise_from_splits = false;
  bool no_model_fits = false;  // no candidate fits (see SelectionOptions::fit_max_rms_px)
};

// Stage "cross-validate and select": fills the table's repeated splits and within_noise.
// Progress stages "repeated splits" and "noise jackknife". InputError when no candidate
// could be fitted (the reasons listed).
SelectionReport select_model(const CalibrationProblem& problem, CandidateFits& fits,
                             std::vector<ModelCandidate>& table, const SelectionOptions& options = {},
                             const StageProgress& progress = {});

// The balanced splits the selection's repeated cross-validation uses, of `views` used views
// (in their order) into two halves: side 0/1 per view, odd/even first, then pseudo-random
// ones from a fixed seed, none equal to an earlier one or its complement; at most `splits`.
std::vector<std::vector<int>> balanced_view_splits(int views, int splits);

// Cross-validation of candidate `type` on one split of `used` (sides from
// balanced_view_splits): each half refitted warm from `full` (the candidate's fit on every
// used view), projection difference over `mask`. inf when a half has < 2 views, cannot be
// fitted, or the two half-models share no covered pixel.
double split_cross_validation(const CalibrationProblem& problem, const ViewSubset& used, const std::vector<int>& side,
                              LensType type, const ModelFit& full, const std::vector<uint8_t>& mask, int step);

// split_validations' inputs: candidate `type` of `problem` refitted from `full` (its fit on
// every used view) on the halves `side` gives.
struct SplitTask {
  const CalibrationProblem* problem;
  LensType type;
  const ModelFit* full;
  const std::vector<int>* side;
};

// Each task's cross-validation and held-out RMS (each half's model on the other half's
// corners, poses re-solved; RMS of both ways), its halves refitted as split_cross_validation
// refits them; both inf where that gives inf. Every half is its own job (its refit, its
// held-out RMS and its rays), and the job that finishes a split's second half compares the
// two: whole splits as jobs left a core idle at the end (MiniOmni: 3 splits of the spline on
// 2 cores), and comparisons after every refit left one idle behind the round's longest.
// Jobs start in task order, so put the dearest tasks first. The same numbers on any number
// of threads.
std::vector<SplitValidation> split_validations(const ViewSubset& used, const std::vector<SplitTask>& tasks,
                                               const std::vector<uint8_t>& mask, int step, bool parallel);

// One model (or one setting of it) challenging another over the same balanced splits: the
// incumbent rule's comparison (SelectionOptions::min_rule_splits above). The challenger
// wins when it is better on most splits and on average by more than t(0.975, splits - 1)
// paired standard errors in the held-out RMS or in the cross-validation, and not
// significantly worse in the other.
struct SplitValues {
  std::vector<double> heldout_px, cross_validation_px;  // per split, every value finite
};
struct SplitChallenge {
  double gain_px = std::numeric_limits<double>::quiet_NaN();  // mean of incumbent - challenger, held-out RMS
  double se_px = std::numeric_limits<double>::quiet_NaN();
  double cv_gain_px = std::numeric_limits<double>::quiet_NaN();  // the same for the cross-validation
  double cv_se_px = std::numeric_limits<double>::quiet_NaN();
  int better = 0, cv_better = 0;  // splits where the challenger is lower
  bool wins = false;              // false too with fewer than 2 splits or unequal lengths
};
SplitChallenge challenge_over_splits(const SplitValues& challenger, const SplitValues& incumbent,
                                     const SelectionOptions& options = {});
// `better` outfits `worse` (SelectionOptions::outfit_factor): a held-out RMS lower by more
// than `factor` on every split, and a cross-validation no worse on at least half of them.
bool outfits_over_splits(const SplitValues& better, const SplitValues& worse, double factor);

// The race's test (SelectionOptions::race_dear_candidates): true when `x`, fitted on the
// first m < `splits` splits, cannot change the incumbent rule's pick `table[pick]` (fitted
// on all of them) whatever its other splits give. It comes after the pick in the rule's
// order (family, then parameters), it cannot be better than the pick on most splits in
// either statistic (a challenger must be), and it cannot outfit (on some split it has, it is
// not lower by outfit_factor) the pick or a candidate that beats one up to the pick. Then
// every candidate before the pick stays beaten by one that is not `x`, and nothing beats the
// pick.
bool cannot_change_pick(const ModelCandidate& x, const std::vector<ModelCandidate>& table, size_t pick, size_t splits,
                        bool perspective_first, const SelectionOptions& options = {});

// The incumbent rule on a filled table (cross_validation_splits_px and heldout_splits_px of
// equal length): the index picked, every other candidate's challenge_* (against the pick)
// and every candidate's split_wins filled. `eligible[i]` false: never picked nor compared.
// perspective_first: the perspective family comes first in the order (else the wide-angle
// families).
// Returns table.size() when there are fewer than min_rule_splits splits or no eligible
// candidate has every split finite.
size_t incumbent_pick(std::vector<ModelCandidate>& table, const std::vector<char>& eligible, bool perspective_first,
                      const SelectionOptions& options = {});

// RMS of per-split cross-validations (inf if any is; NaN for none).
double rms_over_splits(const std::vector<double>& values);

}  // namespace lp
