#include "eval/calib_eval.h"

#include <cassert>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>

#include "calib/lens_model.h"
#include "calib/synthetic_boards.h"
#include "core/error.h"
#include "core/image_io.h"
#include "eval/svg_chart.h"

namespace lp {

namespace {

namespace fs = std::filesystem;
using Corners = std::vector<std::vector<std::array<double, 2>>>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The corners of every image with the board (empty for the others), and the image size.
struct Detected {
  Corners corners;
  int width = 0, height = 0, found = 0;
};

Detected detect(const std::vector<std::string>& images, const BoardSpec& board, ProgressSteps& progress) {
  Detected d;
  d.corners.resize(images.size());
  for (size_t i = 0; i < images.size(); ++i) {
    const CameraImage img = read_camera_image(images[i]);
    if (i == 0) {
      d.width = img.width;
      d.height = img.height;
    } else if (img.width != d.width || img.height != d.height) {
      throw InputError(fmt::format("{}: {}x{} differs from the first image's {}x{}", images[i], img.width, img.height,
                                   d.width, d.height));
    }
    const BoardDetection b = detect_board(img, board);
    if (b.found) {
      d.corners[i] = b.corners;
      ++d.found;
    }
    progress.advance();
  }
  if (d.found < 4)
    throw InputError(fmt::format("a {}x{} board was found in only {} of {} images; at least 4 views are needed",
                                 board.cols, board.rows, d.found, images.size()));
  return d;
}

// Speed, model for model: ONE solve of ours (OpenCV seed + re-posing + joint Ceres / mrcal
// refinement, every corner) against the OpenCV calibrator of the same model alone on the
// same corners, each the fastest of three interleaved runs (the machine is shared: a slow
// run measures the other jobs), and the whole `--model NAME` command (outlier rejection,
// halves, leverage, uncertainty) for scale.
std::vector<CalibComparison::Speed> measure_speed(const Detected& d, const BoardSpec& board,
                                                  const std::vector<PeerCalibration>& peers, int repeats) {
  struct Pair {
    const char* peer;
    std::string ours;  // the candidate OpenCV's calibrator solves
  };
  const Pair pairs[] = {{"cv::fisheye", candidate_name(LensType::KannalaBrandt)},
                        {"cv::calibrateCamera plumb_bob", candidate_name(LensType::OpenCV5)},
                        {"cv::calibrateCamera rational", candidate_name(LensType::OpenCV8)},
                        {"cv::omnidir", candidate_name(LensType::OmnidirMei)}};
  constexpr int kPairs = 4;
  double peer_s[kPairs], ours_s1[kPairs];
  SingleSolve ours_one[kPairs];
  std::fill(peer_s, peer_s + kPairs, kInf);
  std::fill(ours_s1, ours_s1 + kPairs, kInf);
  for (int rep = 0; rep < repeats; ++rep) {
    const auto again = rep == 0 ? peers : calibrate_opencv_alone(d.corners, board, d.width, d.height);
    for (int k = 0; k < kPairs; ++k) {
      for (const PeerCalibration& p : again)
        // The full-set solve counts even when a half failed (lensmodel set, cross-validation not).
        if (p.name == pairs[k].peer && !p.lensmodel.empty()) peer_s[k] = std::min(peer_s[k], p.seconds);
      const SingleSolve one = solve_model_once(d.corners, board, d.width, d.height, pairs[k].ours);
      if (one.ok) ours_s1[k] = std::min(ours_s1[k], one.seconds);
      if (rep == 0) ours_one[k] = one;
    }
  }
  std::vector<CalibComparison::Speed> speed;
  for (int k = 0; k < kPairs; ++k) {
    const PeerCalibration* peer = nullptr;
    for (const PeerCalibration& p : peers)
      if (p.name == pairs[k].peer) peer = &p;
    CalibrateOptions forced;
    forced.model = pairs[k].ours;
    double command_s = kNaN;
    try {
      const auto tc = std::chrono::steady_clock::now();
      calibrate(d.corners, board, d.width, d.height, forced);
      command_s = seconds_since(tc);
    } catch (const InputError&) {
    }
    const double ratio = std::isfinite(ours_s1[k]) && std::isfinite(peer_s[k]) ? ours_s1[k] / peer_s[k] : kNaN;
    speed.push_back({pairs[k].ours, pairs[k].peer, ours_one[k].ok ? ours_one[k].rms_px : kNaN,
                     peer && !peer->lensmodel.empty() ? peer->rms_px : kNaN, ours_s1[k], peer_s[k], ratio, command_s});
  }
  return speed;
}

CalibComparison compare_on_images(const EvalCalibOptions& o, ProgressSteps& progress) {
  const Detected d = detect(o.images, o.board, progress);
  CalibComparison c;
  c.views = d.found;
  const auto t0 = std::chrono::steady_clock::now();
  c.ours = calibrate(d.corners, o.board, d.width, d.height);
  c.ours_seconds = seconds_since(t0);
  c.peers = calibrate_opencv_alone(d.corners, o.board, d.width, d.height);
  c.speed = measure_speed(d, o.board, c.peers, c.speed_repeats);
  return c;
}

std::string compare_csv(const CalibComparison& c) {
  std::string csv = "solver,model,ok,rms_px,cross_validation_px,seconds\n";
  csv += fmt::format("lightprobe,{},1,{},{},{}\n", c.ours.selected, c.ours.model.rms_reprojection_px,
                     c.ours.cross_validation_px, c.ours_seconds);
  for (const ModelCandidate& m : c.ours.table)
    if (m.ok) csv += fmt::format("lightprobe candidate,{},1,{},{},\n", m.name, m.rms_px, m.cross_validation_px);
  for (const PeerCalibration& p : c.peers)
    csv += fmt::format("{},{},{},{},{},{}\n", p.name, p.lensmodel, p.ok ? 1 : 0, p.rms_px, p.cross_validation_px,
                       p.seconds);
  return csv;
}

std::string speed_csv(const CalibComparison& c) {
  std::string csv = "model,peer,ours_rms_px,peer_rms_px,ours_one_solve_s,peer_s,ratio,model_command_s\n";
  for (const CalibComparison::Speed& s : c.speed)
    csv += fmt::format("{},{},{},{},{},{},{},{}\n", s.model, s.peer, s.ours_rms_px, s.peer_rms_px,
                       s.ours_one_solve_seconds, s.peer_seconds, s.ratio, s.model_command_seconds);
  return csv;
}

std::string compare_text(const CalibComparison& c) {
  std::string s = fmt::format("{} views with the board\n{:<34} {:<34} {:>8} {:>10} {:>9}\n", c.views, "solver", "model",
                              "RMS px", "cross-val", "seconds");
  s += fmt::format("{:<34} {:<34} {:>8.3f} {:>10.3f} {:>9.2f}  (whole selection, {} candidates, leverage, uncertainty)\n",
                   "lightprobe (chosen)", c.ours.selected, c.ours.model.rms_reprojection_px, c.ours.cross_validation_px,
                   c.ours_seconds, c.ours.table.size());
  for (const ModelCandidate& m : c.ours.table)
    if (m.ok) s += fmt::format("{:<34} {:<34} {:>8.3f} {:>10.3f}\n", "lightprobe (candidate)", m.name, m.rms_px, m.cross_validation_px);
  for (const PeerCalibration& p : c.peers) {
    if (p.ok)
      s += fmt::format("{:<34} {:<34} {:>8.3f} {:>10.3f} {:>9.3f}{}\n", p.name + " alone", p.lensmodel, p.rms_px,
                       p.cross_validation_px, p.seconds,
                       p.views_posed < c.views ? fmt::format("  ({} of {} views posed)", p.views_posed, c.views) : "");
    else
      s += fmt::format("{:<34} failed: {}\n", p.name + " alone", p.error);
  }
  s += fmt::format("\nspeed, one solve on every corner (fastest of {}), and the whole --model command\n", c.speed_repeats);
  s += fmt::format("{:<26} {:<30} {:>9} {:>9} {:>9} {:>9} {:>7} {:>10}\n", "our model", "OpenCV peer", "ours RMS", "cv RMS",
                   "ours 1 s", "cv s", "ratio", "--model s");
  // "failed" where that solver found no model on the full set.
  auto cell = [](double x, int width, int digits) {
    return std::isfinite(x) ? fmt::format("{:>{}.{}f}", x, width, digits) : fmt::format("{:>{}}", "failed", width);
  };
  for (const CalibComparison::Speed& p : c.speed)
    s += fmt::format("{:<26} {:<30} {} {} {} {} {} {}\n", p.model, p.peer, cell(p.ours_rms_px, 9, 3),
                     cell(p.peer_rms_px, 9, 3), cell(p.ours_one_solve_seconds, 9, 3), cell(p.peer_seconds, 9, 3),
                     std::isfinite(p.ratio) ? fmt::format("{:>7.2f}", p.ratio) : fmt::format("{:>7}", "-"),
                     cell(p.model_command_seconds, 10, 2));
  return s;
}

// The sweep's camera: 190 deg Kannala-Brandt, 1280x960.
CameraModel sweep_truth() {
  CameraModel truth;
  truth.lensmodel = lens_type_name(LensType::KannalaBrandt);
  truth.intrinsics = {330, 331, 641.3, 478.6, 0.02, -0.01, 0.003, -0.0005};
  truth.width = 1280;
  truth.height = 960;
  return truth;
}

// Pixels whose true ray is within `deg` of the axis.
std::vector<uint8_t> field_mask(const CameraModel& truth, double deg) {
  std::vector<uint8_t> m(size_t(truth.width) * truth.height, 0);
  for (int y = 0; y < truth.height; ++y)
    for (int x = 0; x < truth.width; ++x) {
      const auto d = unproject(truth, {double(x), double(y)});
      m[size_t(y) * truth.width + x] = d && std::acos(std::clamp(d->z, -1.0, 1.0)) <= deg * M_PI / 180;
    }
  return m;
}

// One configuration (views, noise_px, max_corner_deg set in `r`) over `draws` noise draws.
void sweep_row(const CameraModel& truth, const std::vector<uint8_t>& mask, int draws, CalibSweepRow* r,
               ProgressSteps* progress) {
  const BoardSpec board{10, 7, 40};
  int ok[4] = {0, 0, 0, 0};
  for (int d = 0; d < draws; ++d) {
    const auto views = project_board_views(truth, board, r->views, r->max_corner_deg > 90 ? 80 : 70, 600, r->noise_px,
                                           100 + d, r->max_corner_deg);
    auto err = [&](const CameraModel& m) {
      const ProjectionDiff pd = projection_difference(m, truth, mask, 16);
      return pd.samples > 0 ? pd.rms_px : kInf;
    };
    // Our selection, then our Kannala-Brandt alone: squared error and time when it succeeds.
    CalibrateOptions sel;
    sel.leverage = false;
    sel.uncertainty = false;
    auto ours = [&](double* sq_error, double* seconds, int* successes) {
      const auto t0 = std::chrono::steady_clock::now();
      try {
        const CalibrationResult a = calibrate(views, board, truth.width, truth.height, sel);
        *seconds += seconds_since(t0);
        *sq_error += std::pow(err(a.model), 2);
        ++*successes;
      } catch (const InputError&) {
      }
    };
    ours(&r->ours_px, &r->ours_seconds, &ok[0]);
    sel.model = candidate_name(LensType::KannalaBrandt);
    ours(&r->ours_kb_px, &r->ours_kb_seconds, &ok[1]);
    // One KB solve of ours right next to cv::fisheye's, on the same corners.
    r->ours_kb_one_solve_seconds += solve_model_once(views, board, truth.width, truth.height, sel.model).seconds;
    for (const PeerCalibration& p : calibrate_opencv_alone(views, board, truth.width, truth.height, 16)) {
      if (!p.ok) continue;
      if (p.name == "cv::fisheye") {
        r->cv_fisheye_px += std::pow(err(p.model), 2);
        r->cv_fisheye_seconds += p.seconds;
        ++ok[2];
      } else if (p.name == "cv::calibrateCamera rational") {
        r->cv_rational_px += std::pow(err(p.model), 2);
        ++ok[3];
      }
    }
    progress->advance();
  }
  auto finish = [](double sum, int n) { return n ? std::sqrt(sum / n) : kNaN; };
  r->ours_px = finish(r->ours_px, ok[0]);
  r->ours_kb_px = finish(r->ours_kb_px, ok[1]);
  r->cv_fisheye_px = finish(r->cv_fisheye_px, ok[2]);
  r->cv_rational_px = finish(r->cv_rational_px, ok[3]);
  r->ours_seconds /= std::max(1, ok[0]);
  r->ours_kb_seconds /= std::max(1, ok[1]);
  r->ours_kb_one_solve_seconds /= draws;
  r->cv_fisheye_seconds /= std::max(1, ok[2]);
}

// The sweep's rows (below) and noise draws per row: its progress steps are their product.
constexpr size_t kSweepRows = 10, kSweepDraws = 3;

// Synthetic sweep: boards up to 70 deg off the axis with every corner inside 88 deg (so
// that cv::fisheye, which cannot image rays beyond 90 deg, competes on equal terms), and
// one case with boards out to 93 deg. Error = RMS projection difference to the true model
// (rotation fitted out) over the pixels whose true ray is within the corners' field (the
// rim beyond is extrapolation for every solver alike), mean square over three noise draws.
std::vector<CalibSweepRow> run_sweep(ProgressSteps& progress) {
  const CameraModel truth = sweep_truth();
  std::vector<CalibSweepRow> rows;
  for (int v : {4, 6, 8, 12, 16, 20}) rows.push_back({v, 0.2});
  for (double n : {0.05, 0.1, 0.5}) rows.push_back({12, n});  // 0.2 is in the first list
  rows.push_back({12, 0.2, 93});
  assert(rows.size() == kSweepRows);
  const std::vector<uint8_t> mask88 = field_mask(truth, 88), mask93 = field_mask(truth, 93);
  const int draws = kSweepDraws;
  for (CalibSweepRow& r : rows) sweep_row(truth, r.max_corner_deg > 90 ? mask93 : mask88, draws, &r, &progress);
  return rows;
}

std::string sweep_csv(const std::vector<CalibSweepRow>& rows) {
  std::string csv =
      "views,noise_px,max_corner_deg,ours_selected_px,ours_kb_px,cv_fisheye_px,cv_rational_px,ours_s,ours_kb_s,"
      "ours_kb_one_solve_s,cv_fisheye_s\n";
  for (const CalibSweepRow& r : rows)
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", r.views, r.noise_px, r.max_corner_deg, r.ours_px, r.ours_kb_px,
                       r.cv_fisheye_px, r.cv_rational_px, r.ours_seconds, r.ours_kb_seconds, r.ours_kb_one_solve_seconds,
                       r.cv_fisheye_seconds);
  return csv;
}

// Error against views (noise 0.2 px) and against noise (12 views); the 93 deg case is in
// the table only.
std::string sweep_chart(const std::vector<CalibSweepRow>& rows) {
  ChartPanel by_views{"0.2 px corner noise", "views", "RMS error vs truth, px", {}, false, true};
  ChartPanel by_noise{"12 views", "corner noise, px", "RMS error vs truth, px", {}, true, true};
  const char* names[4] = {"ours (chosen model)", "ours, Kannala-Brandt", "cv::fisheye alone", "cv rational alone"};
  double CalibSweepRow::*const errors[4] = {&CalibSweepRow::ours_px, &CalibSweepRow::ours_kb_px,
                                            &CalibSweepRow::cv_fisheye_px, &CalibSweepRow::cv_rational_px};
  for (int k = 0; k < 4; ++k) {
    ChartSeries sv{names[k], {}, {}, {}, true}, sn{names[k], {}, {}, {}, true};
    for (const CalibSweepRow& r : rows) {
      const double e = r.*errors[k];
      if (!std::isfinite(e) || r.max_corner_deg > 90) continue;
      if (r.noise_px == 0.2) {
        sv.x.push_back(r.views);
        sv.y.push_back(e);
      }
      if (r.views == 12) {
        sn.x.push_back(r.noise_px);
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
  return svg_chart("Synthetic 190 deg Kannala-Brandt camera, corners within 88 deg: error against the true model",
                   {by_views, by_noise});
}

std::string sweep_text(const std::vector<CalibSweepRow>& rows) {
  std::string s = fmt::format("{:>5} {:>6} {:>7} {:>14} {:>10} {:>14} {:>14} {:>8} {:>10} {:>9} {:>8}\n", "views", "noise",
                              "field", "ours (chosen)", "ours KB", "cv::fisheye", "cv rational", "ours s", "KB cmd s",
                              "KB 1 s", "cv s");
  for (const CalibSweepRow& r : rows)
    s += fmt::format("{:>5} {:>6.2f} {:>7.0f} {:>14.3f} {:>10.3f} {:>14.3f} {:>14.3f} {:>8.2f} {:>10.3f} {:>9.3f} {:>8.3f}\n",
                     r.views, r.noise_px, r.max_corner_deg, r.ours_px, r.ours_kb_px, r.cv_fisheye_px, r.cv_rational_px,
                     r.ours_seconds, r.ours_kb_seconds, r.ours_kb_one_solve_seconds, r.cv_fisheye_seconds);
  return s;
}

}  // namespace

void validate(const EvalCalibOptions& o) {
  if (o.board.cols < 2 || o.board.rows < 2) throw InputError("--board counts inner corners and needs at least 2x2");
  if (!(o.board.square_mm > 0)) throw InputError("--square must be positive (mm)");
  if (o.images.empty() && !o.sweep) throw InputError("eval calib: give chessboard images, --sweep, or both");
}

EvalCalibReport evaluate_calib(const EvalCalibOptions& options, const EvalProgress& on_progress) {
  validate(options);
  ProgressSteps progress(on_progress, (options.images.size()) + (options.sweep ? kSweepRows * kSweepDraws : 0));
  make_output_directory(options.output_dir);
  EvalCalibReport report;
  report.output_dir = options.output_dir;
  const fs::path dir(options.output_dir);
  if (!options.images.empty()) {
    report.comparison = compare_on_images(options, progress);
    write_file_atomically((dir / "calib_compare.csv").string(), compare_csv(*report.comparison));
    write_file_atomically((dir / "calib_speed.csv").string(), speed_csv(*report.comparison));
  }
  if (options.sweep) {
    report.sweep = run_sweep(progress);
    write_file_atomically((dir / "calib_sweep.csv").string(), sweep_csv(report.sweep));
    write_file_atomically((dir / "calib_sweep.svg").string(), sweep_chart(report.sweep));
  }
  return report;
}

std::string EvalCalibReport::summary() const {
  std::string s;
  if (comparison) s += compare_text(*comparison);
  if (!sweep.empty()) s += sweep_text(sweep);
  return s;
}

nlohmann::json EvalCalibReport::to_json() const {
  nlohmann::json j = {{"output", output_dir}};
  if (comparison) {
    const CalibComparison& c = *comparison;
    nlohmann::json rows = nlohmann::json::array();
    rows.push_back({{"solver", "lightprobe"}, {"model", c.ours.selected}, {"ok", true},
                    {"rms_px", c.ours.model.rms_reprojection_px}, {"cross_validation_px", c.ours.cross_validation_px},
                    {"seconds", c.ours_seconds}});
    for (const PeerCalibration& p : c.peers)
      rows.push_back({{"solver", p.name}, {"model", p.lensmodel}, {"ok", p.ok}, {"error", p.error},
                      {"rms_px", num(p.rms_px)}, {"cross_validation_px", num(p.cross_validation_px)},
                      {"seconds", p.seconds}, {"views_posed", p.views_posed}});
    nlohmann::json speed = nlohmann::json::array();
    for (const CalibComparison::Speed& p : c.speed)
      speed.push_back({{"model", p.model}, {"peer", p.peer}, {"ours_rms_px", num(p.ours_rms_px)},
                       {"peer_rms_px", num(p.peer_rms_px)}, {"ours_one_solve_seconds", num(p.ours_one_solve_seconds)},
                       {"peer_seconds", num(p.peer_seconds)}, {"ratio", num(p.ratio)},
                       {"model_command_seconds", num(p.model_command_seconds)}});
    j["compare"] = rows;
    j["speed"] = speed;
  }
  if (!sweep.empty()) {
    nlohmann::json rows = nlohmann::json::array();
    for (const CalibSweepRow& r : sweep)
      rows.push_back({{"views", r.views}, {"noise_px", r.noise_px}, {"max_corner_deg", r.max_corner_deg},
                      {"ours_selected_px", num(r.ours_px)}, {"ours_kb_px", num(r.ours_kb_px)},
                      {"cv_fisheye_px", num(r.cv_fisheye_px)}, {"cv_rational_px", num(r.cv_rational_px)},
                      {"ours_seconds", r.ours_seconds}, {"ours_kb_seconds", r.ours_kb_seconds},
                      {"ours_kb_one_solve_seconds", r.ours_kb_one_solve_seconds},
                      {"cv_fisheye_seconds", r.cv_fisheye_seconds}});
    j["sweep"] = rows;
  }
  return j;
}

}  // namespace lp
