// calib geometric and synth boards: chessboard calibration with model selection by
// cross-validation, and boards rendered through a known camera (ground truth).
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>

#include "calib/board_detect.h"
#include "calib/calibration_report.h"
#include "calib/camera_model.h"
#include "calib/colour_match.h"
#include "calib/photometric.h"
#include "calib/geometric.h"
#include "calib/synthetic_boards.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "hdr/bracket.h"

namespace lp::cli {

struct CalibGeometricArgs {
  std::vector<std::string> images;
  std::string board;                // COLSxROWS inner corners
  double square_mm = 0;
  std::string model;                // override the selection
  bool no_mrcal = false;
  std::string report_dir;           // pictures; default beside the output
  std::string output;               // camera.cameramodel or camera.yaml
  int drop_influential = 0;         // recalibrate without up to N flagged views, worst first
};

struct CalibCompareArgs {
  std::string a, b;                 // two model files of one camera
  int step_px = 4;
  bool no_rotation = false;
};

struct CalibPhotometricArgs {
  std::string readings;
  std::string model = "linear";     // linear|log
  std::string loss = "huber";       // huber|cauchy|none
  std::string output;
};

struct CalibColourArgs {
  std::string patches;              // CSV probe_r,probe_g,probe_b,plate_r,plate_g,plate_b
  std::string output;
};

namespace {

namespace fs = std::filesystem;

std::string with_extension(const std::string& path, const std::string& ext) {
  return (fs::path(path).parent_path() / (fs::path(path).stem().string() + ext)).string();
}

}  // namespace

int run_calib_geometric(const CalibGeometricArgs& args, const Output& out) {
  const BoardSpec board = board_from(args.board, args.square_mm);
  const std::string ext = fs::path(args.output).extension().string();
  if (ext != ".cameramodel" && ext != ".yaml" && ext != ".yml")
    throw InputError(fmt::format("{}: the output must be .cameramodel or .yaml", args.output));
  if (args.drop_influential < 0) throw InputError("--drop-influential must be 0 or more");
  {  // Fail before minutes of work when the output cannot be written.
    std::error_code ec;
    const fs::path dir = fs::path(args.output).parent_path();
    if (!dir.empty() && !fs::is_directory(dir, ec))
      throw InputError(fmt::format("{}: cannot write: directory {} does not exist", args.output, dir.string()));
  }
  // Detect the board in every image, in parallel (each image is independent, so the result
  // does not depend on the order); all images must share one resolution.
  std::vector<std::vector<std::array<double, 2>>> corners(args.images.size());
  std::vector<BoardDetection> detections(args.images.size());
  std::vector<std::array<int, 2>> sizes(args.images.size());
  std::vector<std::string> errors(args.images.size());
  Progress progress("detect boards", args.images.size(), out.progress);
  const auto t0 = std::chrono::steady_clock::now();
  tbb::parallel_for(size_t(0), args.images.size(), [&](size_t i) {
    try {
      const CameraImage img = read_camera_image(args.images[i]);
      sizes[i] = {img.width, img.height};
      detections[i] = detect_board(img, board);
    } catch (const InputError& e) {
      errors[i] = e.what();
    }
    progress.advance();
  });
  progress.finish();
  int width = 0, height = 0, found = 0;
  nlohmann::json images = nlohmann::json::array();
  for (size_t i = 0; i < args.images.size(); ++i) {  // first error in the given order
    if (!errors[i].empty()) throw InputError(errors[i]);
    if (i == 0) {
      width = sizes[i][0];
      height = sizes[i][1];
    } else if (sizes[i][0] != width || sizes[i][1] != height) {
      throw InputError(fmt::format("{}: {}x{} differs from the first image's {}x{} (one camera, one resolution)",
                                   args.images[i], sizes[i][0], sizes[i][1], width, height));
    }
    const BoardDetection& d = detections[i];
    if (d.found) {
      corners[i] = d.corners;
      ++found;
    }
    images.push_back({{"file", args.images[i]}, {"found", d.found}, {"method", d.method}, {"reason", d.reason},
                      {"attempts", d.attempts}, {"seconds", d.seconds}});
  }
  const double detect_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (found == 0)
    throw InputError(fmt::format("no {}x{} board found in any of the {} images (check --board: inner corners)",
                                 board.cols, board.rows, args.images.size()));
  if (found < 4)
    throw InputError(fmt::format("a {}x{} board was found in only {} of {} images; at least 4 views are needed",
                                 board.cols, board.rows, found, args.images.size()));

  CalibrateOptions co;
  co.model = args.model;
  co.use_mrcal = !args.no_mrcal;
  // One bar per stage of the solve (a 60-view solve takes most of a minute).
  std::unique_ptr<Progress> solve_bar;
  std::string solve_stage;
  int solve_done = 0, solve_total = 0;
  co.progress = [&](const std::string& stage, int done, int total) {
    if (stage != solve_stage) {  // the library reports a step as it starts: close the last one
      if (solve_bar) {
        if (solve_total > solve_done) solve_bar->advance(uint64_t(solve_total - solve_done));
        solve_bar->finish();
      }
      solve_bar.reset();
      solve_stage = stage;
      solve_done = 0;
      solve_total = std::max(1, total);
      if (stage != "done") solve_bar = std::make_unique<Progress>("solve: " + stage, uint64_t(std::max(1, total)), out.progress);
    }
    if (solve_bar && done > solve_done) {
      solve_bar->advance(uint64_t(done - solve_done));
      solve_done = done;
    }
  };
  const auto t1 = std::chrono::steady_clock::now();
  CalibrationResult r = calibrate(corners, board, width, height, co);
  // Influential views (a few close-ups can move the whole answer): on request, the worst
  // flagged ones are left out and everything is solved again, and both answers are shown.
  struct Dropped {
    size_t view;
    double leverage_px;
  };
  std::vector<Dropped> dropped;
  nlohmann::json before = nullptr;
  std::string drop_summary;
  if (args.drop_influential > 0) {
    std::vector<Dropped> flagged;
    for (size_t v = 0; v < r.views.size(); ++v)
      if (r.views[v].influential) flagged.push_back({v, r.views[v].leverage_px});
    std::sort(flagged.begin(), flagged.end(), [](const Dropped& a, const Dropped& b) {
      return a.leverage_px > b.leverage_px || (a.leverage_px == b.leverage_px && a.view < b.view);
    });
    int used = 0;
    for (const auto& v : r.views) used += v.used;
    // Never below the 4 views a calibration needs (plus one so each half keeps two).
    const int can_drop = std::max(0, std::min<int>(args.drop_influential, used - 5));
    if (int(flagged.size()) > can_drop) flagged.resize(size_t(can_drop));
    if (!flagged.empty()) {
      before = {{"selected", r.selected}, {"rms_px", r.model.rms_reprojection_px},
                {"cross_validation_px", r.cross_validation_px}, {"heldout_rms_px", r.heldout_rms_px}};
      const std::string was = fmt::format("{} (cross-validation {:.3f} px, RMS {:.3f} px)", r.selected,
                                          r.cross_validation_px, r.model.rms_reprojection_px);
      for (const Dropped& d : flagged) corners[d.view].clear();
      r = calibrate(corners, board, width, height, co);
      for (const Dropped& d : flagged)
        r.views[d.view].why = fmt::format("dropped: influential (leaving it out moved the projection by {:.2f} px)",
                                          d.leverage_px);
      dropped = flagged;
      drop_summary = fmt::format("with all views: {}; without the {} most influential: {} (cross-validation {:.3f} px, "
                                 "RMS {:.3f} px){}\n",
                                 was, dropped.size(), r.selected, r.cross_validation_px, r.model.rms_reprojection_px,
                                 r.cross_validation_px > before["cross_validation_px"].get<double>()
                                     ? "; the halves agree less without them: consider keeping all views"
                                     : "");
    }
  }
  const double solve_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();

  // Files: .cameramodel where mrcal has the model, OpenCV YAML wherever OpenCV has it.
  std::vector<std::string> written;
  const bool mrcal_model = is_mrcal_model(r.model.lensmodel);
  const std::string yaml = ext == ".cameramodel" ? with_extension(args.output, ".yaml") : args.output;
  if (ext == ".cameramodel") {
    if (mrcal_model) {
      write_cameramodel(args.output, r.model);
      written.push_back(args.output);
    } else {
      say(out, "{} is not an mrcal model: writing OpenCV YAML only ({})\n", r.model.lensmodel, yaml);
    }
  }
  try {
    write_opencv_yaml(yaml, r.model);
    written.push_back(yaml);
  } catch (const InputError&) {
    if (written.empty()) throw;
    say(out, "{} has no OpenCV form: {} only\n", r.model.lensmodel, args.output);
  }
  // Pictures.
  const std::string report_dir = args.report_dir.empty() ? fs::path(args.output).parent_path().string() : args.report_dir;
  if (!report_dir.empty()) fs::create_directories(report_dir);
  const std::string stem = (fs::path(report_dir) / fs::path(args.output).stem()).string();
  write_residual_plot(stem + "_residuals.png", r, corners);
  write_coverage_plot(stem + "_coverage.png", r);
  const UncertaintyReport& u = r.uncertainty;
  const UncertaintyGrid& ug = u.headline_grid();
  const bool have_uncertainty = ug.nx > 0 && std::isfinite(ug.median_px);
  if (have_uncertainty) write_uncertainty_plot(stem + "_uncertainty.png", r);

  say(out, "{} of {} images have the {}x{} board ({:.2f} s); solved in {:.2f} s\n", found, args.images.size(),
      board.cols, board.rows, detect_s, solve_s);
  const bool repeated = r.selected_on == "repeated";
  const std::string splits_col = fmt::format("{} splits", r.cv_splits);
  say(out, "{:<44} {:>6} {:>9} {:>10} {:>10} {:>10} {:>10}\n", "model", "params", "RMS px", "held-out", "cv odd/even",
      repeated ? splits_col : "", "lin. sigma");
  for (const ModelCandidate& c : r.table)
    if (c.ok)
      say(out, "{:<44} {:>6} {:>9.3f} {:>10.3f} {:>10.3f} {:>10} {:>10}{}\n", c.name, c.params, c.rms_px,
          c.heldout_rms_px, c.cross_validation_px,
          !repeated ? "" : (std::isnan(c.cross_validation_repeated_px) ? "screened" : fmt::format("{:.3f}", c.cross_validation_repeated_px)),
          std::isfinite(c.linear_sigma_px) ? fmt::format("{:.3f}", c.linear_sigma_px) : "-",
          c.name == r.selected ? "   <- chosen" : (c.within_noise ? "   (within noise)" : ""));
    else
      say(out, "{:<44} failed: {}\n", c.name, c.error);
  if (r.table.size() == 1 || !std::isfinite(r.cv_noise_px))  // --model: no selection, so no noise estimate for it
    say(out, "model {} as requested; {} of {} corners rejected as outliers\n", r.selected, r.corners_rejected,
        r.corners_total);
  else
    say(out, "chosen: {}, the fewest parameters within the noise of the best (cross-validation {} within {} x {:.3f} "
             "px, {}; held-out RMS within {} / sqrt(residuals)); {} of {} corners rejected as outliers\n",
        r.selected, repeated ? "over " + splits_col : "odd/even", r.selection_k, r.selection_noise_px,
        r.selection_noise_from_splits ? "the spread of the per-split values / sqrt(splits)"
                                      : "the jackknife standard error of the odd/even one",
        r.selection_k, r.corners_rejected, r.corners_total);
  for (const Dropped& d : dropped) say(out, "dropped influential view: {} ({:.2f} px)\n", args.images[d.view], d.leverage_px);
  if (!drop_summary.empty()) say(out, "{}", drop_summary);
  int influential = 0;
  for (size_t v = 0; v < r.views.size(); ++v)
    if (r.views[v].influential) {
      say(out, "influential view: {} (leaving it out moves the projection by {:.2f} px)\n", args.images[v],
          r.views[v].leverage_px);
      ++influential;
    }
  if (influential > 0 && args.drop_influential == 0)
    say(out, "to solve again without the worst of them and compare: --drop-influential 1 (or more)\n");
  if (r.no_model_fits)
    say(out, "warning: no candidate model fits these views well (RMS {:.2f} px, cross-validation {:.2f} px): check the "
             "board size, or the lens needs a model not fitted here\n",
        r.model.rms_reprojection_px, r.cross_validation_px);
  if (r.corners_poorly_covered)
    say(out, "warning: the image corners/edges are poorly covered by the boards; the model is extrapolated there\n");
  // Uncertainty: worst-direction standard deviation of a ray at infinity's pixel.
  auto line = [&](const char* name, const UncertaintyGrid& g) {
    if (g.nx > 0 && std::isfinite(g.median_px))
      say(out, "  {:<34} centre {:>7.3f}  median {:>7.3f}  image corners {}\n", name, g.centre_px, g.median_px,
          std::isfinite(g.corner_px) ? fmt::format("{:.3g} px", g.corner_px) : "no ray");
  };
  say(out, "projection uncertainty (1 sigma, rays at infinity; headline: {}):\n", u.headline.empty() ? "none" : u.headline);
  line("jackknife (leave one view out)", u.jackknife);
  line("linear, rotation fitted out", u.rotation_fitted);
  line("linear, mean frames (mrcal)", u.mean_frames);
  if (!u.linear_ok && !u.linear_error.empty()) say(out, "  linear estimate: {}\n", u.linear_error);
  say(out, "cross-validation {:.3f} px ({:.3f} px over {} splits); predicted from the uncertainty: jackknife {:.3f}, "
           "linear {:.3f} px\n",
      r.cross_validation_px, u.cv_repeated_px, u.cv_splits, u.predicted_cv_jackknife_px, u.predicted_cv_linear_px);
  say(out, "wrote {}; pictures {}_residuals.png, {}_coverage.png{}\n", fmt::join(written, ", "), stem, stem,
      have_uncertainty ? fmt::format(", {}_uncertainty.png", stem) : "");

  auto num = [](double x) -> nlohmann::json { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); };
  nlohmann::json table = nlohmann::json::array();
  for (const ModelCandidate& c : r.table)
    table.push_back({{"model", c.name}, {"lensmodel", c.lensmodel}, {"params", c.params}, {"ok", c.ok},
                     {"error", c.error}, {"rms_px", c.rms_px}, {"heldout_rms_px", c.heldout_rms_px},
                     {"cross_validation_px", c.cross_validation_px},
                     {"cross_validation_splits_px", c.cross_validation_splits_px},
                     {"cross_validation_repeated_px", num(c.cross_validation_repeated_px)},
                     {"linear_sigma_px", num(c.linear_sigma_px)},
                     {"linear_forecast_cross_validation_px", num(c.linear_forecast_cv_px)},
                     {"within_noise", c.within_noise}});
  nlohmann::json views = nlohmann::json::array();
  for (size_t v = 0; v < r.views.size(); ++v)
    views.push_back({{"file", args.images[v]}, {"used", r.views[v].used}, {"why", r.views[v].why},
                     {"rms_px", r.views[v].rms_px}, {"leverage_px", r.views[v].leverage_px},
                     {"influential", r.views[v].influential}, {"rejected_corners", r.views[v].rejected_corners}});
  nlohmann::json dropped_json = nlohmann::json::array();
  for (const Dropped& d : dropped) dropped_json.push_back({{"file", args.images[d.view]}, {"leverage_px", d.leverage_px}});
  auto grid_json = [](const UncertaintyGrid& g) -> nlohmann::json {
    auto num = [](double x) -> nlohmann::json { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); };
    if (g.nx <= 0) return nullptr;
    return {{"centre_px", num(g.centre_px)}, {"median_px", num(g.median_px)}, {"corner_px", num(g.corner_px)}};
  };
  const nlohmann::json uncertainty = {
      {"headline", u.headline},
      {"headline_px", grid_json(ug)},
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
      {"plot", have_uncertainty ? nlohmann::json(stem + "_uncertainty.png") : nlohmann::json()}};
  emit_json(out, {{"output", written}, {"selected", r.selected}, {"lensmodel", r.model.lensmodel},
                  {"uncertainty", uncertainty},
                  {"intrinsics", r.model.intrinsics}, {"rms_px", r.model.rms_reprojection_px},
                  {"cross_validation_px", r.cross_validation_px},
                  {"cross_validation_noise_px", std::isfinite(r.cv_noise_px) ? nlohmann::json(r.cv_noise_px) : nlohmann::json()},
                  {"cross_validation_repeated_px", num(r.cross_validation_repeated_px)},
                  {"selection", {{"ranked_on", r.selected_on == "repeated" ? "cross_validation_repeated_px"
                                                                            : "cross_validation_px"},
                                 {"splits", r.cv_splits},
                                 {"noise_px", num(r.selection_noise_px)},
                                 {"noise_from", r.selection_noise_from_splits ? "split_spread" : "jackknife"},
                                 {"jackknife_noise_px", num(r.cv_noise_px)},
                                 {"split_noise_px", num(r.cv_split_noise_px)},
                                 {"k", r.selection_k}}},
                  {"heldout_rms_px", r.heldout_rms_px},
                  {"dropped_views", dropped_json}, {"before_dropping", before},
                  {"views_with_board", found}, {"detect_seconds", detect_s}, {"solve_seconds", solve_s},
                  {"corners_poorly_covered", r.corners_poorly_covered}, {"no_model_fits", r.no_model_fits}, {"table", table}, {"views", views},
                  {"images", images}});
  return 0;
}

int run_calib_compare(const CalibCompareArgs& args, const Output& out) {
  // How far two calibrations of one camera disagree, in pixels over the whole image, with
  // the rotation between their camera frames fitted out (what cross-validation measures).
  const CameraModel a = read_camera_model(args.a), b = read_camera_model(args.b);
  if (a.width != b.width || a.height != b.height)
    throw InputError(fmt::format("{} is for {}x{}, {} for {}x{}", args.a, a.width, a.height, args.b, b.width, b.height));
  std::vector<uint8_t> mask(size_t(a.width) * size_t(a.height), 1);
  const ProjectionDiff d = projection_difference(a, b, mask, std::max(1, args.step_px), !args.no_rotation);
  say(out, "{} vs {}: RMS {:.3f} px, median {:.3f} px, max {:.3f} px over {} samples{}\n", args.a, args.b, d.rms_px,
      d.median_px, d.max_px, d.samples, args.no_rotation ? "" : " (rotation fitted out)");
  emit_json(out, {{"rms_px", d.rms_px}, {"median_px", d.median_px}, {"max_px", d.max_px}, {"samples", d.samples}});
  return 0;
}

int run_calib_photometric(const CalibPhotometricArgs& args, const Output& out) {
  auto readings = read_readings_csv(args.readings);
  resolve_regions(readings, fs::path(args.readings).parent_path().string());
  PhotometricOptions o;
  if (args.model == "linear") o.model = PhotometricOptions::Model::Linear;
  else if (args.model == "log") o.model = PhotometricOptions::Model::LogSensor;
  else throw InputError(fmt::format("--model must be linear or log, got '{}'", args.model));
  if (args.loss == "huber") o.loss = RobustLoss::Huber;
  else if (args.loss == "cauchy") o.loss = RobustLoss::Cauchy;
  else if (args.loss == "none") o.loss = RobustLoss::None;
  else throw InputError(fmt::format("--loss must be huber, cauchy or none, got '{}'", args.loss));
  const PhotometricCalibration cal = fit_photometric(readings, o);
  save_photometric(args.output, cal);
  if (cal.log_sensor)
    say(out, "{}: log sensor value = {:.5g} + {:.5g} ln L (+-{:.2g}, +-{:.2g}); ", args.output, cal.log_sensor->a,
        cal.log_sensor->b, cal.log_sensor->sigma_a, cal.log_sensor->sigma_b);
  else
    say(out, "{}: k = {:.6g} cd/m2 per relative unit (+-{:.2f} %); ", args.output, cal.scale_luminance,
        100 * cal.scale_relative_error);
  say(out, "{} readings, residual RMS {:.2f} %, max {:.2f} %, held-out RMS {:.2f} %\n", cal.readings,
      100 * cal.rms_relative, 100 * cal.max_abs_relative, 100 * cal.held_out_rms_relative);
  nlohmann::json j = {{"output", args.output},
                      {"readings", cal.readings},
                      {"scale_luminance", cal.scale_luminance},
                      {"scale_relative_error", cal.scale_relative_error},
                      {"rms_relative", cal.rms_relative},
                      {"max_abs_relative", cal.max_abs_relative},
                      {"held_out_rms_relative", cal.held_out_rms_relative}};
  if (cal.log_sensor) j["log_sensor"] = {{"a", cal.log_sensor->a}, {"b", cal.log_sensor->b}};
  emit_json(out, j);
  return 0;
}

int run_calib_colour(const CalibColourArgs& args, const Output& out) {
  const ColourMatch m = fit_colour_match(read_colour_patches_csv(args.patches));
  save_colour_match(args.output, m);
  say(out, "{}: 3x3 colour match from {} patches, residual RMS {:.2f} %\n", args.output, m.patches,
      100 * m.rms_relative);
  emit_json(out, {{"output", args.output}, {"patches", m.patches}, {"rms_relative", m.rms_relative},
                  {"matrix", m.matrix.m}});
  return 0;
}
std::vector<Command> calib_commands() {
  return {
      {"calib geometric", "Chessboard calibration with model selection by cross-validation",
       "lightprobe calib geometric views/*.jpg --board 9x6 --square 25 -o camera.cameramodel\nlightprobe calib geometric views/*.jpg --board 9x6 --square 25 --drop-influential 1 -o camera.cameramodel",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<CalibGeometricArgs>();
         f.arg("IMAGE", a->images, "Chessboard views (one camera, one resolution)").required();
         f.opt("--board", a->board, "COLSxROWS inner corners, e.g. 9x6").required();
         f.opt("--square", a->square_mm, "Square size, mm").required();
         f.opt("--model", a->model, "Use this model instead of the selection (see the printed table)");
         f.flag("--no-mrcal", a->no_mrcal, "OpenCV models only");
         f.opt("--report", a->report_dir, "Directory for the residual and coverage pictures");
         f.opt("--drop-influential", a->drop_influential, "Recalibrate without up to N views flagged influential (highest leverage first)");
         f.output(a->output, "camera.cameramodel (and .yaml) or camera.yaml");
         return [a](const Output& out) { return run_calib_geometric(*a, out); };
       }},
      {"calib compare", "Projection difference (px) between two models of one camera",
       "lightprobe calib compare camera_a.cameramodel camera_b.yaml",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<CalibCompareArgs>();
         f.arg("A", a->a, "Model file (.cameramodel or OpenCV YAML)").required();
         f.arg("B", a->b, "Model file").required();
         f.opt("--step", a->step_px, "Sampling step over the image, px");
         f.flag("--no-rotation", a->no_rotation, "Do not fit the rotation between the two camera frames");
         return [a](const Output& out) { return run_calib_compare(*a, out); };
       }},
      {"calib photometric", "Absolute scale (or log-sensor curve) from meter readings",
       "lightprobe calib photometric readings.csv -o photometric.json\nlightprobe hdr fuse IMG_*.jpg --photometric photometric.json -o probe.exr",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<CalibPhotometricArgs>();
         f.arg("READINGS", a->readings, "CSV: region,camera_value,measured,unit").required();
         f.opt("--model", a->model, "linear|log");
         f.opt("--loss", a->loss, "Robust loss: huber|cauchy|none");
         f.output(a->output, "photometric.json");
         return [a](const Output& out) { return run_calib_photometric(*a, out); };
       }},
      {"calib colour", "3x3 colour match of the probe camera to a backplate camera",
       "lightprobe calib colour patches.csv -o colour.json\nlightprobe probe unwrap ball.exr --type mirrorball --colour-match colour.json -o map.exr",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<CalibColourArgs>();
         f.arg("PATCHES", a->patches, "CSV: probe_r,probe_g,probe_b,plate_r,plate_g,plate_b").required();
         f.output(a->output, "colour.json");
         return [a](const Output& out) { return run_calib_colour(*a, out); };
       }},
  };
}

}  // namespace lp::cli
