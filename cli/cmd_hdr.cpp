// hdr response, hdr fuse: what a camera records -> radiance a probe can trust (absolute
// after photometric calibration).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <memory>

#include "calib/photometric.h"
#include "calib/vignetting.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/chromaticities.h"
#include "core/error.h"
#include "core/warnings.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "hdr/align.h"
#include "hdr/bracket.h"
#include "hdr/deghost.h"
#include "hdr/log_sensor.h"
#include "hdr/merge.h"
#include "hdr/response.h"

namespace lp::cli {

struct HdrResponseArgs {
  std::vector<std::string> images;
  std::string exposure_times;       // "1/10,1/40" or a list file; default: EXIF
  std::string method = "debevec";   // debevec|robertson
  double lambda = 50;
  std::string ignore_colour;        // "r,g,b" of registration borders to leave out
  std::string align = "none";       // none|mtb|ecc: register hand-held frames before fitting
  int max_shift = 0;                // px --align searches; 0: AlignOptions' automatic value
  std::string output;
};

struct HdrFuseArgs {
  std::vector<std::string> images;
  std::string exposure_times;
  std::string response;             // saved response; default: recovered from this bracket
  bool linear = false;              // a linear sensor: no response curve
  std::string photometric;          // calibration: absolute units (or a log sensor's decode)
  std::string vignetting;           // calib vignetting's file: divided out of the radiance
  std::string align = "none";       // none|mtb|ecc
  int max_shift = 0;                // px --align searches; 0: AlignOptions' automatic value
  bool deghost = false;
  bool no_exposure_weighting = false;
  std::string ignore_colour;
  std::string output;
};

namespace {

namespace fs = std::filesystem;

// --exposure-times: a list of seconds (1/40 allowed) or a file (one per line, or CSV: by
// file name where it names them).
std::optional<std::vector<double>> exposure_times(const std::string& text, const std::vector<std::string>& images) {
  if (text.empty()) return std::nullopt;
  std::error_code ec;
  if (fs::is_regular_file(text, ec)) return exposure_times_for(text, images);
  return parse_numbers(text, "--exposure-times");
}

std::optional<std::array<uint8_t, 3>> ignore_colour(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const auto v = parse_numbers(text, "--ignore-colour", 3);
  std::array<uint8_t, 3> c{};
  for (int i = 0; i < 3; ++i) {
    if (!(v[size_t(i)] >= 0 && v[size_t(i)] <= 255) || v[size_t(i)] != std::floor(v[size_t(i)]))
      throw InputError(fmt::format("--ignore-colour takes whole 8-bit codes 0..255 per channel, got '{}'", text));
    c[size_t(i)] = uint8_t(v[size_t(i)]);
  }
  return c;
}

// --max-shift: pixels, 0 for automatic, and only with --align; checked before any input is read.
void check_max_shift(const std::string& align, int max_shift) {
  if (max_shift < 0) throw InputError(fmt::format("--max-shift takes pixels, at least 1 (0: automatic), got {}", max_shift));
  if (max_shift != 0 && align == "none") throw InputError("--max-shift is a limit of --align mtb|ecc, which is not given");
}

// Registers the bracket's frames onto the middle exposure (--align mtb|ecc); returns the
// shift per frame for the report.
nlohmann::json align_bracket(Bracket& bracket, const std::string& method, const std::string& ignore, int max_shift) {
  AlignOptions ao;
  if (method == "mtb") ao.method = AlignOptions::Method::Mtb;
  else if (method == "ecc") ao.method = AlignOptions::Method::Ecc;
  else throw InputError(fmt::format("--align must be none, mtb or ecc, got '{}'", method));
  ao.max_shift_px = max_shift;
  ao.ignore_colour = ignore_colour(ignore);
  AlignReport ar;
  bracket.frames = align_frames(bracket.frames, bracket.exposure_seconds, ao, &ar);
  bracket.codes.clear();  // the file's 8-bit codes are not the shifted frames': merge the floats
  nlohmann::json shifts = nlohmann::json::array();
  for (const auto& s : ar.shift_per_frame) shifts.push_back({s[0], s[1], s[2]});
  return shifts;
}

}  // namespace

int run_hdr_response(const HdrResponseArgs& args, const Output& out) {
  check_max_shift(args.align, args.max_shift);
  Bracket bracket = read_bracket(args.images, exposure_times(args.exposure_times, args.images));
  const auto t0 = Clock::now();
  nlohmann::json alignment;
  if (args.align != "none") alignment = align_bracket(bracket, args.align, args.ignore_colour, args.max_shift);
  CameraResponse response;
  if (args.method == "debevec") {
    DebevecOptions o;
    o.lambda = args.lambda;
    o.ignore_colour = ignore_colour(args.ignore_colour);
    response = recover_debevec(bracket, o);
  } else if (args.method == "robertson") {
    if (args.lambda != HdrResponseArgs{}.lambda)
      throw InputError("--lambda is Debevec's smoothness weight; Robertson's method has none");
    RobertsonOptions o;
    o.ignore_colour = ignore_colour(args.ignore_colour);
    response = recover_robertson(bracket, o);
  } else {
    throw InputError(fmt::format("--method must be debevec or robertson, got '{}'", args.method));
  }
  const double ms = 1e3 * seconds_since(t0);
  save_response(args.output, response);
  say(out, "{}: {} response from {} frames ({} levels) in {:.1f} ms\n", args.output, args.method,
      bracket.frames.size(), response.levels, ms);
  nlohmann::json report = {{"output", args.output}, {"method", args.method}, {"frames", bracket.frames.size()},
                            {"levels", response.levels}, {"milliseconds", ms}};
  if (args.align != "none") report["alignment"] = alignment;
  emit_json(out, report);
  return 0;
}

int run_hdr_fuse(const HdrFuseArgs& args, const Output& out) {
  std::optional<PhotometricCalibration> photometric;
  if (!args.photometric.empty()) photometric = load_photometric(args.photometric);
  std::optional<VignettingModel> vignetting;
  if (!args.vignetting.empty()) vignetting = load_vignetting(args.vignetting);
  nlohmann::json report = {{"output", args.output}};
  RgbImage radiance;
  const auto t0 = Clock::now();
  if (photometric && photometric->log_sensor) {
    // A logarithmic sensor: one frame, decoded with the fitted value = a + b ln L.
    if (args.images.size() != 1) throw InputError(args.photometric + ": a log-sensor calibration decodes one frame, not a bracket");
    // The bracket's options mean nothing to one decoded frame: refused, not ignored.
    const HdrFuseArgs d;
    for (const auto& [given, option] :
         {std::pair{args.exposure_times != d.exposure_times, "--exposure-times"}, std::pair{args.response != d.response, "--response"},
          std::pair{args.linear != d.linear, "--linear"}, std::pair{args.align != d.align, "--align"},
          std::pair{args.max_shift != d.max_shift, "--max-shift"},
          std::pair{args.deghost != d.deghost, "--deghost"},
          std::pair{args.no_exposure_weighting != d.no_exposure_weighting, "--no-exposure-weighting"},
          std::pair{args.ignore_colour != d.ignore_colour, "--ignore-colour"}})
      if (given)
        throw InputError(fmt::format("{} is an option of brackets; {} is a log-sensor calibration, which decodes one frame",
                                     option, args.photometric));
    if (is_radiance_file(args.images[0]))
      throw InputError(args.images[0] + ": a log sensor's frame is its camera codes (PNG, TIFF, JPEG), not a float image");
    RgbImage frame = read_rgb_image(args.images[0]);
    if (vignetting) {  // turned as the frame was
      vignetting = vignetting_as_shown(*vignetting, frame.orientation);
      check_vignetting_size(*vignetting, frame.width, frame.height, args.images[0] + " (" + args.vignetting + ")");
    }
    radiance = decode_log_sensor(frame, *photometric);
    radiance.orientation = frame.orientation;  // the turn it was shown by, recorded
    radiance.mirror_ball = frame.mirror_ball;  // where probe register put the ball
    report["mode"] = "log-sensor";
  } else {
    check_max_shift(args.align, args.max_shift);
    Bracket bracket = read_bracket(args.images, exposure_times(args.exposure_times, args.images));
    if (vignetting) {  // before the merge's seconds are spent; turned as the frames were
      vignetting = vignetting_as_shown(*vignetting, bracket.orientation);
      check_vignetting_size(*vignetting, bracket.frames[0].width, bracket.frames[0].height,
                            args.images[0] + " (" + args.vignetting + ")");
      if (const std::string w = aperture_mismatch(*vignetting, bracket.f_number, args.vignetting, "the bracket's frames");
          !w.empty())
        warn(w);
    }
    if (!args.response.empty() && (args.linear || bracket.linear))
      throw InputError(fmt::format("--response {} and {} contradict: a linear bracket has no response curve", args.response,
                                   args.linear ? "--linear" : "RAW frames (linear)"));
    // Aligned first: a response recovered from frames that are not registered is fitted to
    // misregistered pixels (a hand-held bracket 18 px apart: a curve flat over 70 codes).
    if (args.align != "none") report["alignment"] = align_bracket(bracket, args.align, args.ignore_colour, args.max_shift);
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
    MergeOptions mo;
    mo.ignore_colour = ignore_colour(args.ignore_colour);
    mo.exposure_weighting = !args.no_exposure_weighting;
    if (args.deghost) {
      std::array<std::vector<float>, 3> g = response.log_exposure;
      mo.frame_masks = ghost_masks(bracket.frames, bracket.exposure_seconds, &g, {});
      report["ghost_pixels_dropped"] = count_dropped(mo.frame_masks);
    }
    MergeReport mr;
    radiance = merge_bracket(bracket, response, mo, &mr);
    radiance.orientation = bracket.orientation;  // recorded: a fisheye unwrap turns it back
    radiance.mirror_ball = bracket.mirror_ball;  // recorded: probe unwrap takes it, no search
    if (bracket.mirror_ball) report["mirror_ball"] = *bracket.mirror_ball;
    if (bracket.to_rec709) {  // the frames' ICC profile, a matrix one other than sRGB
      apply_colour_matrix(radiance.rgb, *bracket.to_rec709);
      report["colour_profile"] = bracket.colour_profile;
      say(out, "{}: colours converted from the frames' ICC profile ('{}') to Rec. 709\n", args.output,
          bracket.colour_profile);
    }
    // At ISO 100 and f/1, where the frames record their settings: one photometric k then
    // holds for every setting of the camera (hdr/bracket.h reference_exposure_scale).
    if (const double scale = reference_exposure_scale(bracket); scale != 1) {
      for (float& v : radiance.rgb) v = float(v * scale);
      report["exposure_reference"] = {{"iso", bracket.iso}, {"f_number", bracket.f_number}, {"scale", scale}};
      say(out, "{}: scaled x{:.4g} to ISO 100 and f/1 from the frames' {}\n", args.output, scale,
          bracket.iso > 0 && bracket.f_number > 0 ? fmt::format("ISO {:g}, f/{:g}", bracket.iso, bracket.f_number)
          : bracket.iso > 0                       ? fmt::format("ISO {:g} (no f-number recorded)", bracket.iso)
                                                  : fmt::format("f/{:g} (no ISO recorded)", bracket.f_number));
    }
    report["saturated_everywhere"] = mr.saturated_everywhere;
    report["black_everywhere"] = mr.black_everywhere;
    report["frames"] = bracket.frames.size();
    if (bracket.white_level) report["white_level"] = bracket.white_level;
    report["mode"] = "bracket";
    if (mr.saturated_everywhere)
      say(out, "{}: {} pixels are saturated in every frame (their radiance is a lower bound)\n", args.output,
          mr.saturated_everywhere);
  }
  // The lens's falloff out before the absolute scale: a photometric calibration is fitted on
  // readings of corrected probes (docs/hdr.md, "Vignetting").
  if (vignetting) {
    correct_vignetting(radiance, *vignetting, args.vignetting);
    radiance.vignetting_corrected = true;
    report["vignetting"] = args.vignetting;
  }
  if (photometric && !photometric->log_sensor) {
    apply_photometric(radiance, *photometric);
    report["units"] = "radiance";
  }
  write_rgb_image(args.output, radiance);
  const double ms = 1e3 * seconds_since(t0);
  report["milliseconds"] = ms;
  say(out, "{}: {}x{} radiance ({}) in {:.0f} ms\n", args.output, radiance.width, radiance.height,
      to_string(radiance.units), ms);
  emit_json(out, report);
  return 0;
}

std::vector<Command> hdr_commands() {
  return {
      {"hdr response", "Recover a camera's response curve from brackets",
       "lightprobe hdr response IMG_1.jpg IMG_2.jpg IMG_3.jpg -o response.json",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<HdrResponseArgs>();
         f.arg("IMAGE", a->images, "Bracket frames (8/16-bit PNG, JPEG, TIFF)").required();
         f.opt("--exposure-times", a->exposure_times, "Seconds per frame ('1/40' allowed) or a list file (read by file name where it names them); default EXIF");
         f.opt("--method", a->method, "debevec|robertson");
         f.opt("--lambda", a->lambda, "Debevec smoothness weight");
         f.opt("--ignore-colour", a->ignore_colour, "r,g,b of registration borders to leave out");
         f.opt("--align", a->align, "Register hand-held frames before fitting (as hdr fuse --align): none|mtb|ecc").one_of({"none", "mtb", "ecc"});
         f.opt("--max-shift", a->max_shift, "Largest shift --align searches, px; 0: 2.5 % of the long side, at least 32");
         f.output(a->output, "response.json");
         return [a](const Output& out) { return run_hdr_response(*a, out); };
       }},
      {"hdr fuse", "Fuse a bracket (or decode a log sensor frame) into radiance",
       "lightprobe hdr fuse IMG_1.jpg IMG_2.jpg IMG_3.jpg --response response.json --align mtb -o probe.exr",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<HdrFuseArgs>();
         f.arg("IMAGE", a->images, "Bracket frames, or one frame of a log sensor").required();
         f.opt("--exposure-times", a->exposure_times, "Seconds per frame or a list file (read by file name where it names them); default EXIF");
         f.opt("--response", a->response, "Saved response (hdr response); default: recovered here");
         f.flag("--linear", a->linear, "Linear sensor: no response curve");
         f.opt("--photometric", a->photometric, "Photometric calibration: absolute units");
         f.opt("--vignetting", a->vignetting, "The lens's vignetting (calib vignetting), divided out of the radiance");
         f.opt("--align", a->align, "Align hand-held frames: none|mtb|ecc");
         f.opt("--max-shift", a->max_shift, "Largest shift --align searches, px; 0: 2.5 % of the long side, at least 32");
         f.flag("--deghost", a->deghost, "Drop moving objects from the frames that disagree");
         f.flag("--no-exposure-weighting", a->no_exposure_weighting, "Plain hat weights instead of noise-aware ones (every frame trusted alike)");
         f.opt("--ignore-colour", a->ignore_colour, "r,g,b of registration borders to leave out");
         f.output(a->output, "probe.exr");
         return [a](const Output& out) { return run_hdr_fuse(*a, out); };
       }},
  };
}

}  // namespace lp::cli
