// probe unwrap, probe register: mirror-ball and fisheye probes -> maps.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <memory>
#include <optional>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/heap_tuning.h"
#include "core/limits.h"
#include "core/image_io.h"
#include "core/map_sequence.h"
#include "core/progress.h"
#include "core/warnings.h"
#include "calib/colour_match.h"
#include "hdr/bracket.h"
#include "hdr/response.h"
#include "probe/ball_register.h"
#include "probe/camera_unwrap.h"
#include "probe/fill.h"
#include "probe/fisheye.h"
#include "probe/mirror_ball.h"
#include "probe/stabilise.h"
#include "probe/unwrap_sequence.h"

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
  std::string codes;                // camera images: srgb, linear, or a response.json (hdr response)
  std::string vignetting;           // calib vignetting's file: divided out before the unwrap
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

void target_size(const std::string& layout_name, const std::string& size, int nside, Layout* layout, int* w, int* h) {
  const auto l = layout_from_string(layout_name);
  if (!l) throw InputError(fmt::format("--layout: unknown layout '{}' (latlong, hemisphere, healpix)", layout_name));
  *layout = *l;
  refuse_misplaced_geometry(*l, size, nside);
  if (*l == Layout::Healpix) {
    *w = given_nside(nside) > 0 ? nside : 64;
    *h = 1;
    check_nside("--nside", *w);
  } else if (!size.empty()) {
    parse_image_size(size, "--size", w, h);
  } else if (*l == Layout::Hemisphere) {
    *w = 360, *h = 90;
  } else {
    *w = 1024, *h = 512;
  }
}

UnwrapSequenceOptions unwrap_options(const ProbeUnwrapArgs& a) {
  UnwrapSequenceOptions o;
  if (a.type == "mirrorball") o.type = ProbeType::MirrorBall;
  else if (a.type == "fisheye") o.type = ProbeType::Fisheye;
  else throw InputError(fmt::format("--type must be mirrorball or fisheye, got '{}'", a.type));
  if (o.type == ProbeType::MirrorBall && !a.camera.empty())
    throw InputError("--camera applies only to --type fisheye (a ball is unwrapped from its silhouette; --fov, --distance "
                     "give the camera)");
  target_size(a.layout, a.size, a.nside, &o.layout, &o.width, &o.height);
  o.fill = a.fill;
  // 0 is each one's default (orthographic; no field of view); below it is a typo, which
  // the unwrap ignored (`--distance -3` gave an orthographic map with exit 0).
  if (!(a.distance >= 0)) throw InputError(fmt::format("--distance must be 0 (orthographic) or more, got {}", a.distance));
  if (!(a.fov >= 0)) throw InputError(fmt::format("--fov must be a field of view in degrees, got {}", a.fov));
  if (a.distance > 0) o.ball_camera.distance_in_radii = a.distance;
  if (a.fov > 0) o.ball_camera.fov_deg = a.fov;
  // Below 1 % no real mirror: 1e-300 divided the map to infinity, with exit 0.
  if (!(a.reflectivity >= 0.01 && a.reflectivity <= 1))
    throw InputError(fmt::format("--reflectivity must be in [0.01, 1] (a chrome ball reflects about 0.6), got {}", a.reflectivity));
  o.ball_camera.reflectivity = a.reflectivity;
  o.ball_camera.fresnel = a.fresnel;
  if (!a.ball.empty()) {
    const auto v = parse_numbers(a.ball, "--ball", 3);
    o.ball = BallInImage{v[0], v[1], v[2]};
    // Given, not found: unwrapped as asked, but a ball find_ball would refuse as too small
    // holds too few pixels for the map to be more than interpolation.
    if (const double least = FindBallOptions{}.min_radius_px; v[2] > 0 && v[2] < least)
      warn(fmt::format("--ball radius {:g} px: a ball under {:g} px holds under ~200 pixels of the scene; the map "
                       "is mostly interpolation",
                       v[2], least));
  }
  o.blind_spot_deg = a.blind_spot_deg;
  if (!a.camera.empty()) o.camera = read_camera_model(a.camera);
  o.fisheye_fov_deg = a.fov;
  // Without either, the lens was guessed (equidistant, 180 deg, its circle inscribed in the
  // frame) and the map written with exit 0: a real lens is none of these.
  if (o.type == ProbeType::Fisheye && !o.camera && !(a.fov > 0))
    throw InputError("--type fisheye needs the lens: --camera MODEL (from calib geometric), or --fov DEG for an ideal "
                     "equidistant lens whose image circle fits the frame's short side");
  // What the other probe type reads is refused, not ignored: `--type fisheye --reflectivity
  // 0.6` wrote a map no darker, with exit 0.
  const ProbeUnwrapArgs d;
  if (o.type == ProbeType::Fisheye)
    for (const auto& [given, option] : {std::pair{a.distance != d.distance, "--distance"}, std::pair{!a.ball.empty(), "--ball"},
                                        std::pair{a.reflectivity != d.reflectivity, "--reflectivity"},
                                        std::pair{a.fresnel != d.fresnel, "--fresnel"},
                                        std::pair{a.blind_spot_deg != d.blind_spot_deg, "--blind-spot"}})
      if (given) throw InputError(fmt::format("{} applies only to --type mirrorball (a ball's geometry)", option));
  if (a.static_probe && !a.stabilise) throw InputError("--static-probe applies only with --smooth-track");
  if (a.fixed_ball && a.stabilise) throw InputError("--fixed-ball and --smooth-track: give one (no tracking, or a smoothed track)");
  if (!a.rotation.empty()) o.world_from_probe = parse_rotation(a.rotation);
  o.smooth_track = a.stabilise;
  o.static_probe = a.static_probe;
  o.fixed_geometry = a.fixed_ball;
  if (!a.colour_match.empty()) o.colour = load_colour_match(a.colour_match);
  if (!a.codes.empty()) o.codes = code_curve(a.codes);
  if (!a.vignetting.empty()) {
    o.vignetting = load_vignetting(a.vignetting);
    o.vignetting_file = a.vignetting;
  }
  return o;
}

nlohmann::json report_json(const ProbeUnwrapArgs& a, const UnwrapSequenceOptions& o, const UnwrapSequenceReport& r) {
  nlohmann::json per_frame = nlohmann::json::array();
  for (const auto& f : r.frames) {
    nlohmann::json fj = {{"file", f.file}};
    if (f.ball) {
      fj["ball"] = {f.ball->cx, f.ball->cy, f.ball->radius_px};
      fj["ball_raw"] = {f.ball_detected->cx, f.ball_detected->cy, f.ball_detected->radius_px};
      fj["ball_source"] = !a.ball.empty() ? "given" : f.ball_recorded ? "recorded" : "found";
    }
    if (const auto& b = f.ball_fit)  // how the ball was found: sub-pixel or not, the fit's standard errors
      fj["ball_fit"] = {{"subpixel", b->subpixel}, {"sigma_centre_px", b->sigma_centre_px}, {"sigma_radius_px", b->sigma_radius_px},
                        {"noise_sigma_centre_px", b->noise_sigma_centre_px},
                        {"noise_sigma_radius_px", b->noise_sigma_radius_px}, {"rim_agreement", b->rim_agreement},
                        {"searched_from_previous", f.ball_seeded}, {"warning", ball_fit_warning(*b)}};
    fj["valid_fraction"] = f.valid_fraction;
    if (!f.codes.empty()) fj["codes"] = f.codes, fj["clipped_fraction"] = f.clipped_fraction;
    if (f.circle) fj["circle"] = {f.circle->cx, f.circle->cy, f.circle->r};
    per_frame.push_back(fj);
  }
  nlohmann::json report = {{"output", a.output}, {"type", a.type}, {"frames", r.frames.size()},
                           {"layout", a.layout}, {"width", o.width}, {"height", o.height},
                           {"milliseconds", 1e3 * r.unwrap_seconds}, {"per_frame", per_frame}};
  if (a.fill) report["fill_power_share"] = r.fill_power_share;
  if (r.map_jitter_deg) report["map_jitter_deg"] = *r.map_jitter_deg;
  if (r.detected.cx.size() > 1) {
    report["detected_jitter_px"] = residual_jitter_px(r.detected);
    report["used_jitter_px"] = residual_jitter_px(r.used);
  }
  return report;
}

}  // namespace

// Below this share of valid solid angle an unwrapped map earns a warning.
constexpr double kFewValidWarning = 0.05;

int run_probe_unwrap(const ProbeUnwrapArgs& args, const Output& out) {
  const std::vector<std::string> files = find_images(args.inputs);
  UnwrapSequenceOptions o = unwrap_options(args);
  if (o.vignetting && is_camera_image_file(files.front()))
    if (const std::string w = aperture_mismatch(*o.vignetting, read_exif_exposure(files.front()).f_number,
                                                args.vignetting, files.front());
        !w.empty())
      warn(w);
  // The track's options act across frames, on a ball or circle that is found: with one frame,
  // or a ball given by hand, they changed nothing, with exit 0.
  for (const auto& [given, option] : {std::pair{args.stabilise, "--smooth-track"}, std::pair{args.static_probe, "--static-probe"},
                                      std::pair{args.fixed_ball, "--fixed-ball"}}) {
    if (given && files.size() < 2)
      throw InputError(fmt::format("{} acts on a sequence's track, and {} is one frame", option, files.front()));
    if (given && o.ball)
      throw InputError(fmt::format("{} acts on the ball found in each frame; --ball gives one for every frame", option));
  }
  // A sequence is written as a folder of EXR frames: a map file's name for it is a slip.
  if (files.size() > 1 && is_radiance_file(args.output))
    throw InputError(fmt::format("{}: {} frames are written as a folder of frame_NNNN.exr; give a folder, not a map file",
                                 args.output, files.size()));
  // Photos in Adobe RGB or Display P3 were read as sRGB: their colours, as hdr fuse reads a
  // bracket's, from the first photo's ICC profile.
  std::optional<ColourProfile> profile;
  if (!files.empty() && is_camera_image_file(files.front())) profile = read_colour_profile(files.front());
  if (profile) o.to_rec709 = profile->to_rec709;
  const bool sequence = files.size() > 1;
  if (sequence) make_output_directory(args.output);
  if (sequence) keep_heap_for_reuse();  // each frame allocates and frees the same large buffers
  Progress progress("probe unwrap", 2 * files.size(), out.progress && sequence);
  const UnwrapSequenceReport r = unwrap_probe_sequence(
      files, o,
      [&](size_t i, EnvMap& map) {
        write_envmap(sequence ? (fs::path(args.output) / fmt::format("frame_{:04d}.exr", i)).string() : args.output, map);
      },
      [&] { progress.advance(); });
  progress.finish();
  // An LDR photo's lights are where it clips: said once, for the frame that clips most.
  const UnwrapSequenceReport::Frame* most_clipped = nullptr;
  size_t clipped_frames = 0, radiance_frames = 0;
  for (const auto& f : r.frames) {
    radiance_frames += f.codes.empty();
    if (!(f.clipped_fraction > 0)) continue;
    ++clipped_frames;
    if (!most_clipped || f.clipped_fraction > most_clipped->clipped_fraction) most_clipped = &f;
  }
  if (most_clipped)
    std::fprintf(stderr,
                 "lightprobe: warning: %s: %.3g %% of its pixels are at the top code%s: their light is clipped (at "
                 "least that bright); fuse a bracket (hdr fuse) to measure it\n",
                 most_clipped->file.c_str(), 100 * most_clipped->clipped_fraction,
                 clipped_frames > 1 ? fmt::format(" (the most of {} clipped frames)", clipped_frames).c_str() : "");
  if (!args.codes.empty() && radiance_frames > 0)
    std::fprintf(stderr, "lightprobe: warning: %s: radiance already; --codes applies to camera images and is not used\n",
                 radiance_frames == r.frames.size() ? args.inputs[0].c_str()
                                                    : fmt::format("{} of the frames", radiance_frames).c_str());
  for (const auto& f : r.frames) {  // a sliver of a probe: a map, but mostly holes
    if (f.ball_fit && !ball_fit_warning(*f.ball_fit).empty())
      std::fprintf(stderr, "lightprobe: warning: %s: %s\n", f.file.c_str(), ball_fit_warning(*f.ball_fit).c_str());
    if (f.valid_fraction < kFewValidWarning)
      std::fprintf(stderr, "lightprobe: warning: %s: only %.1f %% of the map is valid (is the probe cut by the image edge?)\n",
                   f.file.c_str(), 100 * f.valid_fraction);
  }
  const UnwrapSequenceReport::Frame& first = r.frames[0];
  if (first.ball && !sequence)
    say(out, "{}: ball at ({:.2f}, {:.2f}) r {:.2f} px{} -> {} {}x{}{}\n", args.output, first.ball->cx, first.ball->cy,
        first.ball->radius_px, first.ball_recorded && args.ball.empty() ? " (recorded by probe register)" : "",
        args.layout, o.width, o.height,
        args.fill ? fmt::format(", fill holds {:.2f} % of the power", 100 * r.fill_power_share) : "");
  else
    say(out, "{}: {} frame(s) -> {} {}x{} in {:.0f} ms{}\n", args.output, files.size(), args.layout, o.width, o.height,
        1e3 * r.unwrap_seconds,
        r.detected.cx.size() > 1
            ? fmt::format("; probe centre moved {:.3f} px per frame, unwrapped map {:.4f} deg per frame",
                          residual_jitter_px(r.detected), r.map_jitter_deg.value_or(0))
            : "");
  nlohmann::json report = report_json(args, o, r);
  if (profile) {
    report["colour_profile"] = profile->name;
    say(out, "{}: colours converted from the photos' ICC profile ('{}') to Rec. 709\n", args.output, profile->name);
  }
  emit_json(out, report);
  return 0;
}

// The photos' EXIF exposures, which the registered PNGs do not carry, as the text of an
// exposures.csv to write beside them (`hdr fuse registered/*.png --exposure-times
// registered/exposures.csv`): each time, scaled by ISO / f-number^2 relative to the first
// photo's where those differ, as read_bracket would. nullopt when a photo is no camera
// image, records no time, or has EXIF that cannot be read: the registration needs none.
std::optional<std::string> registered_exposures_csv(const std::vector<std::string>& images,
                                                    const std::vector<std::string>& names) {
  std::vector<ExifExposureSettings> s;
  for (const std::string& f : images) {
    if (!is_camera_image_file(f)) return std::nullopt;
    try {
      s.push_back(read_exif_exposure(f));
    } catch (const InputError&) {
      return std::nullopt;
    }
    if (!s.back().seconds) return std::nullopt;
  }
  Bracket b;
  for (const auto& e : s) b.exposure_seconds.push_back(*e.seconds);
  const std::vector<double> times = b.exposure_seconds;
  b.frames.resize(s.size());
  b.paths = images;
  fold_iso_and_aperture(b, s);
  // The PNGs lose the photos' ISO and f-number, so the times carry them: at ISO 100 and f/1,
  // the registered bracket fuses to the map the photos themselves fuse to.
  const double scale = reference_exposure_scale(b);
  for (double& t : b.exposure_seconds) t /= scale;
  std::string csv = "file,exposure_s\n";
  if (b.exposure_seconds != times)
    csv = "# seconds x (ISO / 100) / f-number^2: the exposure at ISO 100 and f/1, as hdr fuse scales maps\n" + csv;
  for (size_t i = 0; i < names.size(); ++i) csv += fmt::format("{},{:.6g}\n", names[i], b.exposure_seconds[i]);
  return csv;
}

int run_probe_register(const ProbeRegisterArgs& args, const Output& out) {
  // Differently cropped photos of one ball (a bracket shot by hand): find the ball in
  // each, then resample every photo so the ball is centred with one radius, code values
  // untouched, ready for `hdr fuse`.
  if (args.images.size() < 2) throw InputError("probe register needs at least two photos of the ball");
  if (args.size < 32) throw InputError("--size must be at least 32 px");
  keep_heap_for_reuse();  // find_ball's images, freed and allocated again for each photo
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
  std::vector<RgbImage> registered = register_balls(frames, balls, args.size);
  // Each photo records where the ball now is (PNG tEXt, EXR attribute; hdr fuse carries it):
  // probe unwrap takes it instead of searching for the rim of a ball pasted on a canvas, which
  // found no sub-pixel rim on kartik's photos and missed the centre by 0.8 px.
  const BallInImage target = registered_ball(args.size);
  for (RgbImage& r : registered) r.mirror_ball = std::array<double, 3>{target.cx, target.cy, target.radius_px};
  // Each photo keeps what it holds: 8- or 16-bit codes as a PNG of that depth, radiance as
  // EXR. All went to 8-bit PNG: a 16-bit bracket lost 8 bits, radiance was clipped at 1.
  std::vector<std::string> names;
  for (size_t i = 0; i < registered.size(); ++i) {
    names.push_back(fs::path(args.images[i]).stem().string() + (registered[i].code_bits > 0 ? ".png" : ".exr"));
    // a/ball.jpg and b/ball.jpg: one file overwrote the other, and exposures.csv named it twice.
    for (size_t j = 0; j < i; ++j)
      if (names[j] == names[i])
        throw InputError(fmt::format("{} and {} would both be written as {}: give the photos different names",
                                     args.images[j], args.images[i], names[i]));
  }
  // Read before anything is written: nothing here can fail after the photos are.
  const std::optional<std::string> exposures = registered_exposures_csv(args.images, names);
  make_output_directory(args.output_dir);
  for (size_t i = 0; i < registered.size(); ++i) {
    const RgbImage& r = registered[i];
    const std::string path = (fs::path(args.output_dir) / names[i]).string();
    // The part of the ball that lay outside the photo: transparent in the PNG (no data, which
    // hdr fuse takes from the other photos), said with how much.
    if (r.code_bits > 0 && !r.valid.empty()) {
      size_t lost = 0, inside = 0;
      for (int y = 0; y < r.height; ++y)
        for (int x = 0; x < r.width; ++x) {
          const double dx = x + 0.5 - target.cx, dy = y + 0.5 - target.cy;
          if (dx * dx + dy * dy > target.radius_px * target.radius_px) continue;
          ++inside;
          lost += r.valid[size_t(y) * size_t(r.width) + size_t(x)] == 0;
        }
      if (lost > 0)
        warn(fmt::format("{}: {} pixels of the ball ({:.2f} %) lay outside the photo: transparent (no data) in {}",
                         args.images[i], lost, 100.0 * double(lost) / double(std::max<size_t>(1, inside)), names[i]));
    }
    if (r.code_bits > 0) write_code_image(path, r, r.code_bits);
    else write_rgb_image(path, r);
    found[i]["output"] = names[i];
  }
  // An exposures.csv of an earlier run would name these photos with another set's times.
  const fs::path csv = fs::path(args.output_dir) / "exposures.csv";
  if (exposures) write_file_atomically(csv.string(), *exposures);
  else fs::remove(csv);
  const BallInImage& ball = target;
  say(out, "{}: {} photos registered to {}x{}, ball at ({:.1f}, {:.1f}) r {:.1f} px\n", args.output_dir,
      registered.size(), args.size, args.size, ball.cx, ball.cy, ball.radius_px);
  emit_json(out, {{"output", args.output_dir}, {"frames", found},
                  {"registered_ball", {ball.cx, ball.cy, ball.radius_px}}});
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
         f.opt("--fov", a->fov, "fisheye: field of view (deg) of an ideal equidistant lens whose image circle fits the frame's short side, or the image circle of --camera (without it, the circle found in the frame); " "ball: the camera's field of view");
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
         f.opt("--codes", a->codes, "Camera images (PNG, JPEG, TIFF): how codes encode light, made linear before unwrapping: srgb (8-bit default), linear, or a response.json from hdr response; 16-bit images need it");
         f.opt("--vignetting", a->vignetting, "The lens's vignetting (calib vignetting), divided out of each image before unwrapping");
         f.opt("--rotation", a->rotation, "Probe to world: 'yaw,pitch,roll' degrees or 9 numbers (recorded in the map)");
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
