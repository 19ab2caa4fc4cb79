// probe unwrap, synth probe, eval unwrap: mirror-ball and fisheye probes -> maps.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "core/resample.h"
#include "eval/synthetic_scene.h"
#include "calib/colour_match.h"
#include "hdr/bracket.h"
#include "probe/ball_register.h"
#include "probe/camera_unwrap.h"
#include "probe/fill.h"
#include "probe/fisheye.h"
#include "probe/mirror_ball.h"
#include "probe/stabilise.h"
#include "probe/synthetic_probe.h"
#include "probe/unwrap_accuracy.h"

namespace lp::cli {

namespace {

namespace fs = std::filesystem;

bool is_image_file(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e == ".exr" || e == ".hdr" || e == ".pfm" || e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tif" ||
         e == ".tiff";
}

std::vector<std::string> expand_images(const std::vector<std::string>& inputs) {
  std::vector<std::string> files;
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      std::vector<std::string> found;
      for (const auto& e : fs::directory_iterator(in))
        if (e.is_regular_file() && is_image_file(e.path())) found.push_back(e.path().string());
      std::sort(found.begin(), found.end());
      if (found.empty()) throw InputError(fmt::format("{}: directory holds no images", in));
      files.insert(files.end(), found.begin(), found.end());
    } else {
      files.push_back(in);
    }
  }
  return files;
}

void target_size(const std::string& layout_name, const std::string& size, int nside, Layout* layout, int* w, int* h) {
  const auto l = layout_from_string(layout_name);
  if (!l) throw InputError(fmt::format("--layout: unknown layout '{}' (latlong, hemisphere, healpix)", layout_name));
  *layout = *l;
  if (*l == Layout::Healpix) {
    *w = nside > 0 ? nside : 64;
    *h = 1;
  } else if (!size.empty()) {
    parse_size(size, "--size", w, h);
  } else if (*l == Layout::Hemisphere) {
    *w = 360, *h = 90;
  } else {
    *w = 1024, *h = 512;
  }
}

MirrorBallCamera ball_camera(const ProbeUnwrapArgs& a) {
  MirrorBallCamera c;
  if (a.distance > 0) c.distance_in_radii = a.distance;
  if (a.fov > 0) c.fov_deg = a.fov;
  if (!a.rotation.empty()) c.world_from_probe = parse_rotation(a.rotation);
  if (!(a.reflectivity > 0 && a.reflectivity <= 1)) throw InputError("--reflectivity must be in (0, 1]");
  c.reflectivity = a.reflectivity;
  c.fresnel = a.fresnel;
  return c;
}

// A fisheye without --camera: the plain equidistant model of CONVENTIONS, as a KB model.
CameraModel fisheye_model(const ProbeUnwrapArgs& a, const RgbImage& first) {
  if (!a.camera.empty()) return read_camera_model(a.camera);
  return camera_model_from_fisheye(equidistant_fisheye(first.width, first.height, a.fov > 0 ? a.fov : 180));
}

std::string output_for(const ProbeUnwrapArgs& a, size_t frame, size_t frames) {
  if (frames == 1) return a.output;
  return (fs::path(a.output) / fmt::format("frame_{:04d}.exr", frame)).string();
}

}  // namespace

int run_probe_unwrap(const ProbeUnwrapArgs& args, const Output& out) {
  const std::vector<std::string> files = expand_images(args.inputs);
  if (args.type != "mirrorball" && args.type != "fisheye")
    throw InputError(fmt::format("--type must be mirrorball or fisheye, got '{}'", args.type));
  Layout layout;
  int w = 0, h = 0;
  target_size(args.layout, args.size, args.nside, &layout, &w, &h);
  if (files.size() > 1) {
    std::error_code ec;
    fs::create_directories(args.output, ec);
    if (ec) throw InputError(fmt::format("{}: cannot create the output directory for a sequence: {}", args.output, ec.message()));
  }
  // Pass 1: per-frame probe geometry (ball or image circle), then a smoothed track.
  std::vector<RgbImage> frames;
  CircleTrack raw;
  Progress progress("probe unwrap", 2 * files.size(), out.progress && files.size() > 1);
  for (const std::string& f : files) {
    RgbImage img = read_rgb_image(f);
    if (!frames.empty() && (img.width != frames[0].width || img.height != frames[0].height))
      throw InputError(fmt::format("{}: {}x{} differs from the sequence's {}x{}", f, img.width, img.height,
                                   frames[0].width, frames[0].height));
    if (args.type == "mirrorball") {
      BallInImage ball;
      if (!args.ball.empty()) {
        const auto v = parse_numbers(args.ball, "--ball", 3);
        ball = {v[0], v[1], v[2]};
      } else {
        try {
          ball = find_ball(img);
        } catch (const InputError& e) {
          throw InputError(fmt::format("{}: {}", f, e.what()));
        }
      }
      raw.cx.push_back(ball.cx), raw.cy.push_back(ball.cy), raw.r.push_back(ball.radius_px);
    } else if (files.size() > 1 && !args.fixed_ball) {
      const ImageCircle c = find_image_circle(img);
      raw.cx.push_back(c.cx), raw.cy.push_back(c.cy), raw.r.push_back(c.r);
    }
    frames.push_back(std::move(img));
    progress.advance();
  }
  // Stabilisation: every frame is unwrapped with its own ball (or image circle), so the
  // map stays put when the camera shakes. --smooth-track additionally smooths that track,
  // for a fixed probe whose per-frame detection is noisy; --fixed-ball uses frame 0's
  // geometry for every frame (what an unstabilised pipeline does), for comparison.
  CircleTrack track = raw;
  if (args.fixed_ball && !raw.cx.empty())
    for (size_t i = 0; i < raw.cx.size(); ++i) track.cx[i] = raw.cx[0], track.cy[i] = raw.cy[0], track.r[i] = raw.r[0];
  if (args.stabilise && raw.cx.size() > 1) {
    SmoothOptions so;
    so.static_probe = args.static_probe;
    track = smooth_track(raw, so);
  }
  // Pass 2: unwrap every frame with its (smoothed) geometry.
  nlohmann::json per_frame = nlohmann::json::array();
  double fill_share = 0;
  const auto t0 = std::chrono::steady_clock::now();
  std::optional<CameraModel> base_model;
  std::vector<Vec3> centroids;
  std::optional<ColourMatch> colour;
  if (!args.colour_match.empty()) colour = load_colour_match(args.colour_match);
  for (size_t i = 0; i < frames.size(); ++i) {
    EnvMap map;
    nlohmann::json fj = {{"file", files[i]}};
    if (args.type == "mirrorball") {
      const BallInImage ball{track.cx[i], track.cy[i], track.r[i]};
      UnwrapOptions uo;
      uo.blind_spot_deg = args.blind_spot_deg;
      uo.fill = args.fill;
      UnwrapReport ur;
      map = unwrap_mirror_ball(frames[i], ball, ball_camera(args), layout, w, h, uo, &ur);
      fill_share = ur.fill_power_share;
      fj["ball"] = {ball.cx, ball.cy, ball.radius_px};
      fj["ball_raw"] = {raw.cx[i], raw.cy[i], raw.r[i]};
      fj["valid_fraction"] = ur.valid_solid_angle_fraction;
    } else {
      if (!base_model) base_model = fisheye_model(args, frames[0]);
      CameraModel m = *base_model;
      if (!track.cx.empty()) {
        // Move the optical centre with the image circle, relative to the track's first frame.
        m.intrinsics[2] += track.cx[i] - track.cx[0];
        m.intrinsics[3] += track.cy[i] - track.cy[0];
        fj["circle"] = {track.cx[i], track.cy[i], track.r[i]};
      }
      CameraUnwrapOptions co;
      co.max_field_deg = args.fov > 0 ? args.fov / 2 : (args.camera.empty() ? 90 : 0);
      if (args.fill) co.fill.method = FillMethod::PushPull;
      const Mat3 world_from_camera = (args.rotation.empty() ? Mat3{} : parse_rotation(args.rotation)) *
                                     upward_camera_world_from_camera();
      FillReport fr;
      map = unwrap_with_camera(frames[i], m, world_from_camera, layout, w, h, co, &fr);
      fill_share = fr.filled_power_share;
    }
    map.units = frames[i].units;
    if (colour) apply_colour_match(map, *colour);
    // Power-weighted mean direction of the valid map: a static world must keep it still.
    Vec3 c{0, 0, 0};
    for (size_t p = 0; p < map.pixel_count(); ++p)
      if (map.is_valid(p)) {
        const float* q = map.pixel(p);
        c = c + (luminance(q[0], q[1], q[2]) * pixel_solid_angle(map, p)) * pixel_direction(map, p);
      }
    if (length(c) > 0) centroids.push_back(normalize(c));
    write_envmap(output_for(args, i, frames.size()), map);
    per_frame.push_back(fj);
    progress.advance();
  }
  progress.finish();
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json report = {{"output", args.output}, {"type", args.type}, {"frames", frames.size()},
                           {"layout", args.layout}, {"width", w}, {"height", h}, {"milliseconds", ms},
                           {"per_frame", per_frame}};
  if (args.fill) report["fill_power_share"] = fill_share;
  double map_jitter_deg = 0;
  for (size_t i = 1; i < centroids.size(); ++i) map_jitter_deg += angle_between(centroids[i - 1], centroids[i]) * 180 / M_PI;
  if (centroids.size() > 1) {
    map_jitter_deg /= double(centroids.size() - 1);
    report["map_jitter_deg"] = map_jitter_deg;
  }
  if (raw.cx.size() > 1) {
    report["detected_jitter_px"] = residual_jitter_px(raw);
    report["used_jitter_px"] = residual_jitter_px(track);
  }
  if (args.type == "mirrorball" && frames.size() == 1)
    say(out, "{}: ball at ({:.2f}, {:.2f}) r {:.2f} px -> {} {}x{}{}\n", args.output, track.cx[0], track.cy[0],
        track.r[0], args.layout, w, h, args.fill ? fmt::format(", fill holds {:.2f} % of the power", 100 * fill_share) : "");
  else
    say(out, "{}: {} frame(s) -> {} {}x{} in {:.0f} ms{}\n", args.output, frames.size(), args.layout, w, h, ms,
        raw.cx.size() > 1 ? fmt::format("; probe centre moved {:.3f} px per frame, unwrapped map {:.4f} deg per frame",
                                        residual_jitter_px(raw), map_jitter_deg)
                          : "");
  emit_json(out, report);
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

int run_probe_register(const ProbeRegisterArgs& args, const Output& out) {
  // Differently cropped photos of one ball (a bracket shot by hand): find the ball in
  // each, then resample every photo so the ball is centred with one radius, code values
  // untouched, ready for `hdr fuse`.
  if (args.images.size() < 2) throw InputError("probe register needs at least two photos of the ball");
  if (args.size < 32) throw InputError("--size must be at least 32 px");
  std::vector<RgbImage> frames;
  std::vector<BallInImage> balls;
  nlohmann::json found = nlohmann::json::array();
  for (const std::string& f : args.images) {
    frames.push_back(read_rgb_image(f));
    try {
      balls.push_back(find_ball(frames.back()));
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", f, e.what()));
    }
    found.push_back({{"file", f}, {"ball", {balls.back().cx, balls.back().cy, balls.back().radius_px}}});
  }
  const std::vector<RgbImage> registered = register_balls(frames, balls, args.size);
  std::error_code ec;
  fs::create_directories(args.output_dir, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the output directory: {}", args.output_dir, ec.message()));
  for (size_t i = 0; i < registered.size(); ++i) {
    const std::string name = fs::path(args.images[i]).stem().string() + ".png";
    write_code_image((fs::path(args.output_dir) / name).string(), registered[i], 8);
    found[i]["output"] = name;
  }
  const BallInImage ball = registered_ball(args.size);
  say(out, "{}: {} photos registered to {}x{}, ball at ({:.1f}, {:.1f}) r {:.1f} px\n", args.output_dir,
      registered.size(), args.size, args.size, ball.cx, ball.cy, ball.radius_px);
  emit_json(out, {{"output", args.output_dir}, {"frames", found},
                  {"registered_ball", {ball.cx, ball.cy, ball.radius_px}}});
  return 0;
}

int run_synth_probe(const SynthProbeArgs& args, const Output& out) {
  const EnvMap world = args.input == "scene" ? render_scene(describe_scene(), Layout::LatLong, 1024, 512)
                                             : read_envmap(args.input);
  int w = 0, h = 0;
  parse_size(args.size, "--size", &w, &h);
  const bool sequence = args.frames > 1;
  if (args.frames < 1) throw InputError("--frames must be at least 1");
  if (sequence) {
    std::error_code ec;
    fs::create_directories(args.output, ec);
    if (ec) throw InputError(fmt::format("{}: cannot create the output directory: {}", args.output, ec.message()));
  }
  nlohmann::json truth = {{"type", args.type}, {"input", args.input}, {"frames", args.frames}};
  nlohmann::json per_frame = nlohmann::json::array();
  if (args.type == "mirrorball") {
    const double r = args.radius > 0 ? args.radius : 0.4 * std::min(w, h);
    const BallInImage ball{w / 2.0, h / 2.0, r};
    MirrorBallCamera cam;
    if (args.distance > 0) cam.distance_in_radii = args.distance;
    const auto track = jittered_track(ball, args.frames, sequence ? args.jitter : 0, args.seed);
    for (int f = 0; f < args.frames; ++f) {
      RenderBallOptions ro;
      ro.noise_relative = args.noise;
      ro.seed = args.seed + uint64_t(f);
      const RgbImage img = render_mirror_ball(world, track[size_t(f)], cam, w, h, ro);
      const std::string path = sequence ? (fs::path(args.output) / fmt::format("frame_{:04d}.exr", f)).string() : args.output;
      write_rgb_image(path, img);
      per_frame.push_back({{"frame", f}, {"ball", {track[size_t(f)].cx, track[size_t(f)].cy, track[size_t(f)].radius_px}}});
    }
    if (args.distance > 0) truth["distance_in_radii"] = args.distance;
  } else if (args.type == "fisheye") {
    const FisheyeModel m = equidistant_fisheye(w, h, args.fov);
    const RgbImage img = render_fisheye(world, m, 4);
    write_rgb_image(args.output, img);
    truth["fov_deg"] = args.fov;
    if (sequence) throw InputError("--frames applies to mirror balls only");
  } else {
    throw InputError(fmt::format("--type must be mirrorball or fisheye, got '{}'", args.type));
  }
  truth["per_frame"] = per_frame;
  if (sequence) write_file_atomically((fs::path(args.output) / "truth.json").string(), truth.dump(2) + "\n");
  say(out, "{}: synthetic {} probe {}x{}{}\n", args.output, args.type, w, h,
      sequence ? fmt::format(", {} frames, truth.json", args.frames) : "");
  emit_json(out, truth);
  return 0;
}

int run_eval_unwrap(const EvalUnwrapArgs& args, const Output& out) {
  struct Row {
    std::string map, probe;
    UnwrapError error;
    double centre_error_px = 0, radius_error_px = 0, ms = 0;
  };
  std::vector<Row> rows;
  std::error_code ec;
  fs::create_directories(args.output_dir, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the output directory: {}", args.output_dir, ec.message()));
  Progress progress("eval unwrap", args.maps.size(), out.progress);
  for (const std::string& path : args.maps) {
    const EnvMap world = path == "scene" ? render_scene(describe_scene(), Layout::LatLong, 1024, 512) : read_envmap(path);
    const std::string name = path == "scene" ? "scene" : fs::path(path).stem().string();
    const EnvMap truth = resample(world, Layout::LatLong, 256, 128);
    const BallInImage ball{256.3, 251.7, 200.0};
    for (const auto& [label, distance, noise] :
         std::vector<std::tuple<std::string, double, double>>{{"ball, orthographic", 0, 0},
                                                              {"ball, orthographic, 2 % noise", 0, 0.02},
                                                              {"ball, perspective 10 radii", 10, 0},
                                                              {"ball, perspective 10 radii, 2 % noise", 10, 0.02}}) {
      MirrorBallCamera cam;
      if (distance > 0) cam.distance_in_radii = distance;
      RenderBallOptions ro;
      ro.noise_relative = noise;
      const RgbImage img = render_mirror_ball(world, ball, cam, 512, 512, ro);
      const auto t0 = std::chrono::steady_clock::now();
      const BallInImage found = find_ball(img);
      const EnvMap map = unwrap_mirror_ball(img, found, cam, Layout::LatLong, 256, 128);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      rows.push_back({name, label, unwrap_error(map, truth), std::hypot(found.cx - ball.cx, found.cy - ball.cy),
                      std::fabs(found.radius_px - ball.radius_px), ms});
    }
    {
      const FisheyeModel m = equidistant_fisheye(600, 600, 190);
      const RgbImage img = render_fisheye(world, m, 4);
      const auto t0 = std::chrono::steady_clock::now();
      const EnvMap map = unwrap_fisheye(img, m, Layout::LatLong, 256, 128, {});
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const ImageCircle c = find_image_circle(img);
      rows.push_back({name, "fisheye 190 deg equidistant", unwrap_error(map, truth),
                      std::hypot(c.cx - 300.0, c.cy - 300.0), std::fabs(c.r - 300.0 * 190.0 / 190.0), ms});
    }
    progress.advance();
  }
  progress.finish();
  std::string csv = "map,probe,mean_abs_log10,pixels,valid_solid_angle_sr,centre_error_px,radius_error_px,ms\n";
  for (const Row& r : rows)
    csv += fmt::format("{},{},{:.6g},{},{:.4f},{:.4f},{:.4f},{:.2f}\n", r.map, r.probe, r.error.mean_abs_log10,
                       r.error.pixels_compared, r.error.valid_solid_angle, r.centre_error_px, r.radius_error_px, r.ms);
  const std::string csv_path = (fs::path(args.output_dir) / "unwrap.csv").string();
  write_file_atomically(csv_path, csv);
  say(out, "{:<10} {:<40} {:>10} {:>9} {:>10} {:>8}\n", "map", "probe", "log10 err", "valid sr", "centre px", "ms");
  for (const Row& r : rows)
    say(out, "{:<10} {:<40} {:>10.4f} {:>9.3f} {:>10.3f} {:>8.1f}\n", r.map, r.probe, r.error.mean_abs_log10,
        r.error.valid_solid_angle, r.centre_error_px, r.ms);
  say(out, "-> {}\n", csv_path);
  nlohmann::json jr = nlohmann::json::array();
  for (const Row& r : rows)
    jr.push_back({{"map", r.map}, {"probe", r.probe}, {"mean_abs_log10", r.error.mean_abs_log10},
                  {"centre_error_px", r.centre_error_px}, {"ms", r.ms}});
  emit_json(out, {{"csv", csv_path}, {"rows", jr}});
  return 0;
}

}  // namespace lp::cli
