// eval calib: our geometric calibration next to OpenCV run alone (same detected corners),
// and a sweep over views and corner noise on synthetic corners with a known camera.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <algorithm>
#include <filesystem>
#include <limits>

#include "calib/board_detect.h"
#include "calib/geometric.h"
#include "calib/lens_model.h"
#include "calib/synthetic_boards.h"
#include "cli/commands.h"
#include "cli/eval_handlers.h"
#include "cli/report.h"
#include "eval/svg_chart.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/progress.h"

namespace lp::cli {

namespace {

namespace fs = std::filesystem;

nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Images -> our table and OpenCV's, side by side.
// speed_out: one solve of each of our models against its OpenCV peer (see below).
nlohmann::json compare_on_images(const EvalCalibArgs& args, const BoardSpec& board, const Output& out,
                                 nlohmann::json* speed_out) {
  std::vector<std::vector<std::array<double, 2>>> corners(args.images.size());
  int width = 0, height = 0, found = 0;
  Progress progress("detect boards", args.images.size(), out.progress);
  for (size_t i = 0; i < args.images.size(); ++i) {
    const CameraImage img = read_camera_image(args.images[i]);
    if (i == 0) {
      width = img.width;
      height = img.height;
    } else if (img.width != width || img.height != height) {
      throw InputError(fmt::format("{}: {}x{} differs from the first image's {}x{}", args.images[i], img.width,
                                   img.height, width, height));
    }
    const BoardDetection d = detect_board(img, board);
    if (d.found) {
      corners[i] = d.corners;
      ++found;
    }
    progress.advance();
  }
  progress.finish();
  if (found < 4)
    throw InputError(fmt::format("a {}x{} board was found in only {} of {} images; at least 4 views are needed",
                                 board.cols, board.rows, found, args.images.size()));
  const auto t0 = std::chrono::steady_clock::now();
  const CalibrationResult ours = calibrate(corners, board, width, height);
  const double ours_s = seconds_since(t0);
  const std::vector<PeerCalibration> peers = calibrate_opencv_alone(corners, board, width, height);

  std::string csv = "solver,model,ok,rms_px,cross_validation_px,seconds\n";
  nlohmann::json rows = nlohmann::json::array();
  say(out, "{} views with the board\n{:<34} {:<34} {:>8} {:>10} {:>9}\n", found, "solver", "model", "RMS px",
      "cross-val", "seconds");
  say(out, "{:<34} {:<34} {:>8.3f} {:>10.3f} {:>9.2f}  (whole selection, {} candidates, leverage, uncertainty)\n",
      "lightprobe (chosen)", ours.selected, ours.model.rms_reprojection_px, ours.cross_validation_px, ours_s,
      ours.table.size());
  csv += fmt::format("lightprobe,{},1,{},{},{}\n", ours.selected, ours.model.rms_reprojection_px,
                     ours.cross_validation_px, ours_s);
  rows.push_back({{"solver", "lightprobe"}, {"model", ours.selected}, {"ok", true},
                  {"rms_px", ours.model.rms_reprojection_px}, {"cross_validation_px", ours.cross_validation_px},
                  {"seconds", ours_s}});
  for (const ModelCandidate& c : ours.table) {
    if (!c.ok) continue;
    say(out, "{:<34} {:<34} {:>8.3f} {:>10.3f}\n", "lightprobe (candidate)", c.name, c.rms_px, c.cross_validation_px);
    csv += fmt::format("lightprobe candidate,{},1,{},{},\n", c.name, c.rms_px, c.cross_validation_px);
  }
  for (const PeerCalibration& p : peers) {
    if (p.ok)
      say(out, "{:<34} {:<34} {:>8.3f} {:>10.3f} {:>9.3f}{}\n", p.name + " alone", p.lensmodel, p.rms_px,
          p.cross_validation_px, p.seconds,
          p.views_posed < found ? fmt::format("  ({} of {} views posed)", p.views_posed, found) : "");
    else
      say(out, "{:<34} failed: {}\n", p.name + " alone", p.error);
    csv += fmt::format("{},{},{},{},{},{}\n", p.name, p.lensmodel, p.ok ? 1 : 0, p.rms_px, p.cross_validation_px,
                       p.seconds);
    rows.push_back({{"solver", p.name}, {"model", p.lensmodel}, {"ok", p.ok}, {"error", p.error},
                    {"rms_px", num(p.rms_px)}, {"cross_validation_px", num(p.cross_validation_px)},
                    {"seconds", p.seconds}, {"views_posed", p.views_posed}});
  }
  write_file_atomically((fs::path(args.output_dir) / "calib_compare.csv").string(), csv);

  // Speed, model for model: ONE solve of ours (OpenCV seed + re-posing + joint Ceres / mrcal
  // refinement, every corner) against the OpenCV calibrator of the same model alone on the
  // same corners, each the fastest of three interleaved runs (the machine is shared: a
  // slow run measures the other jobs), and the whole `--model NAME` command (outlier
  // rejection, halves, leverage, uncertainty) for scale.
  struct Pair {
    const char* peer;
    std::string ours;  // the candidate OpenCV's calibrator solves
  };
  const Pair pairs[] = {{"cv::fisheye", candidate_name(LensType::KannalaBrandt)},
                        {"cv::calibrateCamera plumb_bob", candidate_name(LensType::OpenCV5)},
                        {"cv::calibrateCamera rational", candidate_name(LensType::OpenCV8)},
                        {"cv::omnidir", candidate_name(LensType::OmnidirMei)}};
  constexpr int kPairs = 4, kRepeats = 3;
  double peer_s[kPairs], ours_s1[kPairs];
  SingleSolve ours_one[kPairs];
  std::fill(peer_s, peer_s + kPairs, std::numeric_limits<double>::infinity());
  std::fill(ours_s1, ours_s1 + kPairs, std::numeric_limits<double>::infinity());
  for (int rep = 0; rep < kRepeats; ++rep) {
    const auto again = rep == 0 ? peers : calibrate_opencv_alone(corners, board, width, height);
    for (int k = 0; k < kPairs; ++k) {
      for (const PeerCalibration& p : again)
        // The full-set solve counts even when a half failed (lensmodel set, cross-validation not).
        if (p.name == pairs[k].peer && !p.lensmodel.empty()) peer_s[k] = std::min(peer_s[k], p.seconds);
      const SingleSolve one = solve_model_once(corners, board, width, height, pairs[k].ours);
      if (one.ok) ours_s1[k] = std::min(ours_s1[k], one.seconds);
      if (rep == 0) ours_one[k] = one;
    }
  }
  say(out, "\nspeed, one solve on every corner (fastest of {}), and the whole --model command\n", kRepeats);
  say(out, "{:<26} {:<30} {:>9} {:>9} {:>9} {:>9} {:>7} {:>10}\n", "our model", "OpenCV peer", "ours RMS", "cv RMS",
      "ours 1 s", "cv s", "ratio", "--model s");
  nlohmann::json speed = nlohmann::json::array();
  std::string speed_csv = "model,peer,ours_rms_px,peer_rms_px,ours_one_solve_s,peer_s,ratio,model_command_s\n";
  for (int k = 0; k < kPairs; ++k) {
    const PeerCalibration* peer = nullptr;
    for (const PeerCalibration& p : peers)
      if (p.name == pairs[k].peer) peer = &p;
    const double peer_rms =
        peer && !peer->lensmodel.empty() ? peer->rms_px : std::numeric_limits<double>::quiet_NaN();
    CalibrateOptions forced;
    forced.model = pairs[k].ours;
    double command_s = std::numeric_limits<double>::quiet_NaN();
    try {
      const auto tc = std::chrono::steady_clock::now();
      calibrate(corners, board, width, height, forced);
      command_s = seconds_since(tc);
    } catch (const InputError&) {
    }
    const double ours_rms = ours_one[k].ok ? ours_one[k].rms_px : std::numeric_limits<double>::quiet_NaN();
    const double ratio = std::isfinite(ours_s1[k]) && std::isfinite(peer_s[k]) ? ours_s1[k] / peer_s[k]
                                                                                 : std::numeric_limits<double>::quiet_NaN();
    // "failed" where that solver found no model on the full set.
    auto cell = [](double x, int width, int digits) {
      return std::isfinite(x) ? fmt::format("{:>{}.{}f}", x, width, digits) : fmt::format("{:>{}}", "failed", width);
    };
    say(out, "{:<26} {:<30} {} {} {} {} {} {}\n", pairs[k].ours, pairs[k].peer, cell(ours_rms, 9, 3),
        cell(peer_rms, 9, 3), cell(ours_s1[k], 9, 3), cell(peer_s[k], 9, 3),
        std::isfinite(ratio) ? fmt::format("{:>7.2f}", ratio) : fmt::format("{:>7}", "-"), cell(command_s, 10, 2));
    speed_csv += fmt::format("{},{},{},{},{},{},{},{}\n", pairs[k].ours, pairs[k].peer, ours_rms, peer_rms, ours_s1[k],
                             peer_s[k], ratio, command_s);
    speed.push_back({{"model", pairs[k].ours}, {"peer", pairs[k].peer}, {"ours_rms_px", num(ours_rms)},
                     {"peer_rms_px", num(peer_rms)}, {"ours_one_solve_seconds", num(ours_s1[k])},
                     {"peer_seconds", num(peer_s[k])}, {"ratio", num(ratio)}, {"model_command_seconds", num(command_s)}});
  }
  write_file_atomically((fs::path(args.output_dir) / "calib_speed.csv").string(), speed_csv);
  *speed_out = speed;
  return rows;
}

// Synthetic sweep: a 190 deg Kannala-Brandt camera; boards up to 70 deg off the axis with
// every corner inside 88 deg (so that cv::fisheye, which cannot image rays beyond 90 deg,
// competes on equal terms), and one case with boards out to 93 deg. Error = RMS projection
// difference to the true model (rotation fitted out) over the pixels whose true ray is
// within the corners' field (the rim beyond is extrapolation for every solver alike),
// mean square over three noise draws.
nlohmann::json sweep(const EvalCalibArgs& args, const Output& out) {
  CameraModel truth;
  truth.lensmodel = lens_type_name(LensType::KannalaBrandt);
  truth.intrinsics = {330, 331, 641.3, 478.6, 0.02, -0.01, 0.003, -0.0005};
  truth.width = 1280;
  truth.height = 960;
  const BoardSpec board{10, 7, 40};
  struct Config {
    int views;
    double noise;
    double max_corner_deg = 88;
  };
  std::vector<Config> configs;
  for (int v : {4, 6, 8, 12, 16, 20}) configs.push_back({v, 0.2});
  for (double n : {0.05, 0.1, 0.5}) configs.push_back({12, n});  // 0.2 is in the first list
  configs.push_back({12, 0.2, 93});
  // Pixels whose true ray is within a field, every 16 px.
  auto field_mask = [&](double deg) {
    std::vector<uint8_t> m(size_t(truth.width) * truth.height, 0);
    for (int y = 0; y < truth.height; ++y)
      for (int x = 0; x < truth.width; ++x) {
        const auto d = unproject(truth, {double(x), double(y)});
        m[size_t(y) * truth.width + x] = d && std::acos(std::clamp(d->z, -1.0, 1.0)) <= deg * M_PI / 180;
      }
    return m;
  };
  const std::vector<uint8_t> mask88 = field_mask(88), mask93 = field_mask(93);
  const int draws = 3;
  struct Row {
    Config c;
    double ours = 0, ours_kb = 0, cv_fisheye = 0, cv_rational = 0, ours_s = 0, ours_kb_s = 0, cv_fisheye_s = 0;
    double ours_kb_one_s = 0;  // one solve (solve_model_once), against cv_fisheye_s
  };
  std::vector<Row> rows;
  Progress progress("calibration sweep", configs.size() * draws, out.progress);
  for (const Config& c : configs) {
    Row r{c};
    int ok[4] = {0, 0, 0, 0};
    for (int d = 0; d < draws; ++d) {
      const auto views =
          project_board_views(truth, board, c.views, c.max_corner_deg > 90 ? 80 : 70, 600, c.noise, 100 + d,
                              c.max_corner_deg);
      const auto& mask = c.max_corner_deg > 90 ? mask93 : mask88;
      auto err = [&](const CameraModel& m) {
        const ProjectionDiff pd = projection_difference(m, truth, mask, 16);
        return pd.samples > 0 ? pd.rms_px : std::numeric_limits<double>::infinity();
      };
      CalibrateOptions sel;
      sel.leverage = false;
      sel.uncertainty = false;
      auto t0 = std::chrono::steady_clock::now();
      try {
        const CalibrationResult a = calibrate(views, board, truth.width, truth.height, sel);
        r.ours_s += seconds_since(t0);
        r.ours += std::pow(err(a.model), 2);
        ++ok[0];
      } catch (const InputError&) {
      }
      sel.model = candidate_name(LensType::KannalaBrandt);
      t0 = std::chrono::steady_clock::now();
      try {
        const CalibrationResult b = calibrate(views, board, truth.width, truth.height, sel);
        r.ours_kb_s += seconds_since(t0);
        r.ours_kb += std::pow(err(b.model), 2);
        ++ok[1];
      } catch (const InputError&) {
      }
      // One KB solve of ours right next to cv::fisheye's, on the same corners.
      const SingleSolve one = solve_model_once(views, board, truth.width, truth.height, sel.model);
      r.ours_kb_one_s += one.seconds;
      for (const PeerCalibration& p : calibrate_opencv_alone(views, board, truth.width, truth.height, 16)) {
        if (!p.ok) continue;
        if (p.name == "cv::fisheye") {
          r.cv_fisheye += std::pow(err(p.model), 2);
          r.cv_fisheye_s += p.seconds;
          ++ok[2];
        } else if (p.name == "cv::calibrateCamera rational") {
          r.cv_rational += std::pow(err(p.model), 2);
          ++ok[3];
        }
      }
      progress.advance();
    }
    auto finish = [](double sum, int n) { return n ? std::sqrt(sum / n) : std::numeric_limits<double>::quiet_NaN(); };
    r.ours = finish(r.ours, ok[0]);
    r.ours_kb = finish(r.ours_kb, ok[1]);
    r.cv_fisheye = finish(r.cv_fisheye, ok[2]);
    r.cv_rational = finish(r.cv_rational, ok[3]);
    r.ours_s /= std::max(1, ok[0]);
    r.ours_kb_s /= std::max(1, ok[1]);
    r.ours_kb_one_s /= draws;
    r.cv_fisheye_s /= std::max(1, ok[2]);
    rows.push_back(r);
  }
  progress.finish();
  std::string csv = "views,noise_px,max_corner_deg,ours_selected_px,ours_kb_px,cv_fisheye_px,cv_rational_px,ours_s,ours_kb_s,ours_kb_one_solve_s,cv_fisheye_s\n";
  say(out, "{:>5} {:>6} {:>7} {:>14} {:>10} {:>14} {:>14} {:>8} {:>10} {:>9} {:>8}\n", "views", "noise", "field",
      "ours (chosen)", "ours KB", "cv::fisheye", "cv rational", "ours s", "KB cmd s", "KB 1 s", "cv s");
  nlohmann::json j = nlohmann::json::array();
  for (const Row& r : rows) {
    say(out, "{:>5} {:>6.2f} {:>7.0f} {:>14.3f} {:>10.3f} {:>14.3f} {:>14.3f} {:>8.2f} {:>10.3f} {:>9.3f} {:>8.3f}\n",
        r.c.views, r.c.noise, r.c.max_corner_deg, r.ours, r.ours_kb, r.cv_fisheye, r.cv_rational, r.ours_s,
        r.ours_kb_s, r.ours_kb_one_s, r.cv_fisheye_s);
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", r.c.views, r.c.noise, r.c.max_corner_deg, r.ours, r.ours_kb,
                       r.cv_fisheye, r.cv_rational, r.ours_s, r.ours_kb_s, r.ours_kb_one_s, r.cv_fisheye_s);
    j.push_back({{"views", r.c.views}, {"noise_px", r.c.noise}, {"max_corner_deg", r.c.max_corner_deg},
                 {"ours_selected_px", num(r.ours)},
                 {"ours_kb_px", num(r.ours_kb)}, {"cv_fisheye_px", num(r.cv_fisheye)},
                 {"cv_rational_px", num(r.cv_rational)}, {"ours_seconds", r.ours_s}, {"ours_kb_seconds", r.ours_kb_s},
                 {"ours_kb_one_solve_seconds", r.ours_kb_one_s},
                 {"cv_fisheye_seconds", r.cv_fisheye_s}});
  }
  write_file_atomically((fs::path(args.output_dir) / "calib_sweep.csv").string(), csv);
  // Chart: error vs views (noise 0.2 px), error vs noise (12 views).
  ChartPanel by_views{"0.2 px corner noise", "views", "RMS error vs truth, px", {}, false, true};
  ChartPanel by_noise{"12 views", "corner noise, px", "RMS error vs truth, px", {}, true, true};
  const char* names[4] = {"ours (chosen model)", "ours, Kannala-Brandt", "cv::fisheye alone", "cv rational alone"};
  for (int k = 0; k < 4; ++k) {
    ChartSeries sv{names[k], {}, {}, {}, true}, sn{names[k], {}, {}, {}, true};
    for (const Row& r : rows) {
      const double e = k == 0 ? r.ours : k == 1 ? r.ours_kb : k == 2 ? r.cv_fisheye : r.cv_rational;
      if (!std::isfinite(e)) continue;
      if (r.c.max_corner_deg > 90) continue;  // in the table only
      if (r.c.noise == 0.2) {
        sv.x.push_back(r.c.views);
        sv.y.push_back(e);
      }
      if (r.c.views == 12) {
        sn.x.push_back(r.c.noise);
        sn.y.push_back(e);
      }
    }
    // noise column sorted (0.2 comes first in the rows)
    std::vector<size_t> order(sn.x.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return sn.x[a] < sn.x[b]; });
    ChartSeries sorted{names[k], {}, {}, {}, true};
    for (size_t i : order) {
      sorted.x.push_back(sn.x[i]);
      sorted.y.push_back(sn.y[i]);
    }
    by_views.series.push_back(sv);
    by_noise.series.push_back(sorted);
  }
  write_file_atomically((fs::path(args.output_dir) / "calib_sweep.svg").string(),
                        svg_chart("Synthetic 190 deg Kannala-Brandt camera, corners within 88 deg: error against the true model",
                                  {by_views, by_noise}));
  return j;
}

}  // namespace

int run_eval_calib(const EvalCalibArgs& args, const Output& out) {
  int cols = 0, rows = 0;
  parse_size(args.board, "--board", &cols, &rows);
  if (cols < 2 || rows < 2) throw InputError("--board counts inner corners and needs at least 2x2");
  if (!(args.square_mm > 0)) throw InputError("--square must be positive (mm)");
  if (args.images.empty() && !args.sweep) throw InputError("eval calib: give chessboard images, --sweep, or both");
  make_output_directory(args.output_dir);
  nlohmann::json report = {{"output", args.output_dir}};
  if (!args.images.empty()) {
    nlohmann::json speed;
    report["compare"] = compare_on_images(args, BoardSpec{cols, rows, args.square_mm}, out, &speed);
    report["speed"] = speed;
  }
  if (args.sweep) report["sweep"] = sweep(args, out);
  emit_json(out, report);
  return 0;
}

}  // namespace lp::cli
