// hdr response, hdr fuse, calib photometric, synth bracket, eval hdr: what a camera
// records -> radiance a probe can trust (absolute after photometric calibration).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <sstream>

#include "calib/photometric.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "eval/svg_chart.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "eval/synthetic_scene.h"
#include "hdr/align.h"
#include "hdr/bracket.h"
#include "hdr/deghost.h"
#include "hdr/hdr_accuracy.h"
#include "hdr/log_sensor.h"
#include "hdr/merge.h"
#include "hdr/opencv_peer.h"
#include "hdr/response.h"
#include "hdr/synthetic_bracket.h"

namespace lp::cli {

std::vector<double> parse_numbers(const std::string& text, const char* option, size_t count) {
  std::vector<double> v;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      size_t used = 0;
      // Fractions such as 1/40 are common for exposure times.
      const auto slash = item.find('/');
      double x;
      if (slash != std::string::npos) {
        size_t u2 = 0;
        const std::string a = item.substr(0, slash), b = item.substr(slash + 1);
        x = std::stod(a, &used) / std::stod(b, &u2);
        if (used != a.size() || u2 != b.size()) throw std::invalid_argument("x");
      } else {
        x = std::stod(item, &used);
        if (used != item.size()) throw std::invalid_argument("x");
      }
      if (!std::isfinite(x)) throw std::invalid_argument("x");
      v.push_back(x);
    } catch (const std::exception&) {
      throw InputError(fmt::format("{}: '{}' is not a number", option, item));
    }
  }
  if (v.empty() || (count && v.size() != count))
    throw InputError(count ? fmt::format("{} takes {} comma-separated numbers, got '{}'", option, count, text)
                           : fmt::format("{} is empty", option));
  return v;
}

namespace {

namespace fs = std::filesystem;

// --exposure-times: a list of seconds (1/40 allowed) or a file (one per line, or CSV).
std::optional<std::vector<double>> exposure_times(const std::string& text) {
  if (text.empty()) return std::nullopt;
  std::error_code ec;
  if (fs::is_regular_file(text, ec)) return read_exposure_list(text);
  return parse_numbers(text, "--exposure-times");
}

std::optional<std::array<uint8_t, 3>> ignore_colour(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const auto v = parse_numbers(text, "--ignore-colour", 3);
  std::array<uint8_t, 3> c{};
  for (int i = 0; i < 3; ++i) {
    if (v[size_t(i)] < 0 || v[size_t(i)] > 255) throw InputError("--ignore-colour takes 0..255 per channel");
    c[size_t(i)] = uint8_t(v[size_t(i)]);
  }
  return c;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int run_hdr_response(const HdrResponseArgs& args, const Output& out) {
  const Bracket bracket = read_bracket(args.images, exposure_times(args.exposure_times));
  const auto t0 = std::chrono::steady_clock::now();
  CameraResponse response;
  if (args.method == "debevec") {
    DebevecOptions o;
    o.lambda = args.lambda;
    o.ignore_colour = ignore_colour(args.ignore_colour);
    response = recover_debevec(bracket, o);
  } else if (args.method == "robertson") {
    RobertsonOptions o;
    o.ignore_colour = ignore_colour(args.ignore_colour);
    response = recover_robertson(bracket, o);
  } else {
    throw InputError(fmt::format("--method must be debevec or robertson, got '{}'", args.method));
  }
  const double ms = ms_since(t0);
  save_response(args.output, response);
  say(out, "{}: {} response from {} frames ({} levels) in {:.1f} ms\n", args.output, args.method,
      bracket.frames.size(), response.levels, ms);
  emit_json(out, {{"output", args.output}, {"method", args.method}, {"frames", bracket.frames.size()},
                  {"levels", response.levels}, {"milliseconds", ms}});
  return 0;
}

int run_hdr_fuse(const HdrFuseArgs& args, const Output& out) {
  std::optional<PhotometricCalibration> photometric;
  if (!args.photometric.empty()) photometric = load_photometric(args.photometric);
  nlohmann::json report = {{"output", args.output}};
  RgbImage radiance;
  const auto t0 = std::chrono::steady_clock::now();
  if (args.images.size() == 1 && photometric && photometric->log_sensor) {
    // A logarithmic sensor: one frame, decoded with the fitted value = a + b ln L.
    const RgbImage codes = read_rgb_image(args.images[0]);
    radiance = decode_log_sensor(codes, LogSensorModel{photometric->log_sensor->a, photometric->log_sensor->b});
    radiance.units = Units::Radiance;
    report["mode"] = "log-sensor";
  } else {
    Bracket bracket = read_bracket(args.images, exposure_times(args.exposure_times));
    CameraResponse response;
    if (!args.response.empty()) {
      response = load_response(args.response);
      report["response"] = args.response;
    } else if (args.linear || bracket.linear) {
      response = linear_response(bracket.bit_depth == 8 ? 256 : 1024);
      report["response"] = "linear";
    } else {
      DebevecOptions o;
      o.ignore_colour = ignore_colour(args.ignore_colour);
      response = recover_debevec(bracket, o);
      report["response"] = "recovered (Debevec-Malik) from this bracket";
    }
    if (args.align != "none") {
      AlignOptions ao;
      if (args.align == "mtb") ao.method = AlignOptions::Method::Mtb;
      else if (args.align == "ecc") ao.method = AlignOptions::Method::Ecc;
      else throw InputError(fmt::format("--align must be none, mtb or ecc, got '{}'", args.align));
      AlignReport ar;
      bracket.frames = align_frames(bracket.frames, bracket.exposure_seconds, ao, &ar);
      nlohmann::json shifts = nlohmann::json::array();
      for (const auto& s : ar.shift_per_frame) shifts.push_back({s[0], s[1], s[2]});
      report["alignment"] = shifts;
    }
    MergeOptions mo;
    mo.ignore_colour = ignore_colour(args.ignore_colour);
    mo.exposure_weighting = !args.no_exposure_weighting;
    if (args.deghost) {
      std::array<std::vector<float>, 3> g = response.log_exposure;
      mo.frame_masks = ghost_masks(bracket.frames, bracket.exposure_seconds, &g, {});
      const auto dropped = count_dropped(mo.frame_masks);
      report["ghost_pixels_dropped"] = dropped;
    }
    MergeReport mr;
    radiance = merge_bracket(bracket, response, mo, &mr);
    report["saturated_everywhere"] = mr.saturated_everywhere;
    report["black_everywhere"] = mr.black_everywhere;
    report["frames"] = bracket.frames.size();
    report["mode"] = "bracket";
    if (mr.saturated_everywhere)
      say(out, "{}: {} pixels are saturated in every frame (their radiance is a lower bound)\n", args.output,
          mr.saturated_everywhere);
  }
  if (photometric && !photometric->log_sensor) {
    apply_photometric(radiance, *photometric);
    report["units"] = "radiance";
  }
  write_rgb_image(args.output, radiance);
  const double ms = ms_since(t0);
  report["milliseconds"] = ms;
  say(out, "{}: {}x{} radiance ({}) in {:.0f} ms\n", args.output, radiance.width, radiance.height,
      to_string(radiance.units), ms);
  emit_json(out, report);
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

namespace {

ResponseCurve curve_from(const std::string& name) {
  if (name == "linear") return ResponseCurve::Linear;
  if (name == "gamma") return ResponseCurve::Gamma22;
  if (name == "scurve") return ResponseCurve::SCurve;
  throw InputError(fmt::format("--response must be linear, gamma or scurve, got '{}'", name));
}

RgbImage radiance_from(const std::string& path) {
  if (path == "scene") return image_from_envmap(render_scene(describe_scene(), Layout::LatLong, 512, 256));
  return read_rgb_image(path);
}

}  // namespace

int run_synth_bracket(const SynthBracketArgs& args, const Output& out) {
  SyntheticBracketOptions o;
  if (!args.exposure_times.empty()) o.exposure_seconds = parse_numbers(args.exposure_times, "--exposure-times");
  o.response = curve_from(args.response);
  o.add_noise = !args.no_noise;
  o.bit_depth = args.bit_depth;
  o.shake_px = args.shake_px;
  o.moving_object = args.moving_object;
  o.seed = args.seed;
  if (o.bit_depth != 8 && o.bit_depth != 16) throw InputError("--bit-depth must be 8 or 16");
  const SyntheticBracket b = make_synthetic_bracket(radiance_from(args.input), o);
  std::error_code ec;
  fs::create_directories(args.output_dir, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the output directory: {}", args.output_dir, ec.message()));
  std::string csv = "file,seconds\n";
  for (size_t f = 0; f < b.frames.size(); ++f) {
    const std::string name = fmt::format("frame_{:02d}.png", f);
    write_code_image((fs::path(args.output_dir) / name).string(), b.frames[f], o.bit_depth);
    csv += fmt::format("{},{:.9g}\n", name, b.exposure_seconds[f]);
  }
  write_file_atomically((fs::path(args.output_dir) / "exposures.csv").string(), csv);
  write_rgb_image((fs::path(args.output_dir) / "truth.exr").string(), b.true_radiance);
  CameraResponse truth;
  truth.levels = int(b.true_log_exposure[0].size());
  truth.log_exposure = b.true_log_exposure;
  save_response((fs::path(args.output_dir) / "true_response.json").string(), truth);
  say(out, "{}: {} frames ({}-bit, {} response{}{}), exposures.csv, truth.exr, true_response.json\n", args.output_dir,
      b.frames.size(), o.bit_depth, args.response, o.shake_px ? fmt::format(", shake {} px", o.shake_px) : "",
      o.moving_object ? ", moving object" : "");
  emit_json(out, {{"output", args.output_dir}, {"frames", b.frames.size()}});
  return 0;
}

int run_eval_hdr(const EvalHdrArgs& args, const Output& out) {
  std::error_code ec;
  fs::create_directories(args.output_dir, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the output directory: {}", args.output_dir, ec.message()));
  struct Row {
    std::string map, method;
    HdrError error;
    double recover_ms = 0, merge_ms = 0, floor_ms = 0;
  };
  std::vector<Row> rows;
  Progress progress("eval hdr", args.maps.size(), out.progress);
  for (const std::string& path : args.maps) {
    SyntheticBracketOptions o;
    o.response = curve_from(args.response);
    o.exposure_seconds = {1 / 64., 1 / 8., 1.};
    const SyntheticBracket sb = make_synthetic_bracket(radiance_from(path), o);
    Bracket bracket;
    bracket.frames = sb.frames;
    bracket.exposure_seconds = sb.exposure_seconds;
    CameraResponse truth;
    truth.levels = int(sb.true_log_exposure[0].size());
    truth.log_exposure = sb.true_log_exposure;
    // The memory floor: one pass over the bracket.
    double floor_ms = 1e30;
    for (int r = 0; r < 5; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      float s = 0;
      for (const auto& f : bracket.frames)
        for (float v : f.rgb) s += v;
      volatile float sink = s;
      (void)sink;
      floor_ms = std::min(floor_ms, ms_since(t0));
    }
    auto timed = [&](auto&& f) {
      double best = 1e30;
      for (int r = 0; r < 3; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        f();
        best = std::min(best, ms_since(t0));
      }
      return best;
    };
    const std::string name = path == "scene" ? "scene" : fs::path(path).stem().string();
    auto add = [&](const std::string& method, const RgbImage& est, double rec_ms, double merge_ms) {
      HdrError e;
      try {
        e = hdr_log_error(est, sb.true_radiance);
      } catch (const InputError&) {  // nothing usable in the estimate: a failure, recorded as such
        e.median_log10 = e.p95_log10 = std::nan("");
        e.pixels_invalid = size_t(est.width) * size_t(est.height);
      }
      rows.push_back({name, method, e, rec_ms, merge_ms, floor_ms});
    };
    RgbImage est;
    double merge_ms = timed([&] { est = merge_bracket(bracket, truth); });
    add("ours (true response)", est, 0, merge_ms);
    CameraResponse deb;
    double rec_ms = timed([&] { deb = recover_debevec(bracket); });
    merge_ms = timed([&] { est = merge_bracket(bracket, deb); });
    add("ours (Debevec)", est, rec_ms, merge_ms);
    CameraResponse rob;
    rec_ms = timed([&] { rob = recover_robertson(bracket); });
    merge_ms = timed([&] { est = merge_bracket(bracket, rob); });
    add("ours (Robertson)", est, rec_ms, merge_ms);
    double ms = 0;
    CameraResponse cvdeb, cvrob;
    rec_ms = timed([&] { cvdeb = opencv_recover_response(bracket, OpenCvHdrMethod::Debevec); });
    merge_ms = timed([&] { est = opencv_merge(bracket, OpenCvHdrMethod::Debevec, &cvdeb, &ms); });
    add("OpenCV Debevec", est, rec_ms, merge_ms);
    rec_ms = timed([&] { cvrob = opencv_recover_response(bracket, OpenCvHdrMethod::Robertson); });
    merge_ms = timed([&] { est = opencv_merge(bracket, OpenCvHdrMethod::Robertson, &cvrob, &ms); });
    add("OpenCV Robertson", est, rec_ms, merge_ms);
    merge_ms = timed([&] { est = opencv_merge(bracket, OpenCvHdrMethod::Robertson, &truth, &ms); });
    add("OpenCV MergeRobertson (true response)", est, 0, merge_ms);
    progress.advance();
  }
  progress.finish();

  std::string csv = "map,method,median_log10,p95_log10,invalid_pixels,recover_ms,merge_ms,merge_x_floor\n";
  for (const Row& r : rows)
    csv += fmt::format("{},{},{:.6g},{:.6g},{},{:.4g},{:.4g},{:.4g}\n", r.map, r.method, r.error.median_log10,
                       r.error.p95_log10, r.error.pixels_invalid, r.recover_ms, r.merge_ms, r.merge_ms / r.floor_ms);
  const std::string csv_path = (fs::path(args.output_dir) / "hdr.csv").string();
  write_file_atomically(csv_path, csv);
  std::map<std::string, ChartSeries> by_method;
  for (const Row& r : rows) {
    auto& s = by_method[r.method];
    s.name = r.method;
    s.x.push_back(r.recover_ms + r.merge_ms);
    s.y.push_back(r.error.p95_log10);
    s.labels.push_back(r.map);
  }
  ChartPanel panel{"95th-percentile log10 luminance error against time", "recover + merge, ms",
                   "p95 |log10 L - log10 L_true|", {}};
  for (auto& [k, s] : by_method) {
    // Points of one method across maps: sort by time so the polyline reads left to right.
    std::vector<size_t> idx(s.x.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return s.x[a] < s.x[b]; });
    ChartSeries sorted{s.name, {}, {}, {}, false};  // one point per map: a scatter
    for (size_t i : idx) sorted.x.push_back(s.x[i]), sorted.y.push_back(s.y[i]), sorted.labels.push_back(s.labels[i]);
    panel.series.push_back(sorted);
  }
  const std::string svg_path = (fs::path(args.output_dir) / "hdr.svg").string();
  write_file_atomically(svg_path, svg_chart(fmt::format("HDR fusion: error against time ({} response, 3 exposures 3 stops apart)",
                                                        args.response),
                                            {panel}, 1));
  say(out, "{:<12} {:<38} {:>9} {:>9} {:>8} {:>10} {:>9} {:>8}\n", "map", "method", "median", "p95", "invalid",
      "recover ms", "merge ms", "x floor");
  for (const Row& r : rows)
    say(out, "{:<12} {:<38} {:>9.4f} {:>9.4f} {:>8} {:>10.1f} {:>9.2f} {:>8.1f}\n", r.map, r.method,
        r.error.median_log10, r.error.p95_log10, r.error.pixels_invalid, r.recover_ms, r.merge_ms,
        r.merge_ms / r.floor_ms);
  say(out, "-> {}, {}\n", csv_path, svg_path);
  nlohmann::json jr = nlohmann::json::array();
  for (const Row& r : rows)
    jr.push_back({{"map", r.map}, {"method", r.method}, {"median_log10", r.error.median_log10},
                  {"p95_log10", r.error.p95_log10}, {"invalid_pixels", r.error.pixels_invalid},
                  {"recover_ms", r.recover_ms}, {"merge_ms", r.merge_ms}});
  emit_json(out, {{"csv", csv_path}, {"chart", svg_path}, {"rows", jr}});
  return 0;
}

}  // namespace lp::cli
