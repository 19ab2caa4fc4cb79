#include "calib/geometric.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "calib/calibration_seed.h"
#include "calib/calibration_solve.h"
#include "core/error.h"

namespace lp {
namespace {

CalibrationProblem problem_of(const BoardSpec& board, int width, int height, const CalibrateOptions& o) {
  CalibrationProblem pr;
  pr.board = board;
  pr.width = width;
  pr.height = height;
  pr.solve.use_mrcal = o.use_mrcal;
  pr.solve.spline_order = o.spline_order;
  pr.solve.spline_nx = o.spline_nx;
  pr.solve.spline_ny = o.spline_ny;
  pr.solve.board_warp = o.board_warp;
  pr.diff_step_px = o.diff_step_px;
  return pr;
}

// The requested model, else the candidates (all of them when none are named), as types.
std::vector<LensType> candidate_types(const CalibrateOptions& o) {
  const std::vector<std::string>& names =
      !o.model.empty() ? std::vector<std::string>{o.model} : (o.candidates.empty() ? all_candidate_names() : o.candidates);
  std::vector<LensType> types;
  for (const std::string& n : names) {
    try {
      types.push_back(candidate_lens_type(n));
    } catch (const InputError& e) {
      throw InputError(std::string("calibrate: ") + e.what());
    }
  }
  return types;
}

OutlierOptions outlier_options(const CalibrateOptions& o) {
  OutlierOptions out;
  out.k = o.outlier_k;
  out.floor_px = o.outlier_floor_px;
  out.rounds = o.outlier_rounds;
  out.reference_views = o.reference_views;
  out.max_view_outlier_fraction = o.max_view_outlier_fraction;
  out.perspective_field_limit_deg = o.perspective_field_limit_deg;
  out.perspective_fit_rms_px = o.fit_max_rms_px;
  out.parallel = o.parallel;
  if (!o.model.empty()) out.model = candidate_lens_type(o.model);
  return out;
}

SelectionOptions selection_options(const CalibrateOptions& o) {
  SelectionOptions out;
  out.fit_max_rms_px = o.fit_max_rms_px;
  out.fit_max_cross_validation_px = o.fit_max_cross_validation_px;
  out.k = o.selection_k;
  out.floor_px = o.selection_floor_px;
  out.cv_splits = o.cv_splits;
  out.screen_factor = o.selection_screen_factor;
  out.noise_from_splits = o.selection_noise_from_splits;
  out.rule = o.selection_rule;
  out.min_rule_splits = o.selection_min_rule_splits;
  out.perspective_field_deg = o.selection_perspective_field_deg;
  out.outfit_factor = o.selection_outfit_factor;
  out.small_set_views = o.selection_small_set_views;
  out.small_set_cv_splits = o.selection_small_set_cv_splits;
  out.race_dear_candidates = o.selection_race_dear_candidates;
  out.measure_noise = o.model.empty();
  out.parallel = o.parallel;
  return out;
}

// The views as given: which have a board, how many corners, why unused.
std::vector<ViewReport> initial_view_reports(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view) {
  std::vector<ViewReport> views(corners_per_view.size());
  for (size_t i = 0; i < corners_per_view.size(); ++i) {
    views[i].has_board = !corners_per_view[i].empty();
    views[i].corners = int(corners_per_view[i].size());
    views[i].why = views[i].has_board ? "" : "no board";
  }
  return views;
}

void take_selection(CalibrationResult& res, const SelectionReport& sel, const ModelCandidate& pick) {
  res.selected = pick.name;
  res.selection_rule = sel.rule;
  res.simplest_within_noise = res.table[sel.simplest_within_noise].name;
  res.selection_field_deg = sel.field_deg;
  res.selection_perspective_first = sel.perspective_first;
  res.no_model_fits = sel.no_model_fits;
  res.selected_on = sel.selected_on;
  res.cv_splits = sel.cv_splits;
  res.cv_noise_px = sel.cv_noise_px;
  res.cv_split_noise_px = sel.cv_split_noise_px;
  res.selection_noise_px = sel.noise_px;
  res.selection_k = sel.k;
  res.selection_noise_from_splits = sel.noise_from_splits;
  res.model = pick.model;
  res.cross_validation_px = pick.cross_validation_px;
  res.cross_validation_repeated_px = pick.cross_validation_repeated_px;
  res.cross_validation_median_px = pick.cross_validation_median_px;
  res.heldout_rms_px = pick.heldout_rms_px;
}

BoardWarpReport board_warp_report(const CalibrationProblem& pr, const ModelFit& chosen, const ViewSubset& used) {
  BoardWarpReport w;
  w.fitted = chosen.warp_fitted;
  if (!w.fitted) return w;
  w.mm = chosen.warp;
  const LinearCovariance cov = fit_covariance(pr, chosen, used);
  if (!cov.ok) {
    w.sd_error = cov.error;
    return w;
  }
  w.sd_mm = {std::sqrt(cov.warp_covariance[0]), std::sqrt(cov.warp_covariance[3])};
  return w;
}

// The held-out RMS a candidate is ranked on: the mean over its first `n` splits (every one it
// has when n = 0 or more), else the odd/even one; inf when some split could not be posed.
double mean_heldout_px(const ModelCandidate& c, size_t n = 0) {
  if (c.heldout_splits_px.empty()) return c.heldout_rms_px;
  if (n == 0 || n > c.heldout_splits_px.size()) n = c.heldout_splits_px.size();
  double sum = 0;
  for (size_t k = 0; k < n; ++k) sum += c.heldout_splits_px[k];
  return sum / double(n);
}

// CalibrationResult::mrcal_stand_in: only candidates whose full fit exists (ok) are looked at,
// so nothing is solved again.
std::optional<CalibrationResult::MrcalStandIn> mrcal_stand_in(CandidateFits& fits,
                                                              const std::vector<ModelCandidate>& table,
                                                              const CameraModel& chosen, const CalibrateOptions& o) {
  if (is_mrcal_model(chosen.lensmodel)) return std::nullopt;
  const ModelCandidate* best = nullptr;
  auto fits_well = [&](const ModelCandidate& c) {
    return c.rms_px <= o.fit_max_rms_px && c.cross_validation_px <= o.fit_max_cross_validation_px;
  };
  auto better = [&](const ModelCandidate& a, const ModelCandidate& b) {  // a ranks before b
    if (fits_well(a) != fits_well(b)) return fits_well(a);
    // On the splits both have: a raced-out row (ModelCandidate::raced_out) has only the first.
    const size_t n = std::min(a.heldout_splits_px.size(), b.heldout_splits_px.size());
    const double ha = fits_well(a) ? mean_heldout_px(a, n) : a.rms_px, hb = fits_well(b) ? mean_heldout_px(b, n) : b.rms_px;
    if (!(ha == hb)) return ha < hb || std::isnan(hb);
    return a.params < b.params;
  };
  for (const ModelCandidate& c : table)
    if (c.ok && is_mrcal_model(c.model.lensmodel) && (!best || better(c, *best))) best = &c;
  if (!best) return std::nullopt;
  CalibrationResult::MrcalStandIn s;
  s.name = best->name;
  s.model = best->model;
  s.model.rms_reprojection_px = best->rms_px;
  s.model.cross_validation_px = best->cross_validation_px;
  s.solve = record_solve(fits.used, fits.full.get(candidate_lens_type(best->name)));
  s.rms_px = best->rms_px;
  s.heldout_rms_px = mean_heldout_px(*best);
  s.fits_poorly = !fits_well(*best);
  s.median_from_chosen_px = projection_difference(chosen, best->model, fits.mask, fits.step).median_px;
  s.same_ray_from_chosen_px = projection_difference(chosen, best->model, fits.mask, fits.step, false).median_px;
  return s;
}

void take_diagnostics(CalibrationResult& res, ViewDiagnostics d) {
  res.view_rms_px = std::move(d.view_rms_px);
  res.residuals = std::move(d.residuals);
  res.coverage_nx = d.coverage_nx;
  res.coverage_ny = d.coverage_ny;
  res.coverage = std::move(d.coverage);
  res.edge_observations = d.edge_observations;
  res.corners_poorly_covered = d.corners_poorly_covered;
  res.corners_total = d.corners_total;
  res.corners_rejected = d.corners_rejected;
}

}  // namespace

double pixel_limit_scale(int width, int height) {
  return std::max(1.0, std::max(width, height) / kPixelLimitsLongSidePx);
}

CalibrationResult calibrate(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                            const BoardSpec& board, int width, int height, const CalibrateOptions& given) {
  CalibrateOptions options = given;
  options.fit_max_rms_px *= pixel_limit_scale(width, height);
  options.fit_max_cross_validation_px *= pixel_limit_scale(width, height);
  if (board.cols < 2 || board.rows < 2)
    throw InputError("calibrate: board needs at least 2 inner corners per side (got " + std::to_string(board.cols) +
                     "x" + std::to_string(board.rows) + ")");
  if (!(board.square_mm > 0) || !std::isfinite(board.square_mm))
    throw InputError("calibrate: board square size must be positive and finite");
  if (width <= 0 || height <= 0) throw InputError("calibrate: image size must be positive");
  const std::vector<LensType> candidates = candidate_types(options);
  CalibrationProblem pr = problem_of(board, width, height, options);
  std::vector<BoardView> views = make_board_views(corners_per_view, pr, "calibrate", true);
  CalibrationResult res;
  res.views = initial_view_reports(corners_per_view);

  // Outliers, with one reference model.
  const OutlierReport outliers = reject_outliers(pr, views, outlier_options(options), options.progress);
  pr.solve.mei_from_kannala_brandt = outliers.mei_from_kannala_brandt;  // every Mei fit seeded alike
  res.outlier_rounds = outliers.rounds;
  res.outlier_reference = lens_type_name(outliers.reference);
  for (size_t i = 0; i < views.size(); ++i)
    if (!outliers.why[i].empty()) res.views[size_t(views[i].index)].why = outliers.why[i];

  // Candidates on the views left and their halves; the selection.
  CandidateFits fits(pr, used_views(views, outliers.view_used));
  std::optional<ModelFit> reference = reference_fit(pr, outliers, fits.used);
  if (pr.solve.board_warp && options.board_warp_auto) {
    // Does the board's flex repay its parameters here? Decided on the reference model, before
    // any candidate is solved (the fits hold `pr` by reference and solve with its setting).
    const ModelFit warped = reference ? *reference : CandidateSolver(pr, fits.used).get(outliers.reference);
    BoardWarpChoiceOptions wo;
    wo.splits = options.board_warp_splits;
    wo.selection = selection_options(options);
    wo.parallel = options.parallel;
    ModelFit flat;
    res.board_warp_choice =
        choose_board_warp(pr, fits.used, outliers.reference, warped, fits.mask, fits.step, wo, options.progress, &flat);
    if (!res.board_warp_choice.keep) {
      pr.solve.board_warp = false;
      reference.reset();
      if (flat.ok) {
        reference = flat;
        reference->solver = warped.solver + ", re-solved flat";  // what --json's table[].solver says
      }
    } else if (!reference && warped.ok) {
      reference = warped;
    }
  }
  if (reference) fits.full.adopt(outliers.reference, *reference);
  // The decision refitted the reference on the selection's splits from the fit just adopted:
  // the winning side's values are the selection's (the same solves), not refitted there.
  if (const BoardWarpChoice& c = res.board_warp_choice; c.decided && reference) {
    const SplitValues& won = c.keep ? c.warp : c.flat;
    KnownSplits ks{outliers.reference, c.splits, {}};
    for (size_t k = 0; k < won.heldout_px.size(); ++k)
      ks.values.push_back({won.cross_validation_px[k], won.heldout_px[k]});
    fits.known_splits = std::move(ks);
  }
  for (auto& [type, f] : fits_from_sample(pr, outliers, fits.used, options.fit_max_rms_px, options.parallel))
    if (!fits.full.solved(type)) fits.full.adopt(type, std::move(f));
  CandidateOptions co;
  co.screen_rms_px = options.model.empty() ? options.fit_max_rms_px : std::numeric_limits<double>::infinity();
  co.perspective_field_limit_deg = options.perspective_field_limit_deg;
  co.parallel = options.parallel;
  res.table = solve_candidates(pr, fits, candidates, co, options.progress);
  const SelectionReport sel = select_model(pr, fits, res.table, selection_options(options), options.progress);
  take_selection(res, sel, res.table[sel.selected]);
  const LensType pick = candidate_lens_type(res.selected);
  const ModelFit& chosen = fits.full.get(pick);
  res.solve = record_solve(fits.used, chosen);
  res.board_warp = board_warp_report(pr, chosen, fits.used);

  // How the chosen model fits each view; what each view weighs.
  take_diagnostics(res, diagnose_views(pr, views, outliers.view_used, chosen, res.views,
                                       {options.coverage_nx, options.coverage_ny, options.edge_band,
                                        options.min_edge_observations}));
  std::vector<CameraModel> leave_one_out;
  if (options.leverage)
    leave_one_out = view_leverage(pr, views, outliers.view_used, pick, chosen, fits.mask, fits.step, res.views,
                                  {options.leverage_flag_factor, options.leverage_min_px, options.parallel},
                                  options.progress);
  res.model.rms_reprojection_px = res.table[sel.selected].rms_px;
  res.model.cross_validation_px = res.table[sel.selected].cross_validation_px;
  res.mrcal_stand_in = mrcal_stand_in(fits, res.table, res.model, options);

  if (options.uncertainty) {
    UncertaintyOptions uo;
    uo.nx = options.uncertainty_nx;
    uo.ny = options.uncertainty_ny;
    uo.parallel = options.parallel;
    res.uncertainty =
        calibration_uncertainty(pr, fits, res.table, sel.selected, sel, leave_one_out, uo, options.progress);
  }
  report_progress(options.progress, "done", 1, 1);
  return res;
}

SingleSolve solve_model_once(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                             const BoardSpec& board, int width, int height, const std::string& model,
                             const CalibrateOptions& options) {
  LensType type;
  try {
    type = candidate_lens_type(model);
  } catch (const InputError& e) {
    throw InputError(std::string("solve_model_once: ") + e.what());
  }
  const CalibrationProblem pr = problem_of(board, width, height, options);
  const std::vector<BoardView> views = make_board_views(corners_per_view, pr, "solve_model_once", false);
  const ViewSubset all = all_of(views);
  SingleSolve out;
  const auto t0 = std::chrono::steady_clock::now();
  CandidateSolver solver(pr, all);
  const ModelFit& f = solver.get(type);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.ok = f.ok;
  out.error = f.error;
  if (!f.ok) return out;
  out.model = f.model;
  out.rms_px = fit_rms(pr, f, all);
  return out;
}

namespace {

// One OpenCV calibrator alone; `posed` marks the views it gave a pose.
ModelFit opencv_alone(const CalibrationProblem& pr, const std::string& name, const ViewSubset& s,
                      std::vector<char>& posed) {
  posed.assign(s.size(), 1);
  if (name == "cv::fisheye") return opencv_fisheye(pr, s, [](const std::array<double, 2>&) { return true; }, &posed);
  if (name == "cv::omnidir") return opencv_omnidir(pr, s, &posed);
  // OpenCV's defaults, as a user runs it: its steps by SVD, not the seeds' LU.
  if (name == "cv::calibrateCamera plumb_bob") return opencv_calibrate_camera(pr, s, LensType::OpenCV5, false);
  return opencv_calibrate_camera(pr, s, LensType::OpenCV8, false);
}

}  // namespace

std::vector<PeerCalibration> calibrate_opencv_alone(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                                                    const BoardSpec& board, int width, int height, int diff_step_px) {
  CalibrateOptions o;
  o.diff_step_px = diff_step_px;
  const CalibrationProblem pr = problem_of(board, width, height, o);
  const std::vector<BoardView> views = make_board_views(corners_per_view, pr, "calibrate_opencv_alone", false);
  ViewSubset all, half[2];
  for (size_t i = 0; i < views.size(); ++i) {
    all.push_back(&views[i]);
    half[i % 2].push_back(&views[i]);
  }
  const std::vector<uint8_t> mask = coverage_mask(pr, all);
  const int step = auto_step(pr);
  std::vector<PeerCalibration> out;
  for (const std::string name :
       {"cv::fisheye", "cv::calibrateCamera plumb_bob", "cv::calibrateCamera rational", "cv::omnidir"}) {
    PeerCalibration p;
    p.name = name;
    std::vector<char> posed;
    const auto t0 = std::chrono::steady_clock::now();
    const ModelFit f = opencv_alone(pr, name, all, posed);
    p.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!f.ok) {
      p.error = f.error;
      out.push_back(p);
      continue;
    }
    p.lensmodel = f.model.lensmodel;
    p.model = f.model;
    ViewSubset posed_views;
    ModelFit fp = f;
    fp.poses.clear();
    for (size_t i = 0; i < all.size(); ++i)
      if (posed[i]) {
        posed_views.push_back(all[i]);
        fp.poses.push_back(f.poses[i]);
      }
    p.views_posed = int(posed_views.size());
    p.rms_px = fit_rms(pr, fp, posed_views);
    std::vector<char> pa, pb;
    const ModelFit a = opencv_alone(pr, name, half[0], pa), b = opencv_alone(pr, name, half[1], pb);
    if (!a.ok || !b.ok) {
      p.error = "a half of the views could not be fitted: " + (a.ok ? b.error : a.error);
      p.cross_validation_px = std::numeric_limits<double>::infinity();
      out.push_back(p);
      continue;
    }
    const ProjectionDiff d = projection_difference(a.model, b.model, mask, step);
    p.cross_validation_px = d.samples > 0 ? d.rms_px : std::numeric_limits<double>::infinity();
    p.ok = std::isfinite(p.rms_px) && p.rms_px < 1e5 && std::isfinite(p.cross_validation_px);
    if (!p.ok && p.error.empty()) p.error = "cannot image some corners or no covered pixel";
    out.push_back(p);
  }
  return out;
}

}  // namespace lp
