// calib geometric|compare|photometric|colour: chessboard calibration with model selection
// by cross-validation, the projection difference of two models, absolute and colour scales.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>

#include "calib/calibration_run.h"
#include "calib/camera_model.h"
#include "calib/colour_match.h"
#include "calib/corners_vnl.h"
#include "calib/photometric.h"
#include "calib/vignetting.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/warnings.h"
#include "core/heap_tuning.h"
#include "core/progress.h"
#include "core/sensor_white_level.h"
#include "eval/svg_chart.h"
#include "hdr/bracket.h"
#include "hdr/raw_input.h"

namespace lp::cli {

struct CalibGeometricArgs {
  std::vector<std::string> images;
  std::string board;                // COLSxROWS inner corners
  double square_mm = 0;
  std::string model;                // override the selection
  bool no_mrcal = false;
  std::string board_warp = "auto";  // fit the board's flex (mrcal's calobject_warp): auto, on, off
  std::string report_dir;           // pictures; default beside the output
  std::string output;               // camera.cameramodel or camera.yaml
  int drop_influential = 0;         // recalibrate without up to N flagged views, worst first
  std::string corners_in, corners_out, imagersize;  // mrcal's corners.vnl; W,H for corners_in
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

struct CalibVignettingArgs {
  std::vector<std::string> flats;   // flat fields of one camera and lens setting
  std::string codes;                // camera images: srgb (8-bit default), linear, or a response.json
  int terms = 0;                    // 0: the fewest the flats support
  std::string output;
};

struct CalibColourArgs {
  std::string patches;              // CSV probe_r,probe_g,probe_b,plate_r,plate_g,plate_b
  std::string output;
};

namespace fs = std::filesystem;

int run_calib_geometric(const CalibGeometricArgs& args, const Output& out) {
  const BoardSpec board = board_from(args.board, args.square_mm);
  if (args.drop_influential < 0) throw InputError("--drop-influential must be 0 or more");
  check_calibration_output(args.output, args.model);
  keep_heap_for_reuse();
  GeometricCalibrationOptions o;
  o.calibrate.model = args.model;
  o.calibrate.use_mrcal = !args.no_mrcal;
  o.calibrate.board_warp = args.board_warp != "off";
  o.calibrate.board_warp_auto = args.board_warp == "auto";
  o.calibrate.progress = stage_progress_bars("solve: ", out.progress);
  o.drop_influential = args.drop_influential;
  if (args.images.empty() == args.corners_in.empty()) throw InputError("give either IMAGE... or --corners-in");
  // Checked before the solve: a file there ended the run with an internal error after the
  // camera file was written.
  if (std::error_code ec; !args.report_dir.empty() && fs::exists(args.report_dir, ec) && !fs::is_directory(args.report_dir, ec))
    throw InputError(fmt::format("--report {}: a file is there; it names a directory for the pictures", args.report_dir));
  // The images say their size: --imagersize is for a corners.vnl whose images are not at hand.
  if (!args.imagersize.empty() && !args.images.empty())
    throw InputError("--imagersize is for --corners-in without the images; the images give their own size");
  // --corners-out over one of the inputs: `--corners-out imgs/*.jpg` took the first image's
  // name and overwrote the photo with corner text; over --corners-in it dropped what it held.
  if (!args.corners_out.empty()) {
    std::error_code ec;
    auto same = [&](const std::string& other) { return other == args.corners_out || fs::equivalent(other, args.corners_out, ec); };
    for (const std::string& image : args.images)
      if (same(image)) throw InputError(fmt::format("--corners-out {} is one of the images", args.corners_out));
    if (!args.corners_in.empty() && same(args.corners_in))
      throw InputError(fmt::format("--corners-out {} is the --corners-in file; write the corners elsewhere", args.corners_out));
    if (is_camera_image_file(args.corners_out) || is_radiance_file(args.corners_out))
      throw InputError(fmt::format("--corners-out {}: the corners are text (mrcal's corners.vnl), not an image", args.corners_out));
  }
  const std::vector<double> size = args.imagersize.empty() ? std::vector<double>{0, 0} : parse_numbers(args.imagersize, "--imagersize", 2);
  Progress detected("detect boards", args.images.size(), out.progress);
  CornersFile corners = !args.corners_in.empty() ? read_corners_vnl(args.corners_in, board, size[0], size[1])
                                                 : CornersFile{detect_boards(args.images, board, o.detect, [&] { detected.advance(); }), {}};
  detected.finish();
  if (const BoardDetections& d = corners.detections; d.reoriented > 0)
    corners.notes.push_back(fmt::format("{} of the {} images were shot turned another way (EXIF Orientation): their "
                                        "corners were turned into the frame of the others ({}x{}, Orientation {})",
                                        d.reoriented, d.images.size(), d.width, d.height, d.orientation));
  if (!args.corners_out.empty()) {
    write_corners_vnl(args.corners_out, corners.detections);
    if (corners.detections.turned > 0)  // right for lightprobe and mrcal's solves; not for drawing on the files
      warn(fmt::format("{}: {} of the {} images were turned by their EXIF Orientation: the corners are in the images "
                       "as {}, and mrcal's tools that draw on the image files load them as stored",
                       args.corners_out, corners.detections.turned, corners.detections.images.size(),
                       corners.detections.reoriented > 0 ? "most of them are shown" : "shown"));
  }
  GeometricCalibration run = calibrate_detections(std::move(corners.detections), board, o);
  run.notes.insert(run.notes.begin(), corners.notes.begin(), corners.notes.end());
  write_calibration_files(run, args.output, args.report_dir);
  say(out, "{}", run.summary());
  if (out.json) std::printf("%s\n", run.to_json().c_str());
  return 0;
}

int run_calib_compare(const CalibCompareArgs& args, const Output& out) {
  // How far two calibrations of one camera disagree, in pixels over the whole image, with
  // the rotation between their camera frames fitted out (what cross-validation measures).
  const CameraModel a = read_camera_model(args.a), b = read_camera_model(args.b);
  if (a.width != b.width || a.height != b.height)
    throw InputError(fmt::format("{} is for {}x{}, {} for {}x{}", args.a, a.width, a.height, args.b, b.width, b.height));
  // --step 0 or -7 ran as 1 without a word; one so coarse that fewer than 3 samples fit the
  // rotation printed "(rotation fitted out)" over an unfitted one.
  if (args.step_px < 1 || args.step_px > std::min(a.width, a.height) / 3)
    throw InputError(fmt::format("--step must be 1..{} px (a third of the {}x{} image's shorter side), got {}",
                                 std::max(1, std::min(a.width, a.height) / 3), a.width, a.height, args.step_px));
  std::vector<uint8_t> mask(size_t(a.width) * size_t(a.height), 1);
  const ProjectionDiff d = projection_difference(a, b, mask, args.step_px, !args.no_rotation);
  if (d.samples < (args.no_rotation ? 1 : 3))  // an RMS over nothing is no agreement
    throw InputError(fmt::format("{} vs {}: {} pixels of the {}x{} image (every {} px) image a ray both models can "
                                 "project, too few to compare{}",
                                 args.a, args.b, d.samples, a.width, a.height, args.step_px,
                                 args.no_rotation ? "" : " with the rotation fitted out"));
  say(out, "{} vs {}: RMS {:.3f} px, median {:.3f} px, max {:.3f} px over {} samples{}\n", args.a, args.b, d.rms_px,
      d.median_px, d.max_px, d.samples, args.no_rotation ? "" : " (rotation fitted out)");
  emit_json(out, {{"rms_px", d.rms_px}, {"median_px", d.median_px}, {"max_px", d.max_px}, {"samples", d.samples}});
  return 0;
}

int run_calib_photometric(const CalibPhotometricArgs& args, const Output& out) {
  auto readings = read_readings_csv(args.readings);
  resolve_regions(readings, fs::path(args.readings).parent_path().string());
  PhotometricOptions o;
  o.model = args.model == "log" ? PhotometricOptions::Model::LogSensor : PhotometricOptions::Model::Linear;  // one_of
  o.loss = args.loss == "huber" ? RobustLoss::Huber : args.loss == "cauchy" ? RobustLoss::Cauchy : RobustLoss::None;
  // hdr fuse and the stream decode a log sensor's codes as they are read, in [0, 1]: a curve
  // fitted on 8-bit codes 0..255 decoded every frame to a flat map, with exit 0.
  if (o.model == PhotometricOptions::Model::LogSensor)
    for (const PhotometricReading& r : readings)
      if (!(r.camera_value >= 0 && r.camera_value <= 1))
        throw InputError(fmt::format("{}: camera value {:g} of '{}' is not a code in [0, 1]; a log sensor's codes are "
                                     "given as read (8-bit 51 is 51/255 = 0.2)",
                                     args.readings, r.camera_value, r.label));
  const PhotometricCalibration cal = fit_photometric(readings, o);
  // Readings that contradict each other give a k (or a curve) all the same: refused, not
  // saved. A log sensor's value cannot fall as the light rises; and when the typical reading,
  // predicted from the others, is off by more than half, no k describes them (one wild
  // reading moves the median little: the robust fit keeps k, and that reading is named).
  if (cal.log_sensor && !(cal.log_sensor->b > 0))
    throw InputError(fmt::format("{}: the fitted camera value falls as the luminance rises (b = {:.3g}): no log sensor "
                                 "responds so; check the readings' columns",
                                 args.readings, cal.log_sensor->b));
  std::vector<double> held;
  const PhotometricResidual* worst = nullptr;
  for (const PhotometricResidual& r : cal.residuals) {
    held.push_back(std::abs(r.held_out_relative));
    if (!worst || std::abs(r.held_out_relative) > std::abs(worst->held_out_relative)) worst = &r;
  }
  std::nth_element(held.begin(), held.begin() + long(held.size() / 2), held.end());
  constexpr double kMaxMedianHeldOut = 0.5;
  if (!held.empty() && held[held.size() / 2] > kMaxMedianHeldOut)
    throw InputError(fmt::format("{}: the readings contradict each other: predicted from the others, the median reading "
                                 "is off by {:.0f} % (worst '{}', {:+.0f} %); check units, columns and regions",
                                 args.readings, 100 * held[held.size() / 2], worst->label,
                                 100 * worst->held_out_relative));
  if (worst && std::abs(worst->held_out_relative) > kMaxMedianHeldOut)
    warn(fmt::format("{}: reading '{}' is off by {:+.0f} % from what the others predict; the fit ({} loss) {}",
                     args.readings, worst->label, 100 * worst->held_out_relative, cal.loss,
                     cal.loss == "none" ? "is pulled by it: consider --loss huber" : "weighs it down"));
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

// One flat field as linear luminance: codes through --codes, and NaN where a channel is at the
// top code (clipped: its light is unknown) or the file marks no data. Read as stored: the model
// is in the sensor's frame (calib/vignetting.h). `white_level`: 16-bit flats of a sensor of
// fewer bits (Mono12 saved as 16-bit) clip at its white level, not at 65535.
FlatField read_flat(const std::string& path, const std::optional<CodeCurve>& codes, SequenceWhiteLevel& white_level,
                    double* f_number) {
  // A RAW flat is the best one: linear, and before any in-camera vignetting correction, which
  // most cameras apply to their JPEGs.
  const bool raw = is_camera_raw_file(path);
  RawExposure raw_settings;
  RgbImage img = raw ? read_camera_raw(path, &raw_settings) : read_rgb_image(path, true);
  *f_number = raw ? raw_settings.f_number : is_camera_image_file(path) ? read_exif_exposure(path).f_number : 0.0;
  if (img.vignetting_corrected)
    throw InputError(path + ": its vignetting is corrected already; a flat field measures it on the camera's own output");
  const size_t n = size_t(img.width) * size_t(img.height);
  std::vector<char> clipped(n, 0);
  auto mark_clipped = [&](float top) {
    for (size_t i = 0; i < n; ++i) clipped[i] = std::max({img.rgb[3 * i], img.rgb[3 * i + 1], img.rgb[3 * i + 2]}) >= top;
  };
  if (raw) {  // linear 16-bit codes; LibRaw clips highlights to its top code in every channel
    if (codes) warn(fmt::format("{}: a RAW file is linear; --codes is not used for it", path));
    mark_clipped(65534.0f / 65535.0f);
  } else if (img.code_bits > 0) {
    require_curve_for_deep_codes(img, codes.has_value(), path);
    if (img.code_bits == 16) img.code_bits = white_level.read(img.rgb, path);
    mark_clipped(1.0f - 0.5f / float((1 << img.code_bits) - 1));
    linearise_codes(img, codes.value_or(CodeCurve{}), path);
  } else if (codes) {
    warn(fmt::format("{}: radiance already; --codes applies to camera images and is not used", path));
  }
  FlatField f{img.width, img.height, std::vector<float>(n), path};
  for (size_t i = 0; i < n; ++i) {
    const float* p = &img.rgb[3 * i];
    const bool usable = !clipped[i] && (img.valid.empty() || img.valid[i]);
    f.luminance[i] = usable ? float(0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) : std::nanf("");
  }
  return f;
}

int run_calib_vignetting(const CalibVignettingArgs& args, const Output& out) {
  if (args.terms < 0 || args.terms > VignettingModel::kMaxTerms)
    throw InputError(fmt::format("--terms must be 0 (the fewest the flats support) to {}", VignettingModel::kMaxTerms));
  // The picture is written beside the file as .svg: an output named so would be overwritten.
  if (fs::path(args.output).extension() == ".svg")
    throw InputError(fmt::format("-o {}: name the calibration (vignetting.json); its picture is written beside it as "
                                 ".svg",
                                 args.output));
  const auto t0 = std::chrono::steady_clock::now();
  std::optional<CodeCurve> codes;
  if (!args.codes.empty()) codes = code_curve(args.codes);
  std::vector<FlatField> flats;
  std::vector<double> f_numbers(args.flats.size(), 0.0);
  {  // a RAW flat takes LibRaw about a second to develop
    Progress progress("calib vignetting", args.flats.size(), out.progress && args.flats.size() > 1);
    SequenceWhiteLevel white_level;
    for (size_t k = 0; k < args.flats.size(); ++k) {
      flats.push_back(read_flat(args.flats[k], codes, white_level, &f_numbers[k]));
      progress.advance();
    }
    progress.finish();
  }
  // One aperture: a lens's falloff changes with it, and flats of two would fit neither.
  double f_number = 0;
  std::string f_number_file;
  for (size_t k = 0; k < args.flats.size(); ++k) {
    const std::string& path = args.flats[k];
    const double f = f_numbers[k];
    if (!(f > 0)) continue;
    if (f_number > 0 && std::abs(std::log2(f / f_number)) > 1.0 / 12 + 1e-9)
      throw InputError(fmt::format("{}: taken at f/{:g}, but {} at f/{:g}: vignetting changes with the aperture; "
                                   "calibrate each aperture from its own flats",
                                   path, f, f_number_file, f_number));
    if (!(f_number > 0)) f_number = f, f_number_file = path;
  }
  VignettingFitOptions o;
  o.terms = args.terms;
  VignettingModel m = fit_vignetting(flats, o);
  m.f_number = f_number;
  const double ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Light that falls off across a flat (a lamp to one side) is nearly the same as a falloff
  // about another centre, and a single flat cannot tell them apart: a 20 % gradient moved the
  // centre by 9 % of the half-diagonal with a residual of 0.6 %. Lenses sit closer to the
  // middle than that; flats turned about the axis average a gradient out.
  constexpr double kFarCentre = 0.05;
  const double off_centre = std::hypot(m.centre[0] - (m.image_width - 1) / 2.0, m.centre[1] - (m.image_height - 1) / 2.0);
  if (m.centre_from == "fit" && off_centre > kFarCentre * m.radius_px)
    warn(fmt::format("{}: the falloff's centre is {:.0f} px ({:.0f} % of the half-diagonal) from the image's: light "
                     "that is not even across the flats looks like this; turn the camera about its axis between flats",
                     args.flats.front(), off_centre, 100 * off_centre / m.radius_px));
  constexpr double kUnevenRms = 0.02;
  if (m.rms_relative > kUnevenRms)
    warn(fmt::format("{}: the flats depart from one smooth falloff by {:.1f} % RMS: uneven light, a textured target "
                     "or flats that disagree; the correction is no better than that",
                     args.flats.front(), 100 * m.rms_relative));

  // The picture: every block's level against r, and the fitted curve.
  const fs::path chart_path = fs::path(args.output).replace_extension(".svg");
  ChartPanel panel{"relative illumination V against r (1 = half the image diagonal)", "r", "V", {}, false, false};
  ChartSeries blocks{"blocks of the flats (each over its own scale)", {}, {}, {}, false};
  for (const VignettingSample& s : vignetting_samples(flats, m, 3000)) {
    blocks.x.push_back(std::max(s.r, 1e-3));
    blocks.y.push_back(s.value);
  }
  ChartSeries curve{fmt::format("fit, {} term{}", m.terms, m.terms == 1 ? "" : "s"), {}, {}, {}, true};
  for (int i = 0; i <= 100; ++i) {
    const double r = std::max(1e-3, m.max_radius * i / 100.0);
    curve.x.push_back(r);
    curve.y.push_back(relative_illumination(m, m.centre[0] + r * m.radius_px, m.centre[1]));
  }
  panel.series = {blocks, curve};
  // Residuals show what the curve hides: dust (single low blocks), uneven light (a band).
  ChartPanel misfit{"block over the fit, minus 1 (%)", "r", "%", {}, false, false};
  ChartSeries residual{"blocks of the flats (each over its own scale)", {}, {}, {}, false};
  for (size_t i = 0; i < blocks.x.size(); ++i) {
    residual.x.push_back(blocks.x[i]);
    const double at = relative_illumination(m, m.centre[0] + blocks.x[i] * m.radius_px, m.centre[1]);
    residual.y.push_back(100 * (blocks.y[i] / at - 1));
  }
  misfit.series = {residual};
  save_vignetting(args.output, m);
  write_file_atomically(chart_path.string(), svg_chart("Vignetting of " + args.output, {panel, misfit}, 1));

  const double v_edge = relative_illumination(m, m.centre[0] + m.max_radius * m.radius_px, m.centre[1]);
  std::string poly = "1";
  for (int t = 0; t < m.terms; ++t)
    poly += fmt::format(" {} {:.4g} r^{}", m.k[size_t(t)] < 0 ? "-" : "+", std::abs(m.k[size_t(t)]), 2 * t + 2);
  say(out, "{}: V = {} about ({:.1f}, {:.1f}) px ({}); at the measured edge, r = {:.2f} ({:.0f} px), V = {:.3f} "
           "({:+.2f} stops, +-{:.2f} %)\n",
      args.output, poly, m.centre[0], m.centre[1], m.centre_from == "fit" ? "fitted" : "the image centre: too little falloff to place it",
      m.max_radius, m.max_radius * m.radius_px, v_edge, std::log2(v_edge), 100 * m.edge_sigma_relative);
  say(out, "{}: residual RMS {:.2f} % over {} blocks of {} flat{}{}; picture {}; {:.0f} ms\n", args.output,
      100 * m.rms_relative, m.blocks, m.flats, m.flats == 1 ? "" : "s",
      m.blocks_dropped ? fmt::format(", {} left out (dust, specks)", m.blocks_dropped) : std::string(),
      chart_path.string(), ms);
  emit_json(out, {{"output", args.output},
                  {"picture", chart_path.string()},
                  {"k", m.k},
                  {"terms", m.terms},
                  {"centre", m.centre},
                  {"centre_from", m.centre_from},
                  {"radius_px", m.radius_px},
                  {"max_radius", m.max_radius},
                  {"edge_relative_illumination", v_edge},
                  {"edge_sigma_relative", m.edge_sigma_relative},
                  {"rms_relative", m.rms_relative},
                  {"flats", m.flats},
                  {"blocks", m.blocks},
                  {"blocks_dropped", m.blocks_dropped},
                  {"f_number", m.f_number},
                  {"milliseconds", ms}});
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
       "lightprobe calib geometric views/*.jpg --board 9x6 --square 25 -o camera.cameramodel\nlightprobe calib geometric views/*.jpg --board 9x6 --square 25 --drop-influential 1 -o camera.cameramodel\nlightprobe calib geometric views/*.jpg --board 10x10 --square 25 --corners-out corners.vnl -o camera.cameramodel\nlightprobe calib geometric --corners-in corners.vnl --imagersize 1280,960 --board 10x10 --square 25 -o camera.cameramodel",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<CalibGeometricArgs>();
         f.arg("IMAGE", a->images, "Chessboard views (one camera, one resolution)");
         f.opt("--corners-in", a->corners_in, "Solve from mrcal's corners.vnl instead of images");
         f.opt("--corners-out", a->corners_out, "Write the detected corners as mrcal's corners.vnl");
         f.opt("--imagersize", a->imagersize, "W,H of the images of --corners-in (default: read one)");
         f.opt("--board", a->board, "COLSxROWS inner corners, e.g. 9x6").required();
         f.opt("--square", a->square_mm, "Square size, mm").required();
         f.opt("--model", a->model, "Use this model instead of the selection (see the printed table)");
         f.flag("--no-mrcal", a->no_mrcal, "OpenCV models only");
         f.opt("--board-warp", a->board_warp,
               "Fit the board's flex (mrcal's calobject_warp): auto (where it repays its two parameters over "
               "balanced splits of the views; always with fewer than 6 views), on, off")
             .one_of({"auto", "on", "off"});
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
         f.opt("--model", a->model, "linear|log").one_of({"linear", "log"});
         f.opt("--loss", a->loss, "Robust loss: huber|cauchy|none").one_of({"huber", "cauchy", "none"});
         f.output(a->output, "photometric.json");
         return [a](const Output& out) { return run_calib_photometric(*a, out); };
       }},
      {"calib vignetting", "Lens vignetting (relative illumination) from flat fields",
       "lightprobe calib vignetting flat_*.dng -o vignetting.json\nlightprobe hdr fuse IMG_*.jpg --vignetting vignetting.json -o probe.exr",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<CalibVignettingArgs>();
         f.arg("FLAT", a->flats, "Images of a uniformly lit, featureless field filling the view (a diffuser over the lens), unclipped; RAW files best (linear, before in-camera correction); several: the camera turned about its axis between them").required();
         f.opt("--codes", a->codes, "Camera images: how codes encode light: srgb (8-bit default), linear, or a response.json from hdr response; 16-bit images need it");
         f.opt("--terms", a->terms, "Even terms of the falloff polynomial, 1-5; 0: the fewest the flats support");
         f.output(a->output, "vignetting.json (and its picture, vignetting.svg)");
         return [a](const Output& out) { return run_calib_vignetting(*a, out); };
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
