// probe unwrap, synth probe, eval unwrap: mirror-ball and fisheye probes -> maps.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <memory>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "cli/commands.h"
#include "cli/eval_handlers.h"
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

struct ProbeUnwrapArgs {
  std::vector<std::string> inputs;  // an image, several, or a directory (a sequence)
  std::string type = "mirrorball";  // mirrorball|fisheye
  std::string camera;               // fisheye: OpenCV fisheye YAML (default: equidistant)
  double fov = 0;                   // fisheye: equidistant field of view; ball: camera fov
  double distance = 0;              // ball: camera distance in ball radii (0: orthographic)
  std::string ball;                 // "cx,cy,r" instead of detection
  double reflectivity = 1.0;
  bool fresnel = false;
  double blind_spot_deg = 15;
  bool fill = false;
  bool stabilise = false;           // smooth the per-frame ball / circle track
  bool static_probe = false;        // with stabilise: one median position for all frames
  bool fixed_ball = false;          // use frame 0's geometry for every frame (no tracking)
  std::string colour_match;         // 3x3 transform to the backplate camera (calib colour)
  std::string rotation;
  std::string layout = "latlong";
  std::string size;
  int nside = 0;
  std::string output;               // a map, or a directory for a sequence
};

struct ProbeRegisterArgs {
  std::vector<std::string> images;  // photos of one ball, cropped differently
  int size = 512;                   // output square, px
  std::string output_dir;
};

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

std::vector<Command> probe_commands() {
  return {
      {"probe unwrap", "Unwrap a probe image (or a sequence) into a map in the world frame",
       "lightprobe probe unwrap ball.exr --type mirrorball --fill --layout latlong --size 1024x512 -o map.exr\nlightprobe probe unwrap sky.png --type fisheye --camera fisheye.yaml --layout hemisphere -o sky.exr\nlightprobe probe unwrap frames/ --type mirrorball -o maps/",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<ProbeUnwrapArgs>();
         f.arg("IMAGE", a->inputs, "Probe image(s) or a directory of frames").required();
         f.opt("--type", a->type, "mirrorball|fisheye");
         f.opt("--camera", a->camera, "fisheye: calibrated model (.cameramodel or OpenCV YAML, any lens model)");
         f.opt("--fov", a->fov, "fisheye: field of view (deg): of the equidistant default model, or the image circle of --camera; " "ball: the camera's field of view");
         f.opt("--distance", a->distance, "ball: camera distance in ball radii (default orthographic)");
         f.opt("--ball", a->ball, "ball: 'cx,cy,r' in pixels instead of detection");
         f.opt("--reflectivity", a->reflectivity, "ball: reflectivity at normal incidence (chrome ~0.6-0.7)");
         f.flag("--fresnel", a->fresnel, "ball: reflectivity rises towards the rim (Schlick)");
         f.opt("--blind-spot", a->blind_spot_deg, "ball: half-angle (deg) masked around the blind spot");
         f.flag("--fill", a->fill, "Fill what the camera cannot see smoothly (mask kept)");
         f.flag("--smooth-track", a->stabilise, "Sequences: smooth the per-frame ball / image-circle track (a fixed probe, noisy detection)");
         f.flag("--static-probe", a->static_probe, "With --smooth-track: one median position for every frame");
         f.flag("--fixed-ball", a->fixed_ball, "Sequences: no tracking, frame 0's geometry for all (for comparison)");
         f.opt("--colour-match", a->colour_match, "3x3 colour transform to the backplate (calib colour)");
         f.opt("--rotation", a->rotation, "Probe to world: 'yaw,pitch,roll' degrees or 9 numbers");
         f.opt("--layout", a->layout, "latlong|hemisphere|healpix");
         f.opt("--size", a->size, "WxH");
         f.opt("--nside", a->nside, "healpix nside");
         f.output(a->output, "Output map (or directory for a sequence)");
         return [a](const Output& out) { return run_probe_unwrap(*a, out); };
       }},
      {"probe register", "Centre one ball in differently cropped photos (for hdr fuse)",
       "lightprobe probe register a.jpg b.jpg c.jpg -o registered/",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<ProbeRegisterArgs>();
         f.arg("IMAGE", a->images, "Photos of the same mirror ball").required();
         f.opt("--size", a->size, "Output square size, px");
         f.output(a->output_dir, "Directory for the registered photos (PNG)");
         return [a](const Output& out) { return run_probe_register(*a, out); };
       }},
  };
}

}  // namespace lp::cli
