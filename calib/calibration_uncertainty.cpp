#include "calib/calibration_uncertainty.h"

#include <algorithm>
#include <cmath>

#include "calib/parallel_jobs.h"

namespace lp {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<SolvedView> solved(const ViewSubset& s, const ModelFit& f) {
  std::vector<SolvedView> out;
  for (size_t i = 0; i < s.size(); ++i) out.push_back({f.poses[i], s[i]->px, s[i]->inlier});
  return out;
}

}  // namespace

LinearCovariance fit_covariance(const CalibrationProblem& pr, const ModelFit& f, const ViewSubset& views) {
  return linearised_covariance(f.model, pr.board, solved(views, f), pr.solve.board_warp ? &f.warp : nullptr);
}

namespace {

// Linear from each half's own covariance (rotation fitted out), NaN when one is singular.
double predicted_cv_linear(const CalibrationProblem& pr, CandidateFits& fits, LensType type,
                           const std::vector<std::array<double, 2>>& cv_pixels) {
  const ModelFit& a = fits.halves[0].get(type);
  const ModelFit& b = fits.halves[1].get(type);
  if (!a.ok || !b.ok) return kNaN;
  const LinearCovariance ca = fit_covariance(pr, a, fits.half[0]);
  const LinearCovariance cb = fit_covariance(pr, b, fits.half[1]);
  if (!ca.ok || !cb.ok) return kNaN;
  const int n = int(cv_pixels.size());
  const double ra = rms_over(linear_uncertainty_rotation_fitted(ca, a.model, fits.mask, fits.step, cv_pixels, n, 1));
  const double rb = rms_over(linear_uncertainty_rotation_fitted(cb, b.model, fits.mask, fits.step, cv_pixels, n, 1));
  return std::sqrt(ra * ra + rb * rb);
}

// A candidate's own linear uncertainty over the covered area (the issue compares candidates
// by cross-validation and by projection uncertainty side by side), at `coarse` pixels.
void candidate_linear_sigma(const CalibrationProblem& pr, CandidateFits& fits, ModelCandidate& c,
                            const std::vector<std::array<double, 2>>& coarse) {
  if (!c.ok) return;
  const ModelFit& f = fits.full.get(candidate_lens_type(c.name));
  if (!f.ok) return;
  const LinearCovariance cc = fit_covariance(pr, f, fits.used);
  if (!cc.ok) return;
  const double s =
      rms_over(linear_uncertainty_rotation_fitted(cc, f.model, fits.mask, fits.step, coarse, int(coarse.size()), 1));
  c.linear_sigma_px = s;
  c.linear_forecast_cv_px = 2 * s;
}

}  // namespace

UncertaintyReport calibration_uncertainty(const CalibrationProblem& pr, CandidateFits& fits,
                                          std::vector<ModelCandidate>& table, size_t pick,
                                          const SelectionReport& selection,
                                          const std::vector<CameraModel>& leave_one_out, const UncertaintyOptions& o,
                                          const StageProgress& progress) {
  UncertaintyReport u;
  const ModelCandidate& chosen_row = table[pick];
  const LensType type = candidate_lens_type(chosen_row.name);
  const ModelFit& chosen = fits.full.get(type);
  const int gx = std::max(1, o.nx), gy = std::max(1, o.ny);
  const auto grid = grid_pixels(chosen.model, gx, gy);
  const auto cv_pixels = mask_pixels(fits.mask, pr.width, pr.height, fits.step);
  // Independent jobs on every core: the jackknife (its models compared on every core too),
  // the chosen fit's linear uncertainty, the halves' linear forecast, and every candidate's
  // linear sigma over the covered area, sampled more coarsely than the cross-validation (a
  // summary, not a map). Each job writes its own results: the same as one after the other.
  report_progress(progress, "uncertainty", 0, 1);
  std::vector<std::array<double, 2>> coarse;
  const size_t stride = std::max<size_t>(1, cv_pixels.size() / size_t(std::max(1, o.candidate_samples)));
  for (size_t k = 0; k < cv_pixels.size(); k += stride) coarse.push_back(cv_pixels[k]);
  u.predicted_cv_jackknife_px = kNaN;
  double predicted_cv_linear_px = kNaN;
  run_jobs(3 + table.size(), [&](size_t j) {
    if (j == 0) {
      if (leave_one_out.size() < 3) return;
      UncertaintyGrid at_covered;
      u.jackknife =
          jackknife_uncertainty(chosen.model, leave_one_out, cv_pixels, grid, gx, gy, &at_covered, o.parallel);
      u.predicted_cv_jackknife_px = 2 * rms_over(at_covered);
    } else if (j == 1) {
      // Linear: the full fit over the image.
      const LinearCovariance cov = fit_covariance(pr, chosen, fits.used);
      u.linear_ok = cov.ok;
      u.linear_error = cov.error;
      u.sigma_px = cov.sigma_px;
      u.mean_frames = linear_uncertainty_mean_frames(cov, chosen.model, solved(fits.used, chosen), grid, gx, gy);
      u.rotation_fitted = linear_uncertainty_rotation_fitted(cov, chosen.model, fits.mask, fits.step, grid, gx, gy);
    } else if (j == 2) {
      // Each half's own, for the cross-validation forecast (kept only where the full fit's is).
      predicted_cv_linear_px = predicted_cv_linear(pr, fits, type, cv_pixels);
    } else {
      candidate_linear_sigma(pr, fits, table[j - 3], coarse);
    }
  }, o.parallel ? 0 : 1);
  u.predicted_cv_linear_px = u.linear_ok ? predicted_cv_linear_px : kNaN;
  u.headline = leave_one_out.size() >= 3 ? "jackknife" : "linear";
  // The cross-validation repeated over balanced splits (the selection's, when it ranked on
  // them; else over o.repeated_splits: odd/even and pseudo-random ones).
  std::vector<double> v = chosen_row.cross_validation_splits_px;
  if (v.size() < 2) {
    const auto sp = selection.splits.size() > 1 ? selection.splits
                                                : balanced_view_splits(int(fits.used.size()), o.repeated_splits);
    v = {chosen_row.cross_validation_px};
    for (size_t k = 1; k < sp.size(); ++k)
      v.push_back(split_cross_validation(pr, fits.used, sp[k], type, chosen, fits.mask, fits.step));
  }
  std::vector<double> finite;
  for (double x : v)
    if (std::isfinite(x)) finite.push_back(x);
  u.cv_splits = int(finite.size());
  u.cv_repeated_px = finite.empty() ? kNaN : rms_over_splits(finite);
  return u;
}

}  // namespace lp
