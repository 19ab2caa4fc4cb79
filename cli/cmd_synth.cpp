// synth: the ground-truth makers (a procedural scene, dynamic sequences, chessboard views,
// exposure brackets, probe images, a walk through a room), each with its truth beside it.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>

#include "calib/board_detect.h"
#include "calib/camera_model.h"
#include "calib/synthetic_boards.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/accuracy.h"
#include "core/envmap.h"
#include "core/error.h"
#include "core/limits.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "core/resample.h"
#include "estimate/exposure_metering.h"
#include "estimate/metadata_track.h"
#include "estimate/walkthrough.h"
#include "eval/harness.h"
#include "eval/synthetic_scene.h"
#include "eval/synthetic_sequence.h"
#include "hdr/bracket.h"
#include "hdr/response.h"
#include "hdr/synthetic_bracket.h"
#include "probe/fisheye.h"
#include "probe/mirror_ball.h"
#include "probe/synthetic_probe.h"

namespace lp::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace

struct SynthSceneArgs {
  std::string output;
  std::string layout = "latlong";
  std::string size;                 // default 1024x512 (latlong), 360x90 (hemisphere)
  int nside = 0;
  double sun_scale = 1.0;
  bool no_sun = false;
};

struct SynthSequenceArgs {
  std::string scenario = "moving-light";
  std::string base = "scene";       // a map file or "scene"
  int frames = 48;
  double fps = 21;
  uint64_t seed = 7;
  std::string size;                 // resample the base first (WxH)
  std::string output_dir;
};

struct SynthBoardsArgs {
  int views = 20;
  std::string board = "9x6";
  double square_mm = 30;
  double noise = 0.01;
  double fov = 190;
  std::string camera;               // a model file; default a 190 deg Kannala-Brandt 1280x960
  uint64_t seed = 1;
  std::string output_dir;
};

struct SynthBracketArgs {
  std::string input = "scene";      // a radiance image/map or "scene"
  std::string exposure_times;       // default 1/64,1/8,1
  std::string response = "gamma";   // linear|gamma|scurve
  bool no_noise = false;
  int bit_depth = 8;
  int shake_px = 0;
  bool moving_object = false;
  uint64_t seed = 1;
  std::string output_dir;
};

struct SynthProbeArgs {
  std::string input = "scene";
  std::string type = "mirrorball";
  std::string size = "512x512";
  double radius = 0;                // ball radius px (0: 40 % of the short side)
  double distance = 0;              // 0: orthographic
  double fov = 190;                 // fisheye
  double noise = 0;
  int frames = 1;
  double jitter = 1.0;              // ball centre jitter px per frame (sequences)
  uint64_t seed = 1;
  std::string output;
};

struct SynthWalkthroughArgs {
  std::string output_dir;
  double fps = 10, speed = 0.7;
  int rays = 16;                    // camera rays across
  int probe_size = 128;             // latlong width of the query probes
  int samples = 4;                  // per pixel edge
  bool no_mean_code = false;        // the camera does not report its metered mean
  bool bright_rgb = false;          // record the brightest pixels' colour
};

int run_synth_scene(const SynthSceneArgs& args, const Output& out) {
  const auto layout = optional_layout(args.layout, "--layout").value_or(Layout::LatLong);
  if (layout == Layout::Healpix && !args.size.empty())
    throw InputError("--size does not apply to healpix: use --nside");
  int w = 0, h = 0;
  target_geometry(layout, args.size, args.nside > 0 ? args.nside : 128, nullptr, &w, &h);
  SceneOptions so;
  if (!(args.sun_scale >= 0)) throw InputError("--sun-scale must be >= 0");
  for (double& c : so.sun_rgb) c *= args.no_sun ? 0.0 : args.sun_scale;
  const SceneDescription scene = describe_scene(so);
  const EnvMap map = render_scene(scene, layout, w, h);
  write_envmap(args.output, map);
  const auto sun = scene.sun_power();
  const double total = total_luminance_power(map);
  say(out, "{}: procedural scene, {}; power {:.6g}, sun {:.1f} %\n", args.output, describe_size(map), total,
      total > 0 ? 100 * luminance(sun.data()) / total : 0.0);
  emit_json(out, {{"output", args.output},
                  {"layout", std::string(to_string(map.layout))},
                  {"width", map.width},
                  {"height", map.height},
                  {"power_luminance", total},
                  {"sun_power_luminance", luminance(sun.data())}});
  return 0;
}


int run_synth_sequence(const SynthSequenceArgs& args, const Output& out) {
  const auto scenario = scenario_from_string(args.scenario);
  if (!scenario) throw InputError(fmt::format("--scenario: unknown scenario '{}'", args.scenario));
  SequenceOptions so;
  so.scenario = *scenario;
  so.frames = args.frames;
  so.frame_rate_hz = args.fps;
  so.seed = args.seed;
  check_frame_count("--frames", args.frames);
  try {
    validate(so);
  } catch (const InputError& e) {
    throw InputError(fmt::format("synth sequence: {}", e.what()));
  }
  EnvMap base = map_or_scene(args.base, 512);
  if (!args.size.empty()) {
    int w = 0, h = 0;
    parse_image_size(args.size, "--size", &w, &h);
    base = resample(base, base.layout == Layout::Healpix ? Layout::LatLong : base.layout, w, h);
  }
  Progress progress("synth sequence", size_t(so.frames), out.progress);
  const std::string truth_path =
      write_sequence_files(args.output_dir, base, args.base, so, [&] { progress.advance(); });
  progress.finish();
  say(out, "{}: {} frames of '{}' on {} ({}), ground truth in {}\n", args.output_dir, so.frames, to_string(so.scenario),
      map_label(args.base), describe_size(base), truth_path);
  emit_json(out, {{"output", args.output_dir}, {"frames", so.frames}, {"truth", truth_path}});
  return 0;
}

int run_synth_boards(const SynthBoardsArgs& args, const Output& out) {
  SyntheticBoardsOptions o;
  o.views = args.views;
  o.board = board_from(args.board, args.square_mm);
  o.noise_sigma = args.noise;
  o.seed = args.seed;
  o.field_deg = args.fov;
  if (!args.camera.empty()) o.camera = read_camera_model(args.camera);
  if (o.views < 1) throw InputError("--views must be at least 1");
  check_count("--views", o.views, limits().max_frames, "views", "each is an image file");
  const SyntheticBoards b = synthesize_boards(o);
  make_output_directory(args.output_dir);
  nlohmann::json truth = {{"board", {o.board.cols, o.board.rows}}, {"square_mm", o.board.square_mm},
                          {"lensmodel", o.camera.lensmodel}, {"intrinsics", o.camera.intrinsics},
                          {"width", o.camera.width}, {"height", o.camera.height}};
  nlohmann::json views = nlohmann::json::array();
  for (size_t i = 0; i < b.images.size(); ++i) {
    const std::string name = fmt::format("board_{:02d}.png", i);
    RgbImage rgb;
    rgb.width = b.images[i].width;
    rgb.height = b.images[i].height;
    rgb.rgb = b.images[i].rgb;
    write_code_image((fs::path(args.output_dir) / name).string(), rgb, 8);
    views.push_back({{"file", name}, {"corners", b.true_corners[i]}, {"pose", b.poses[i]}});
  }
  truth["views"] = views;
  write_file_atomically((fs::path(args.output_dir) / "truth.json").string(), truth.dump(1) + "\n");
  try {
    write_opencv_yaml((fs::path(args.output_dir) / "true_camera.yaml").string(), o.camera);
  } catch (const InputError&) {
  }
  say(out, "{}: {} views of a {}x{} board through {} ({}x{}), truth.json\n", args.output_dir, b.images.size(),
      o.board.cols, o.board.rows, o.camera.lensmodel, o.camera.width, o.camera.height);
  emit_json(out, {{"output", args.output_dir}, {"views", b.images.size()}});
  return 0;
}

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
  const SyntheticBracket b = make_synthetic_bracket(radiance_or_scene(args.input), o);
  write_synthetic_bracket(args.output_dir, b, o.bit_depth);
  say(out, "{}: {} frames ({}-bit, {} response{}{}), exposures.csv, truth.exr, true_response.json\n", args.output_dir,
      b.frames.size(), o.bit_depth, args.response, o.shake_px ? fmt::format(", shake {} px", o.shake_px) : "",
      o.moving_object ? ", moving object" : "");
  emit_json(out, {{"output", args.output_dir}, {"frames", b.frames.size()}});
  return 0;
}

int run_synth_probe(const SynthProbeArgs& args, const Output& out) {
  int w = 0, h = 0;
  parse_image_size(args.size, "--size", &w, &h);
  check_frame_count("--frames", args.frames);
  const EnvMap world = args.input == "scene" ? render_scene(describe_scene(), Layout::LatLong, 1024, 512)
                                             : read_envmap(args.input);
  const bool sequence = args.frames > 1;
  if (args.frames < 1) throw InputError("--frames must be at least 1");
  if (sequence) {
    make_output_directory(args.output);
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


int run_synth_walkthrough(const SynthWalkthroughArgs& args, const Output& out) {
  if (args.probe_size < 8 || args.probe_size % 2) throw InputError(fmt::format("--probe-size must be even and >= 8, got {}", args.probe_size));
  if (args.rays < 2) throw InputError(fmt::format("--rays must be >= 2, got {}", args.rays));
  check_image_size("--probe-size", args.probe_size, args.probe_size / 2, "probe");
  check_image_size("--rays", args.rays, args.rays, "ray grid");
  check_count("--samples", args.samples, 64, "rays a pixel edge", "every probe pixel traces samples^2 rays");
  const Room room = default_room();
  WalkthroughOptions o;
  o.fps = args.fps;
  o.speed = args.speed;
  o.rays_x = args.rays;
  o.record_mean_code = !args.no_mean_code;
  o.record_bright_rgb = args.bright_rgb;
  const auto t0 = Clock::now();
  Progress progress("probes", walkthrough_query_points(room, o).size(), out.progress);
  const WalkthroughFiles files =
      write_walkthrough(args.output_dir, room, o, args.probe_size, args.samples, [&] { progress.advance(); });
  progress.finish();
  say(out, "{}: {} frames along a {:.0f} s walk through an {}x{} m room, {} query probes ({}x{}), truth in {} ({:.1f} s)\n",
      args.output_dir, files.frames, files.duration_s, room.width, room.depth, files.queries, args.probe_size,
      args.probe_size / 2, files.truth_path, seconds_since(t0));
  emit_json(out, {{"output", args.output_dir}, {"track", files.track_path}, {"truth", files.truth_path},
                  {"frames", files.frames}, {"queries", files.queries}, {"seconds", seconds_since(t0)}});
  return 0;
}

namespace {

// The two commands with the most options, out of the table to keep it short.
Command synth_bracket_command() {
  return {"synth bracket", "A bracket with known response, noise and truth from a radiance map",
          "lightprobe synth bracket scene --response gamma -o bracket/\nlightprobe hdr fuse bracket/frame_0*.png --exposure-times bracket/exposures.csv -o fused.exr",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<SynthBracketArgs>();
            f.arg("INPUT", a->input, "Radiance map or image, or 'scene'");
            f.opt("--exposure-times", a->exposure_times, "Seconds, default 1/64,1/8,1");
            f.opt("--response", a->response, "linear|gamma|scurve");
            f.flag("--no-noise", a->no_noise, "No shot or read noise");
            f.opt("--bit-depth", a->bit_depth, "8 or 16");
            f.opt("--shake", a->shake_px, "Camera shake, max px per frame");
            f.flag("--moving-object", a->moving_object, "A bright square moving between frames");
            f.opt("--seed", a->seed, "Noise seed");
            f.output(a->output_dir, "Directory for frames, exposures.csv, truth");
            return [a](const Output& out) { return run_synth_bracket(*a, out); };
          }};
}

Command synth_probe_command() {
  return {"synth probe", "Ray-trace a mirror ball or fisheye view of a map (ground truth)",
          "lightprobe synth probe scene --type mirrorball --size 512x512 -o ball.exr\nlightprobe synth probe probe.exr --type fisheye --fov 190 --size 1024x1024 -o sky.exr",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<SynthProbeArgs>();
            f.arg("MAP", a->input, "A latlong map, or 'scene'");
            f.opt("--type", a->type, "mirrorball|fisheye");
            f.opt("--size", a->size, "Image WxH");
            f.opt("--radius", a->radius, "Ball radius, px");
            f.opt("--distance", a->distance, "Camera distance in ball radii (default orthographic)");
            f.opt("--fov", a->fov, "Fisheye field of view, deg");
            f.opt("--noise", a->noise, "Relative Gaussian noise");
            f.opt("--frames", a->frames, "Frames (a jittered sequence)");
            f.opt("--jitter", a->jitter, "Ball centre jitter per frame, px");
            f.opt("--seed", a->seed, "Noise seed");
            f.output(a->output, "Image (or directory for a sequence)");
            return [a](const Output& out) { return run_synth_probe(*a, out); };
          }};
}

}  // namespace

std::vector<Command> synth_commands() {
  return {
      {"synth scene", "The procedural sky + sun + area lights scene",
       "lightprobe synth scene -o scene.exr --size 1024x512\nlightprobe synth scene -o scene_polar.exr --layout hemisphere",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<SynthSceneArgs>();
         f.output(a->output, "Output map");
         f.opt("--layout", a->layout, "latlong|hemisphere|healpix");
         f.opt("--size", a->size, "WxH (latlong, hemisphere)");
         f.opt("--nside", a->nside, "HEALPix nside");
         f.opt("--sun-scale", a->sun_scale, "Multiply the sun's radiance");
         f.flag("--no-sun", a->no_sun, "Leave the sun out");
         return [a](const Output& out) { return run_synth_scene(*a, out); };
       }},
      {"synth sequence", "A dynamic sequence with ground truth, one EXR per frame",
       "lightprobe synth sequence --scenario abrupt-switch --base probe.exr --frames 48 -o seq/",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<SynthSequenceArgs>();
         f.opt("--scenario", a->scenario, "static-noise|moving-light|swinging-bulb|abrupt-switch|flicker|rising-light|camera-turn");
         f.opt("--base", a->base, "Base map file, or 'scene' (the procedural scene at 512x256)");
         f.opt("--frames", a->frames, "Number of frames");
         f.opt("--fps", a->fps, "Frame rate (flicker aliasing depends on it)");
         f.opt("--seed", a->seed, "Noise seed");
         f.opt("--size", a->size, "Resample the base to WxH first");
         f.output(a->output_dir, "Output directory (frame_0000.exr ..., truth.json)");
         return [a](const Output& out) { return run_synth_sequence(*a, out); };
       }},
      {"synth boards", "Chessboard views rendered through a known camera (ground truth)",
       "lightprobe synth boards --views 10 -o boards/\nlightprobe calib geometric boards/board_*.png --board 9x6 --square 30 -o camera.yaml",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<SynthBoardsArgs>();
         f.opt("--views", a->views, "Number of views");
         f.opt("--board", a->board, "COLSxROWS inner corners");
         f.opt("--square", a->square_mm, "Square size, mm");
         f.opt("--noise", a->noise, "Image noise (0..1 units)");
         f.opt("--fov", a->fov, "Image circle, deg (0: the model's own domain)");
         f.opt("--camera", a->camera, "Camera model file (default: 190 deg Kannala-Brandt 1280x960)");
         f.opt("--seed", a->seed, "Seed");
         f.output(a->output_dir, "Directory for board_NN.png, truth.json, true_camera.yaml");
         return [a](const Output& out) { return run_synth_boards(*a, out); };
       }},
      synth_bracket_command(),
      synth_probe_command(),
      {"synth walkthrough", "A room walked by a metadata camera, with true probes at query points",
       "lightprobe synth walkthrough -o walk/\nlightprobe eval metadata walk/ -o eval/metadata",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<SynthWalkthroughArgs>();
         f.output(a->output_dir, "Directory for track.jsonl, probes/, truth.json");
         f.opt("--fps", a->fps, "Camera frame rate");
         f.opt("--speed", a->speed, "Walking speed, m/s");
         f.opt("--rays", a->rays, "Camera rays across the frame");
         f.opt("--probe-size", a->probe_size, "Latlong width of the query probes");
         f.opt("--samples", a->samples, "Probe rays per pixel edge");
         f.flag("--no-mean-code", a->no_mean_code, "The camera does not report its metered mean (AE assumed on target)");
         f.flag("--bright-rgb", a->bright_rgb, "Record the brightest pixels' colour");
         return [a](const Output& out) { return run_synth_walkthrough(*a, out); };
       }},
  };
}

}  // namespace lp::cli
