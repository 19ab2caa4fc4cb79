// synth: the ground-truth makers (a procedural scene, dynamic sequences, chessboard views,
// exposure brackets, probe images, a walk through a room), each with its truth beside it.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <memory>

#include "calib/camera_model.h"
#include "calib/synthetic_boards.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/accuracy.h"
#include "core/envmap.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/limits.h"
#include "core/progress.h"
#include "core/resample.h"
#include "estimate/walkthrough.h"
#include "eval/harness.h"
#include "eval/synthetic_scene.h"
#include "eval/synthetic_sequence.h"
#include "hdr/synthetic_bracket.h"
#include "probe/synthetic_probe.h"

namespace lp::cli {

struct SynthSceneArgs {
  std::string output;
  std::string layout = "latlong";
  std::string size;                 // default 1024x512 (latlong), 360x90 (hemisphere)
  int nside = 0;
  double sun_scale = 1.0;
  bool no_sun = false;
};

struct SynthSequenceArgs {
  SequenceOptions o;                // frames, fps and seed bound directly
  std::string scenario = "moving-light";
  std::string base = "scene";       // a map file or "scene"
  std::string size;                 // resample the base first (WxH)
  std::string output_dir;
};

struct SynthBoardsArgs {
  SyntheticBoardsOptions o;         // views, noise, fov and seed bound directly
  std::string board = "9x6";
  double square_mm = 30;
  std::string camera;               // a model file; default a 190 deg Kannala-Brandt 1280x960
  std::string output_dir;
};

struct SynthBracketArgs {
  SyntheticBracketOptions o;        // bit depth, shake, moving object and seed bound directly
  std::string input = "scene";      // a radiance image/map or "scene"
  std::string exposure_times;       // default 1/64,1/8,1
  std::string response = "gamma";   // linear|gamma|scurve
  bool no_noise = false;
  std::string output_dir;
};

struct SynthProbeArgs {
  SyntheticProbeOptions o;
  std::string input = "scene";
  std::string size = "512x512";
  std::string output;
};

struct SynthWalkthroughArgs {
  WalkthroughOptions o;             // fps, speed, rays and the bright-RGB record bound directly
  std::string output_dir;
  int probe_size = 128;             // latlong width of the query probes
  int samples = 4;                  // per pixel edge
  bool no_mean_code = false;        // the camera does not report its metered mean
};

int run_synth_scene(const SynthSceneArgs& args, const Output& out) {
  const auto layout = optional_layout(args.layout, "--layout").value_or(Layout::LatLong);
  refuse_misplaced_geometry(layout, args.size, args.nside);
  int w = 0, h = 0;
  target_geometry(layout, args.size, given_nside(args.nside) > 0 ? args.nside : 128, nullptr, &w, &h);
  SceneOptions so;
  if (!(args.sun_scale >= 0) || !std::isfinite(args.sun_scale))  // inf wrote a map of infinite pixels
    throw InputError(fmt::format("--sun-scale must be a finite number >= 0, got {}", args.sun_scale));
  if (args.no_sun && args.sun_scale != SynthSceneArgs{}.sun_scale) throw InputError("--sun-scale and --no-sun: give one");
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
  SequenceOptions so = args.o;
  so.scenario = *scenario;
  check_frame_count("--frames", so.frames);
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
  SyntheticBoardsOptions o = args.o;
  o.board = board_from(args.board, args.square_mm);
  if (!args.camera.empty()) o.camera = read_camera_model(args.camera);
  if (o.views < 1) throw InputError("--views must be at least 1");
  check_count("--views", o.views, limits().max_frames, "views", "each is an image file");
  const SyntheticBoards b = synthesize_boards(o);
  write_synthetic_boards(args.output_dir, o, b);
  say(out, "{}: {} views of a {}x{} board through {} ({}x{}), truth.json\n", args.output_dir, b.images.size(),
      o.board.cols, o.board.rows, o.camera.lensmodel, o.camera.width, o.camera.height);
  emit_json(out, {{"output", args.output_dir}, {"views", b.images.size()}});
  return 0;
}

int run_synth_bracket(const SynthBracketArgs& args, const Output& out) {
  SyntheticBracketOptions o = args.o;
  if (!args.exposure_times.empty()) o.exposure_seconds = parse_numbers(args.exposure_times, "--exposure-times");
  o.response = curve_from(args.response);
  o.add_noise = !args.no_noise;
  if (args.no_noise && o.seed != SynthBracketArgs{}.o.seed) throw InputError("--seed seeds the noise, and --no-noise has none");
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
  SyntheticProbeOptions o = args.o;
  parse_image_size(args.size, "--size", &o.width, &o.height);
  check_frame_count("--frames", o.frames);
  const EnvMap world = args.input == "scene" ? render_scene(describe_scene(), Layout::LatLong, 1024, 512)
                                             : read_envmap(args.input);
  const nlohmann::json truth = write_synthetic_probe(world, args.input, o, args.output);
  say(out, "{}: synthetic {} probe {}x{}{}\n", args.output, o.type, o.width, o.height,
      o.frames > 1 ? fmt::format(", {} frames, truth.json", o.frames) : "");
  emit_json(out, truth);
  return 0;
}

int run_synth_walkthrough(const SynthWalkthroughArgs& args, const Output& out) {
  if (args.probe_size < 8 || args.probe_size % 2) throw InputError(fmt::format("--probe-size must be even and >= 8, got {}", args.probe_size));
  if (args.o.rays_x < 2) throw InputError(fmt::format("--rays must be >= 2, got {}", args.o.rays_x));
  check_image_size("--probe-size", args.probe_size, args.probe_size / 2, "probe");
  check_image_size("--rays", args.o.rays_x, args.o.rays_x, "ray grid");
  check_count("--samples", args.samples, 64, "rays a pixel edge", "every probe pixel traces samples^2 rays");
  const Room room = default_room();
  WalkthroughOptions o = args.o;
  o.record_mean_code = !args.no_mean_code;
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
            f.opt("--bit-depth", a->o.bit_depth, "8 or 16");
            f.opt("--shake", a->o.shake_px, "Camera shake, max px per frame");
            f.flag("--moving-object", a->o.moving_object, "A bright square moving between frames");
            f.opt("--seed", a->o.seed, "Noise seed");
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
            f.opt("--type", a->o.type, "mirrorball|fisheye");
            f.opt("--size", a->size, "Image WxH");
            f.opt("--radius", a->o.radius_px, "Ball radius, px");
            f.opt("--distance", a->o.distance_in_radii, "Camera distance in ball radii (default orthographic)");
            f.opt("--fov", a->o.fov_deg, "Fisheye field of view, deg");
            f.opt("--noise", a->o.noise_relative, "Relative Gaussian noise");
            f.opt("--frames", a->o.frames, "Frames (a jittered sequence)");
            f.opt("--jitter", a->o.jitter_px, "Ball centre jitter per frame, px");
            f.opt("--seed", a->o.seed, "Noise seed");
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
         f.opt("--frames", a->o.frames, "Number of frames");
         f.opt("--fps", a->o.frame_rate_hz, "Frame rate (flicker aliasing depends on it)");
         f.opt("--seed", a->o.seed, "Noise seed");
         f.opt("--size", a->size, "Resample the base to WxH first");
         f.output(a->output_dir, "Output directory (frame_0000.exr ..., truth.json)");
         return [a](const Output& out) { return run_synth_sequence(*a, out); };
       }},
      {"synth boards", "Chessboard views rendered through a known camera (ground truth)",
       "lightprobe synth boards --views 10 -o boards/\nlightprobe calib geometric boards/board_*.png --board 9x6 --square 30 -o camera.yaml",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<SynthBoardsArgs>();
         f.opt("--views", a->o.views, "Number of views");
         f.opt("--board", a->board, "COLSxROWS inner corners");
         f.opt("--square", a->square_mm, "Square size, mm");
         f.opt("--noise", a->o.noise_sigma, "Image noise (0..1 units)");
         f.opt("--fov", a->o.field_deg, "Image circle, deg (0: the model's own domain)");
         f.opt("--camera", a->camera, "Camera model file (default: 190 deg Kannala-Brandt 1280x960)");
         f.opt("--seed", a->o.seed, "Seed");
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
         f.opt("--fps", a->o.fps, "Camera frame rate");
         f.opt("--speed", a->o.speed, "Walking speed, m/s");
         f.opt("--rays", a->o.rays_x, "Camera rays across the frame");
         f.opt("--probe-size", a->probe_size, "Latlong width of the query probes");
         f.opt("--samples", a->samples, "Probe rays per pixel edge");
         f.flag("--no-mean-code", a->no_mean_code, "The camera does not report its metered mean (AE assumed on target)");
         f.flag("--bright-rgb", a->o.record_bright_rgb, "Record the brightest pixels' colour");
         return [a](const Output& out) { return run_synth_walkthrough(*a, out); };
       }},
  };
}

}  // namespace lp::cli
