#include "calib/board_warp_choice.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace lp {

BoardWarpChoice choose_board_warp(const CalibrationProblem& problem, const ViewSubset& used, LensType type,
                                  const ModelFit& warped, const std::vector<uint8_t>& mask, int step,
                                  const BoardWarpChoiceOptions& o, const StageProgress& progress,
                                  ModelFit* flat_fit) {
  BoardWarpChoice c;
  c.model = candidate_name(type);
  if (!warped.ok || !warped.warp_fitted) {
    c.why = "the warp kept untested: no fit with it to compare";
    return c;
  }
  if (int(used.size()) < o.min_views) {
    c.why = "the warp kept untested: " + std::to_string(used.size()) + " views, fewer than the " +
            std::to_string(o.min_views) + " it takes to judge it";
    return c;
  }
  report_progress(progress, "board warp", 0, 1);
  CalibrationProblem flat_problem = problem;
  flat_problem.solve.board_warp = false;
  ModelFit seed = warped;
  seed.warp = {0, 0};
  const ModelFit flat = warm_refit(flat_problem, used, type, seed, warped.poses);
  if (flat_fit) *flat_fit = flat;
  // A small set gets the selection's small-set splits: its refits are cheap and its
  // differences the noisiest (SelectionOptions::small_set_views).
  const int n_splits = o.splits > 1 && int(used.size()) <= o.selection.small_set_views
                           ? std::max(o.splits, o.selection.small_set_cv_splits)
                           : o.splits;
  const std::vector<std::vector<int>> splits = balanced_view_splits(int(used.size()), n_splits);
  if (!flat.ok || splits.size() < 2) {
    c.why = !flat.ok ? "the warp kept untested: the flat board could not be fitted (" + flat.error + ")"
                     : "the warp kept untested: too few views to split (" + std::to_string(used.size()) + ")";
    return c;
  }
  // Every (setting, split) on every core, each into its own slot.
  std::vector<SplitTask> tasks;
  for (size_t j = 0; j < 2 * splits.size(); ++j) {
    const bool with_warp = j < splits.size();
    tasks.push_back({with_warp ? &problem : &flat_problem, type, with_warp ? &warped : &flat, &splits[j % splits.size()]});
  }
  const std::vector<SplitValidation> values = split_validations(used, tasks, mask, step, o.parallel);
  for (size_t j = 0; j < values.size(); ++j) {
    if (!std::isfinite(values[j].cross_validation_px) || !std::isfinite(values[j].heldout_rms_px)) {
      c.why = "the warp kept untested: a split could not be fitted " +
              std::string(j < splits.size() ? "with" : "without") + " it";
      report_progress(progress, "board warp", 1, 1);
      return c;
    }
    SplitValues& v = j < splits.size() ? c.warp : c.flat;
    v.heldout_px.push_back(values[j].heldout_rms_px);
    v.cross_validation_px.push_back(values[j].cross_validation_px);
  }
  c.splits = splits;
  c.challenge = challenge_over_splits(c.warp, c.flat, o.selection);
  c.outfits = o.selection.outfit_factor >= 1 && outfits_over_splits(c.warp, c.flat, o.selection.outfit_factor);
  c.decided = true;
  c.keep = c.challenge.wins || c.outfits;
  char b[400];
  std::snprintf(b, sizeof b,
                "%s over %zu splits: with it the held-out RMS is %+.4f +- %.4f px lower (on %d of %zu), the "
                "cross-validation %+.4f +- %.4f px lower (on %d of %zu)",
                c.keep ? (c.challenge.wins ? "the warp repays its parameters"
                                           : "the warp repays its parameters (it outfits the flat board)")
                       : "the warp does not repay its parameters",
                splits.size(), c.challenge.gain_px, c.challenge.se_px, c.challenge.better, splits.size(),
                c.challenge.cv_gain_px, c.challenge.cv_se_px, c.challenge.cv_better, splits.size());
  c.why = b;
  report_progress(progress, "board warp", 1, 1);
  return c;
}

}  // namespace lp
