#include "calib/calibration_run.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>

#include "calib/calibration_report.h"
#include "calib/lens_model.h"
#include "calib/parallel_jobs.h"
#include "core/error.h"

namespace lp {
namespace {

namespace fs = std::filesystem;

// Two views whose corners are closer than this (px RMS, at 2048 px of long side or less;
// pixel_limit_scale beyond) are one pose: detection's noise is 0.02-0.1 px, and a board moved
// by hand moves its corners by pixels.
constexpr double kRepeatedViewRmsPx = 0.3;

struct RepeatedView {
  size_t view = 0, same_as = 0;  // image indices: `view` repeats the earlier `same_as`
  double rms_px = 0;             // their corners' RMS distance
};

// RMS distance between two views' corners, the second read in its own order or back to
// front (a board turned half a turn is labelled from its other end), over the corners both
// have (corners.vnl marks a missing one '-': NaN); inf for other counts or fewer than 4 pairs.
double corner_rms_px(const std::vector<std::array<double, 2>>& a, const std::vector<std::array<double, 2>>& b) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (a.empty() || a.size() != b.size()) return kInf;
  const size_t n = a.size();
  const auto rms = [&](bool back) {
    double sum = 0;
    size_t pairs = 0;
    for (size_t k = 0; k < n; ++k) {
      const auto& p = a[k];
      const auto& q = b[back ? n - 1 - k : k];
      const double d = std::pow(p[0] - q[0], 2) + std::pow(p[1] - q[1], 2);
      if (std::isfinite(d)) sum += d, ++pairs;
    }
    return pairs >= 4 ? std::sqrt(sum / double(pairs)) : kInf;
  };
  return std::min(rms(false), rms(true));
}

// Each view with a board that lies within limit_px of an earlier kept one, with the nearest.
std::vector<RepeatedView> repeated_views(const std::vector<std::vector<std::array<double, 2>>>& corners,
                                         double limit_px) {
  std::vector<RepeatedView> out;
  std::vector<size_t> kept;
  for (size_t i = 0; i < corners.size(); ++i) {
    if (corners[i].empty()) continue;
    RepeatedView nearest{i, i, std::numeric_limits<double>::infinity()};
    for (size_t j : kept)
      if (const double r = corner_rms_px(corners[j], corners[i]); r < nearest.rms_px) nearest = {i, j, r};
    if (nearest.rms_px <= limit_px)
      out.push_back(nearest);
    else
      kept.push_back(i);
  }
  return out;
}

// "b.png = a.png (0.00 px), ..." for the first three, then how many more.
std::string repeats_text(const std::vector<RepeatedView>& repeats, const std::vector<std::string>& images) {
  std::string s;
  for (size_t k = 0; k < repeats.size() && k < 3; ++k)
    s += fmt::format("{}{} = {} ({:.2f} px)", k ? ", " : "", images[repeats[k].view], images[repeats[k].same_as],
                     repeats[k].rms_px);
  if (repeats.size() > 3) s += fmt::format(" and {} more", repeats.size() - 3);
  return s;
}

// A fit of every view has more data and the same parameters as each half's, so its RMS
// is below the held-out RMS (each half's model on the other half's corners, poses
// re-solved) unless the solve of all views stopped in a worse minimum than the halves'
// (a board left in its flipped pose did: 0.124 px against 0.034 held out, docs/calibration.md
// "A view left in its flipped pose"). 1.5x: on the eight shared sets the ratio is 0.87-0.99.
bool fit_worse_than_heldout(const CalibrationResult& r) {
  return r.heldout_rms_px > 0 && r.model.rms_reprojection_px > 1.5 * r.heldout_rms_px;
}

std::string with_extension(const std::string& path, const std::string& ext) {
  return (fs::path(path).parent_path() / (fs::path(path).stem().string() + ext)).string();
}

bool has_uncertainty(const CalibrationResult& r) {
  const UncertaintyGrid& g = r.uncertainty.headline_grid();
  return g.nx > 0 && std::isfinite(g.median_px);
}

// The flagged views to leave out, worst first, as many as may go.
std::vector<DroppedView> views_to_drop(const CalibrationResult& r, int drop_influential) {
  std::vector<DroppedView> flagged;
  for (size_t v = 0; v < r.views.size(); ++v)
    if (r.views[v].influential) flagged.push_back({v, r.views[v].leverage_px});
  std::sort(flagged.begin(), flagged.end(), [](const DroppedView& a, const DroppedView& b) {
    return a.leverage_px > b.leverage_px || (a.leverage_px == b.leverage_px && a.view < b.view);
  });
  int used = 0;
  for (const auto& v : r.views) used += v.used;
  const int can_drop = std::max(0, std::min<int>(drop_influential, used - 5));
  if (int(flagged.size()) > can_drop) flagged.resize(size_t(can_drop));
  return flagged;
}

// ---- summary ---------------------------------------------------------------------------

std::string table_text(const CalibrationResult& r) {
  std::string s;
  const bool repeated = r.selected_on == "repeated";
  const std::string splits_col = fmt::format("{} splits", r.cv_splits);
  const bool incumbent = r.selection_rule == "incumbent";
  s += fmt::format("{:<44} {:>6} {:>9} {:>10} {:>10} {:>10} {:>10} {:>6}\n", "model", "params", "RMS px", "held-out",
                   "cv odd/even", repeated ? splits_col : "", "lin. sigma", incumbent ? "wins" : "");
  for (const ModelCandidate& c : r.table)
    if (c.ok)
      s += fmt::format("{:<44} {:>6} {:>9.3f} {:>10.3f} {:>10.3f} {:>10} {:>10} {:>6}{}\n", c.name, c.params, c.rms_px,
                       c.heldout_rms_px, c.cross_validation_px,
                       !repeated ? ""
                                 : (c.raced_out ? fmt::format("{} of {}", c.cross_validation_splits_px.size(), r.cv_splits)
                                    : std::isnan(c.cross_validation_repeated_px)
                                        ? "screened"
                                        : fmt::format("{:.3f}", c.cross_validation_repeated_px)),
                       std::isfinite(c.linear_sigma_px) ? fmt::format("{:.3f}", c.linear_sigma_px) : "-",
                       incumbent && !c.raced_out ? fmt::format("{}/{}", c.split_wins, r.cv_splits) : "",
                       c.name == r.selected ? "   <- chosen"
                       : c.raced_out        ? "   (raced out: cannot change the pick)"
                                            : (c.outfitted ? "   (outfitted)" : (c.within_noise ? "   (within noise)" : "")));
    else if (c.screened)
      s += fmt::format("{:<44} {:>6} {:>9} {}\n", c.name, c.params,
                       std::isnan(c.rms_px) ? "-" : fmt::format("{:.3f}", c.rms_px), c.error);
    else
      s += fmt::format("{:<44} failed: {}\n", c.name, c.error);
  // A forced model: one candidate, no selection. (Not "no noise estimate": with 4 views the
  // halves of 2 have no jackknife, yet the model was chosen.)
  if (r.table.size() == 1)
    s += fmt::format("model {} as requested; {} of {} corners rejected as outliers\n", r.selected, r.corners_rejected,
                     r.corners_total);
  else if (incumbent)
    s += fmt::format(
        "chosen: {}, the simplest model, the {} family first, that no later one beats beyond the noise of the {} "
        "splits (corners seen to {:.0f} deg; to beat, a held-out RMS or cross-validation better on most splits "
        "and on average by more than t x the standard error of the difference; wins: splits on which a model had "
        "the lowest held-out RMS); the fewest parameters within the noise of the best would be {}; {} of {} "
        "corners rejected as outliers\n",
        r.selected, r.selection_perspective_first ? "perspective" : "wide-angle",
        r.cv_splits, r.selection_field_deg, r.simplest_within_noise, r.corners_rejected, r.corners_total);
  else
    s += fmt::format(
        "chosen: {}, the fewest parameters within the noise of the best (cross-validation {} within {} x {:.3f} "
        "px, {}; held-out RMS within {} / sqrt(residuals)); {} of {} corners rejected as outliers\n",
        r.selected, repeated ? "over " + splits_col : "odd/even", r.selection_k, r.selection_noise_px,
        r.selection_noise_from_splits ? "the spread of the per-split values / sqrt(splits)"
                                      : "the jackknife standard error of the odd/even one",
        r.selection_k, r.corners_rejected, r.corners_total);
  return s;
}

// One line: the fitted board warp with its standard deviation, or that the board was taken as flat.
std::string board_warp_text(const BoardWarpReport& w, const BoardWarpChoice& choice) {
  if (choice.decided && !choice.keep) return "board taken as flat: " + choice.why + "\n";
  if (!w.fitted) return "board taken as flat (no board warp fitted)\n";
  const std::string sd = std::isfinite(w.sd_mm[0]) ? fmt::format(" (+- {:.3f}, +- {:.3f})", w.sd_mm[0], w.sd_mm[1])
                                                   : fmt::format(" (no uncertainty: {})", w.sd_error);
  return fmt::format("board warp (peak deflection along x, y): {:.3f}, {:.3f} mm{}\n", w.mm[0], w.mm[1], sd);
}

std::string views_text(const GeometricCalibration& run) {
  const CalibrationResult& r = run.result;
  const std::vector<std::string>& images = run.detections.images;
  std::string s;
  for (const DroppedView& d : run.dropped)
    s += fmt::format("dropped influential view: {} ({:.2f} px)\n", images[d.view], d.leverage_px);
  // Views the solve left out (too many outlier corners): named here, not only in --json.
  for (size_t v = 0; v < r.views.size() && v < images.size(); ++v)
    if (!r.views[v].used && !run.corners[v].empty() && r.views[v].why.rfind("dropped: influential", 0) != 0)
      s += fmt::format("view left out: {} ({})\n", images[v], r.views[v].why.empty() ? "not used" : r.views[v].why);
  if (run.before_dropping) {
    const auto& b = *run.before_dropping;
    s += fmt::format("with all views: {} (cross-validation {:.3f} px, RMS {:.3f} px); without the {} most influential: "
                     "{} (cross-validation {:.3f} px, RMS {:.3f} px){}\n",
                     b.selected, b.cross_validation_px, b.rms_px, run.dropped.size(), r.selected,
                     r.cross_validation_px, r.model.rms_reprojection_px,
                     r.cross_validation_px > b.cross_validation_px
                         ? "; the halves agree less without them: consider keeping all views"
                         : "");
  }
  int influential = 0;
  for (size_t v = 0; v < r.views.size(); ++v)
    if (r.views[v].influential) {
      s += fmt::format("influential view: {} (leaving it out moves the projection by {:.2f} px)\n", images[v],
                       r.views[v].leverage_px);
      ++influential;
    }
  if (influential > 0 && run.drop_influential == 0)
    s += "to solve again without the worst of them and compare: --drop-influential 1 (or more)\n";
  if (r.no_model_fits)
    s += fmt::format("warning: no candidate model fits these views well (RMS {:.2f} px, cross-validation {:.2f} px): "
                     "check the board size, or the lens needs a model not fitted here\n",
                     r.model.rms_reprojection_px, r.cross_validation_px);
  if (r.corners_poorly_covered)
    s += "warning: the image corners/edges are poorly covered by the boards; the model is extrapolated there\n";
  if (fit_worse_than_heldout(r))
    s += fmt::format("warning: the model fits every view at {:.3f} px RMS but the views it did not see at {:.3f} px: a fit "
                     "of all views should not be worse than held out (a solve caught in a local minimum?); compare the "
                     "table's other candidates with --model\n",
                     r.model.rms_reprojection_px, r.heldout_rms_px);
  return s;
}

// Worst-direction standard deviation of a ray at infinity's pixel, per estimate.
std::string uncertainty_text(const CalibrationResult& r) {
  const UncertaintyReport& u = r.uncertainty;
  std::string s;
  auto line = [&](const char* name, const UncertaintyGrid& g) {
    if (g.nx > 0 && std::isfinite(g.median_px))
      s += fmt::format("  {:<34} centre {:>7.3f}  median {:>7.3f}  image corners {}\n", name, g.centre_px,
                       g.median_px, std::isfinite(g.corner_px) ? fmt::format("{:.3g} px", g.corner_px) : "no ray");
  };
  s += fmt::format("projection uncertainty (1 sigma, rays at infinity; headline: {}):\n",
                   u.headline.empty() ? "none" : u.headline);
  line("jackknife (leave one view out)", u.jackknife);
  line("linear, rotation fitted out", u.rotation_fitted);
  line("linear, mean frames (mrcal)", u.mean_frames);
  if (!u.linear_ok && !u.linear_error.empty()) s += fmt::format("  linear estimate: {}\n", u.linear_error);
  s += fmt::format(
      "cross-validation {:.3f} px ({:.3f} px over {} splits); predicted from the uncertainty: jackknife {:.3f}, "
      "linear {:.3f} px\n",
      r.cross_validation_px, u.cv_repeated_px, u.cv_splits, u.predicted_cv_jackknife_px, u.predicted_cv_linear_px);
  return s;
}

// ---- JSON ------------------------------------------------------------------------------

nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); }

nlohmann::json board_warp_json(const BoardWarpReport& w) {
  if (!w.fitted) return nullptr;
  return {{"x2_mm", w.mm[0]}, {"y2_mm", w.mm[1]}, {"x2_sd_mm", num(w.sd_mm[0])}, {"y2_sd_mm", num(w.sd_mm[1])},
          {"sd_error", w.sd_error}};
}

// How --board-warp auto decided; null when it was not asked. "tested" false: kept untested
// ("why" says why), without the comparison's numbers.
nlohmann::json board_warp_choice_json(const BoardWarpChoice& c) {
  if (c.why.empty()) return nullptr;
  if (!c.decided) return {{"kept", c.keep}, {"tested", false}, {"model", c.model}, {"why", c.why}};
  const SplitChallenge& r = c.challenge;
  return {{"kept", c.keep},
          {"tested", true},
          {"model", c.model},
          {"splits", c.warp.heldout_px.size()},
          {"heldout_gain_px", num(r.gain_px)},
          {"heldout_gain_se_px", num(r.se_px)},
          {"cross_validation_gain_px", num(r.cv_gain_px)},
          {"cross_validation_gain_se_px", num(r.cv_se_px)},
          {"heldout_splits_px", {{"warp", c.warp.heldout_px}, {"flat", c.flat.heldout_px}}},
          {"cross_validation_splits_px", {{"warp", c.warp.cross_validation_px}, {"flat", c.flat.cross_validation_px}}},
          {"why", c.why}};
}

nlohmann::json grid_json(const UncertaintyGrid& g) {
  if (g.nx <= 0) return nullptr;
  return {{"centre_px", num(g.centre_px)}, {"median_px", num(g.median_px)}, {"corner_px", num(g.corner_px)}};
}

nlohmann::json uncertainty_json(const GeometricCalibration& run) {
  const UncertaintyReport& u = run.result.uncertainty;
  return {{"headline", u.headline},
          {"headline_px", grid_json(u.headline_grid())},
          {"jackknife_px", grid_json(u.jackknife)},
          {"linear_rotation_fitted_px", grid_json(u.rotation_fitted)},
          {"linear_mean_frames_px", grid_json(u.mean_frames)},
          {"linear_ok", u.linear_ok},
          {"linear_error", u.linear_error},
          {"sigma_px", num(u.linear_ok ? u.sigma_px : std::numeric_limits<double>::quiet_NaN())},
          {"predicted_cross_validation_jackknife_px", num(u.predicted_cv_jackknife_px)},
          {"predicted_cross_validation_linear_px", num(u.predicted_cv_linear_px)},
          {"cross_validation_repeated_px", num(u.cv_repeated_px)},
          {"cross_validation_splits", u.cv_splits},
          {"plot", run.uncertainty_picture ? nlohmann::json(run.picture_stem + "_uncertainty.png") : nlohmann::json()}};
}

nlohmann::json table_json(const CalibrationResult& r) {
  nlohmann::json table = nlohmann::json::array();
  for (const ModelCandidate& c : r.table)
    table.push_back({{"model", c.name}, {"lensmodel", c.lensmodel}, {"solver", c.solver}, {"params", c.params}, {"ok", c.ok},
                     {"error", c.error}, {"screened", c.screened}, {"rms_px", c.rms_px}, {"heldout_rms_px", c.heldout_rms_px},
                     {"cross_validation_px", c.cross_validation_px},
                     {"cross_validation_splits_px", c.cross_validation_splits_px},
                     {"cross_validation_repeated_px", num(c.cross_validation_repeated_px)},
                     {"heldout_splits_px", c.heldout_splits_px}, {"split_wins", c.split_wins}, {"raced_out", c.raced_out}, {"outfitted", c.outfitted},
                     {"challenge_gain_px", num(c.challenge_gain_px)}, {"challenge_se_px", num(c.challenge_se_px)},
                     {"linear_sigma_px", num(c.linear_sigma_px)},
                     {"linear_forecast_cross_validation_px", num(c.linear_forecast_cv_px)},
                     {"within_noise", c.within_noise}});
  return table;
}

nlohmann::json views_json(const GeometricCalibration& run) {
  const CalibrationResult& r = run.result;
  nlohmann::json views = nlohmann::json::array();
  for (size_t v = 0; v < r.views.size(); ++v)
    views.push_back({{"file", run.detections.images[v]}, {"used", r.views[v].used}, {"why", r.views[v].why},
                     {"rms_px", r.views[v].rms_px}, {"leverage_px", r.views[v].leverage_px},
                     {"influential", r.views[v].influential}, {"rejected_corners", r.views[v].rejected_corners}});
  return views;
}

nlohmann::json images_json(const BoardDetections& d) {
  nlohmann::json images = nlohmann::json::array();
  for (size_t i = 0; i < d.images.size(); ++i) {
    const BoardDetection& b = d.per_image[i];
    images.push_back({{"file", d.images[i]}, {"found", b.found}, {"method", b.method}, {"reason", b.reason},
                      {"attempts", b.attempts}, {"seconds", b.seconds}});
  }
  return images;
}

nlohmann::json selection_json(const CalibrationResult& r) {
  return {{"rule", r.selection_rule},
          {"simplest_within_noise", r.simplest_within_noise},
          {"field_deg", num(r.selection_field_deg)},
          {"family_first", r.selection_perspective_first ? "perspective" : "wide-angle"},
          {"ranked_on", r.selected_on == "repeated" ? "cross_validation_repeated_px" : "cross_validation_px"},
          {"splits", r.cv_splits},
          {"noise_px", num(r.selection_noise_px)},
          {"noise_from", r.selection_noise_from_splits ? "split_spread" : "jackknife"},
          {"jackknife_noise_px", num(r.cv_noise_px)},
          {"split_noise_px", num(r.cv_split_noise_px)},
          {"k", r.selection_k}};
}

}  // namespace

std::string GeometricCalibration::summary() const {
  std::string s;
  for (const std::string& n : notes) s += n + "\n";
  s += fmt::format("{} of {} images have the {}x{} board ({:.2f} s); solved in {:.2f} s\n", detections.found,
                   detections.images.size(), board.cols, board.rows, detections.seconds, solve_seconds);
  s += table_text(result);
  s += views_text(*this);
  s += uncertainty_text(result);
  s += board_warp_text(result.board_warp, result.board_warp_choice);
  // Kept: why (won, or untested on too few views).
  if (const BoardWarpChoice& c = result.board_warp_choice; c.keep && result.board_warp.fitted && !c.why.empty())
    s += "  (" + c.why + ")\n";
  if (optimization_inputs)
    s += "the .cameramodel carries mrcal's optimization_inputs: mrcal-show-projection-uncertainty and "
         "mrcal-show-residuals-board-observation read it\n";
  s += fmt::format("wrote {}; pictures {}_residuals.png, {}_coverage.png{}\n", fmt::join(written, ", "), picture_stem,
                   picture_stem, uncertainty_picture ? fmt::format(", {}_uncertainty.png", picture_stem) : "");
  return s;
}

std::string GeometricCalibration::to_json() const {
  const CalibrationResult& r = result;
  nlohmann::json dropped_json = nlohmann::json::array();
  for (const DroppedView& d : dropped)
    dropped_json.push_back({{"file", detections.images[d.view]}, {"leverage_px", d.leverage_px}});
  nlohmann::json before = nullptr;
  if (before_dropping)
    before = {{"selected", before_dropping->selected}, {"rms_px", before_dropping->rms_px},
              {"cross_validation_px", before_dropping->cross_validation_px},
              {"heldout_rms_px", before_dropping->heldout_rms_px}};
  nlohmann::json stand_in = nullptr;  // CalibrationResult::mrcal_stand_in, and the file holding it
  if (const auto& s = r.mrcal_stand_in) {
    nlohmann::json file = nullptr;
    for (const std::string& w : written)
      if (fs::path(w).extension() == ".cameramodel") file = w;
    stand_in = {{"candidate", s->name}, {"lensmodel", s->model.lensmodel}, {"file", file},
                {"rms_px", num(s->rms_px)}, {"heldout_rms_px", num(s->heldout_rms_px)},
                {"median_from_chosen_px", num(s->median_from_chosen_px)},
                {"same_ray_from_chosen_px", num(s->same_ray_from_chosen_px)}, {"fits_poorly", s->fits_poorly}};
  }
  const nlohmann::json j = {
      {"output", written}, {"optimization_inputs", optimization_inputs}, {"mrcal_stand_in", stand_in}, {"selected", r.selected}, {"lensmodel", r.model.lensmodel},
      {"uncertainty", uncertainty_json(*this)}, {"intrinsics", r.model.intrinsics},
      {"board_warp", board_warp_json(r.board_warp)},
      {"board_warp_choice", board_warp_choice_json(r.board_warp_choice)},
      {"rms_px", r.model.rms_reprojection_px}, {"cross_validation_px", r.cross_validation_px},
      {"cross_validation_noise_px", num(r.cv_noise_px)},
      {"cross_validation_repeated_px", num(r.cross_validation_repeated_px)}, {"selection", selection_json(r)},
      {"heldout_rms_px", r.heldout_rms_px}, {"dropped_views", dropped_json}, {"before_dropping", before},
      {"views_with_board", detections.found}, {"detect_seconds", detections.seconds},
      {"solve_seconds", solve_seconds}, {"corners_poorly_covered", r.corners_poorly_covered},
      {"no_model_fits", r.no_model_fits}, {"fit_worse_than_heldout", fit_worse_than_heldout(r)},
      {"outliers", {{"reference", r.outlier_reference}, {"rounds", r.outlier_rounds},
                    {"corners_rejected", r.corners_rejected}, {"corners_total", r.corners_total}}},
      {"table", table_json(r)}, {"views", views_json(*this)},
      {"images", images_json(detections)}};
  return j.dump();
}

void check_calibration_output(const std::string& output, const std::string& model) {
  if (!model.empty()) {
    try {
      candidate_lens_type(model);
    } catch (const InputError& e) {
      throw InputError(std::string("--model: ") + e.what());
    }
  }
  const std::string ext = fs::path(output).extension().string();
  if (ext != ".cameramodel" && ext != ".yaml" && ext != ".yml")
    throw InputError(output + ": the output must be .cameramodel or .yaml");
  std::error_code ec;
  const fs::path dir = fs::path(output).parent_path();
  if (!dir.empty() && !fs::is_directory(dir, ec))
    throw InputError(output + ": cannot write: directory " + dir.string() + " does not exist");
}

GeometricCalibration calibrate_images(const std::vector<std::string>& images, const BoardSpec& board,
                                      const GeometricCalibrationOptions& options,
                                      const std::function<void()>& on_image_detected) {
  return calibrate_detections(detect_boards(images, board, options.detect, on_image_detected), board, options);
}

GeometricCalibration calibrate_detections(BoardDetections detections, const BoardSpec& board,
                                          const GeometricCalibrationOptions& options) {
  GeometricCalibration run;
  run.board = board;
  run.drop_influential = options.drop_influential;
  run.detections = std::move(detections);
  const BoardDetections& d = run.detections;
  const size_t n = d.images.size();
  if (d.found == 0) {
    for (const BoardDetection& b : d.per_image)  // a wrong --board: say what the images show
      if (b.other_cols > 0)
        throw InputError(fmt::format("no {}x{} board found in any of the {} images: found {}x{} inner corners, --board says {}x{}",
                                     board.cols, board.rows, n, b.other_cols, b.other_rows, board.cols, board.rows));
    throw InputError(fmt::format("no {}x{} board found in any of the {} images (check --board: inner corners)",
                                 board.cols, board.rows, n));
  }
  // Some images show another board size (a count of squares given for inner corners finds
  // a sub-board in a few views and drops the rest): said, or refused when they are the most.
  std::map<std::pair<int, int>, int> other_sizes;
  for (const BoardDetection& b : d.per_image)
    if (b.other_cols > 0) ++other_sizes[{b.other_cols, b.other_rows}];
  for (const auto& [size, count] : other_sizes) {
    const std::string what = fmt::format("{} of the {} images show a {}x{} board (inner corners), not the {}x{} of --board",
                                         count, n, size.first, size.second, board.cols, board.rows);
    if (count > int(d.found)) throw InputError(what + fmt::format(", found in only {}: check --board", d.found));
    run.notes.push_back(what + ": those views are left out");
  }
  if (d.found < 4)
    throw InputError(fmt::format("a {}x{} board was found in only {} of {} images; at least 4 views are needed",
                                 board.cols, board.rows, d.found, n));
  // A view that repeats an earlier one adds no pose, and one in each half of a split makes a
  // held-out view a fitted one: a copy of a file gave a cross-validation of 1e-14 px, a second
  // frame of a board that had not moved (0.05 px of noise) took stereo's odd/even value from
  // 0.119 to 0.065 px. Each is used once; the later ones are left out and said in one line.
  const std::vector<RepeatedView> repeats =
      repeated_views(d.corners, kRepeatedViewRmsPx * pixel_limit_scale(d.width, d.height));
  if (d.found - repeats.size() < 4)
    throw InputError(fmt::format("only {} distinct views: {} of the {} with a board repeat an earlier one ({}); at least 4 "
                                 "are needed",
                                 d.found - repeats.size(), repeats.size(), d.found, repeats_text(repeats, d.images)));
  if (!repeats.empty())
    run.notes.push_back(fmt::format("{} {} an earlier one, each used once: {}", repeats.size(),
                                    repeats.size() == 1 ? "view repeats" : "views repeat", repeats_text(repeats, d.images)));
  const auto t0 = std::chrono::steady_clock::now();
  run.corners = d.corners;
  for (const RepeatedView& r : repeats) run.corners[r.view].clear();
  // After every solve (the one without influential views included): what the report says of them.
  const auto say_repeats = [&] {
    for (const RepeatedView& r : repeats)
      run.result.views[r.view].why = fmt::format("left out: the same view as {} (corners {:.2f} px RMS apart)",
                                                 d.images[r.same_as], r.rms_px);
  };
  run.result = calibrate(run.corners, board, d.width, d.height, options.calibrate);
  say_repeats();
  if (options.drop_influential > 0) {
    const std::vector<DroppedView> drop = views_to_drop(run.result, options.drop_influential);
    // At least five views stay: asking for more than that leaves was capped without a word.
    int flagged = 0;
    for (const auto& v : run.result.views) flagged += v.influential;
    if (flagged == 0)  // asked for and nothing done: said, not left to the reader to notice
      run.notes.push_back(fmt::format(
          "--drop-influential {}: no view is flagged influential (none moves the projection by more than both {} x "
          "the median view's leverage and {:.2g} px), so none was dropped",
          options.drop_influential, options.calibrate.leverage_flag_factor, options.calibrate.leverage_min_px));
    else if (int(drop.size()) < std::min(options.drop_influential, flagged))
      run.notes.push_back(fmt::format("--drop-influential {}: {} of the {} influential views dropped; at least 5 views stay",
                                      options.drop_influential, drop.size(), flagged));
    if (!drop.empty()) {
      const CalibrationResult& r = run.result;
      run.before_dropping =
          GeometricCalibration::Answer{r.selected, r.model.rms_reprojection_px, r.cross_validation_px, r.heldout_rms_px};
      for (const DroppedView& v : drop) run.corners[v.view].clear();
      run.result = calibrate(run.corners, board, d.width, d.height, options.calibrate);
      say_repeats();
      for (const DroppedView& v : drop)
        run.result.views[v.view].why =
            fmt::format("dropped: influential (leaving it out moved the projection by {:.2f} px)", v.leverage_px);
      run.dropped = drop;
    }
  }
  // No model within reach of the corners: a board of the same corner count but another
  // shape (--board 18x3 for 9x6: a spline at 59 px RMS), never a lens. Refused, not written
  // with a warning. Between fit_max_rms_px and this, a warning says it (a blurred board).
  // Both limits grow with the image as the fit limits do (pixel_limit_scale).
  const double refuse_rms_px = 5 * pixel_limit_scale(d.width, d.height);
  if (run.result.no_model_fits && run.result.model.rms_reprojection_px > refuse_rms_px)
    throw InputError(fmt::format("no model fits these views: the best ({}) misses the corners by {:.1f} px RMS (over {:g} "
                                 "px): check --board (inner corners, columns x rows) and that every view is of one camera",
                                 run.result.selected, run.result.model.rms_reprojection_px, refuse_rms_px));
  // Nor a model whose two halves of the views disagree by tens of pixels: the views do not
  // determine the lens (an audit's 5 views of a 125 deg lens: halves 413 px apart, the model
  // written 287 px from the truth with a warning). A good model on 4 views of a 190 deg lens
  // had one split 9 px apart: far below.
  const double refuse_cross_validation_px = 50 * pixel_limit_scale(d.width, d.height);
  if (run.result.no_model_fits && run.result.cross_validation_px > refuse_cross_validation_px)
    throw InputError(fmt::format(
        "no model is determined by these views: models of two halves of them ({}) differ by {:.0f} px RMS (over {:g} "
        "px): add views, with boards over the whole image and at several angles",
        run.result.selected, run.result.cross_validation_px, refuse_cross_validation_px));
  run.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return run;
}

void write_calibration_files(GeometricCalibration& run, const std::string& output, const std::string& report_dir) {
  const CameraModel& model = run.result.model;
  const bool cameramodel = fs::path(output).extension() == ".cameramodel";
  const std::string yaml = cameramodel ? with_extension(output, ".yaml") : output;
  if (cameramodel) {
    if (is_mrcal_model(model.lensmodel)) {
      const SolveRecord& solve = run.result.solve;
      write_cameramodel(output, model,
                        solve.views.empty() ? "" : mrcal_optimization_inputs(model, run.board, solve, run.detections.images));
      run.optimization_inputs = !solve.views.empty();
      run.written.push_back(output);
    } else if (const auto& s = run.result.mrcal_stand_in) {
      // The choice has no mrcal form; the best mrcal candidate of the same solve stands in, so
      // that mrcal's tools have this calibration to work on. Said in one line, with how far the
      // two project apart.
      write_cameramodel(output, s->model, mrcal_optimization_inputs(s->model, run.board, s->solve, run.detections.images));
      run.optimization_inputs = true;
      run.written.push_back(output);
      run.notes.push_back(fmt::format(
          "{} (the choice) is not an mrcal model: {} holds it; {} holds {}, the best mrcal candidate of the same "
          "solve (RMS {:.3f} px, held-out {:.3f} px{}), {:.3f} px from the choice over the covered area with the "
          "rotation between their frames fitted out, {:.3f} px without{}",
          model.lensmodel, yaml, output, s->model.lensmodel, s->rms_px, s->heldout_rms_px,
          s->fits_poorly ? ", beyond the fit limits: use with care" : "", s->median_from_chosen_px,
          s->same_ray_from_chosen_px,
          s->same_ray_from_chosen_px > 2 * s->median_from_chosen_px + 0.1
              ? ": their camera frames differ, so take light directions (probe unwrap --camera) from the YAML"
              : ""));
    } else {
      // An earlier run's .cameramodel beside the new YAML would disagree with it: said.
      std::error_code ec;
      if (fs::exists(output, ec))
        run.notes.push_back(output + " is from an earlier run and was not replaced: it no longer matches " + yaml);
      // No stand-in: the model was forced (--model), or no mrcal candidate fits; say which.
      const ModelCandidate* best = nullptr;
      for (const ModelCandidate& c : run.result.table)
        if (is_mrcal_model(c.model.lensmodel) && c.rms_px > 0 && (!best || c.rms_px < best->rms_px)) best = &c;
      run.notes.push_back(model.lensmodel + " is not an mrcal model: writing OpenCV YAML only (" + yaml +
                          "; mrcal's tools cannot read it" +
                          (best ? fmt::format("; no mrcal candidate fits these corners, the best {} at RMS {:.3f} px)",
                                              best->model.lensmodel, best->rms_px)
                                : std::string(")")));
    }
  }
  if (LensModel::parse(model.lensmodel).has_opencv_form()) {
    write_opencv_yaml(yaml, model);
    run.written.push_back(yaml);
    // cv::fisheye projects through atan(r / z): a ray beyond 90 degrees of the axis lands on
    // the wrong side (over 1000 px off on a 190 degree lens). Where the model maps the middle
    // of a frame edge that far, the YAML's readers are told. (On a circular fisheye an edge's
    // middle may lie beyond the image circle, where the polynomial is extrapolated: the note
    // says what the model maps, not what the lens saw.)
    if (model.lensmodel == "LENSMODEL_KANNALA_BRANDT") {
      double field = 0;
      const double w = model.width, h = model.height;
      for (const Pixel px : {Pixel{0.5, h / 2}, Pixel{w - 0.5, h / 2}, Pixel{w / 2, 0.5}, Pixel{w / 2, h - 0.5}})
        if (const auto ray = unproject(model, px))
          field = std::max(field, std::acos(std::clamp(ray->z / length(*ray), -1.0, 1.0)) * 180 / M_PI);
      if (field > 90)
        run.notes.push_back(fmt::format(
            "{}: the model maps the frame's edges to rays up to {:.0f} degrees from the axis; OpenCV's cv::fisheye "
            "functions take rays within 90 degrees only (projectPoints puts one beyond on the wrong side): beyond that use the "
            ".cameramodel, mrcal or lightprobe's own unwrap",
            yaml, field));
    }
  } else {
    if (run.written.empty()) write_opencv_yaml(yaml, model);  // throws the writer's one-line reason
    run.notes.push_back(model.lensmodel + " has no OpenCV form: " + output + " only");
  }
  const std::string dir = report_dir.empty() ? fs::path(output).parent_path().string() : report_dir;
  if (!dir.empty()) fs::create_directories(dir);
  run.picture_stem = (fs::path(dir) / fs::path(output).stem()).string();
  // The three pictures are independent files: drawn and encoded on every core (each PNG
  // writer renames its own temporary file; the first error is rethrown).
  run.uncertainty_picture = has_uncertainty(run.result);
  run_jobs(3, [&](size_t j) {
    if (j == 0) write_residual_plot(run.picture_stem + "_residuals.png", run.result, run.corners);
    if (j == 1) write_coverage_plot(run.picture_stem + "_coverage.png", run.result);
    if (j == 2 && run.uncertainty_picture) write_uncertainty_plot(run.picture_stem + "_uncertainty.png", run.result);
  });
}

}  // namespace lp
