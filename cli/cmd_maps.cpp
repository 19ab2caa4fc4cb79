// info, convert, preview: the map commands.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include "cli/commands.h"
#include "cli/report.h"
#include "core/envmap.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/map_statistics.h"
#include "core/resample.h"
#include "core/warnings.h"
#include "core/tonemap.h"
#include "hdr/bracket.h"
#include "probe/cube_map.h"

namespace lp::cli {

struct InfoArgs {
  std::vector<std::string> files;
  std::string layout;  // override
};

struct ConvertArgs {
  std::string input, output;
  std::string layout;    // target layout
  std::string size;      // WxH
  int nside = 0;
  std::string in_layout; // override of the input's layout
  std::string rotation;  // "yaw,pitch,roll" degrees or 9 numbers
  bool half = false;     // EXR half floats
};

struct PreviewArgs {
  std::string input, output;
  double percentile = 0.99;
};

namespace {

// A photo, not a map: a camera's PNG or JPEG, a fused bracket, a registered ball. What it
// holds and records (its EXIF exposure, the ball probe register put in it, the turn hdr fuse
// recorded), and what makes a map of it. `info` refused them, so a user checking a fused
// ball before unwrapping it learned only that it was no map.
nlohmann::json photo_info(const std::string& path, const Output& out) {
  const RgbImage img = read_rgb_image(path);
  const size_t n = size_t(img.width) * size_t(img.height);
  size_t valid = 0;
  for (size_t i = 0; i < n; ++i) valid += img.valid.empty() || img.valid[i];
  nlohmann::json j = {{"file", path}, {"kind", "photo"}, {"width", img.width}, {"height", img.height},
                      {"valid_fraction", n ? double(valid) / double(n) : 0.0}};
  say(out, "{}\n  photo       {}x{}, not a map: `lightprobe probe unwrap` makes a map of it (--type mirrorball or "
      "fisheye)\n",
      path, img.width, img.height);
  if (valid < n) say(out, "  valid       {:.1f} % of {} pixels (the rest hold no data)\n", 100.0 * double(valid) / double(n), n);
  if (img.code_bits > 0) {
    // Codes: how many sit at the top (clipped light) and at 0.
    size_t top = 0, black = 0;
    const float top_code = 1.0f - 0.5f / float((1 << img.code_bits) - 1);  // codes are c / (2^bits - 1)
    for (size_t i = 0; i < n; ++i) {
      if (!img.valid.empty() && !img.valid[i]) continue;
      const float* p = &img.rgb[3 * i];
      top += std::max({p[0], p[1], p[2]}) >= top_code;
      black += std::max({p[0], p[1], p[2]}) <= 0.0f;
    }
    const double clipped = valid ? double(top) / double(valid) : 0.0, dark = valid ? double(black) / double(valid) : 0.0;
    j["code_bits"] = img.code_bits;
    j["clipped_fraction"] = clipped;
    j["black_fraction"] = dark;
    say(out, "  codes       {}-bit camera codes; {:.2f} % at the top code (clipped), {:.2f} % at 0\n", img.code_bits,
        100 * clipped, 100 * dark);
    if (is_camera_image_file(path)) {
      ExifExposureSettings e;
      try {
        e = read_exif_exposure(path);
      } catch (const InputError&) {  // unreadable EXIF: the codes are still worth reporting
      }
      if (e.seconds) j["exposure_s"] = *e.seconds;
      if (e.iso > 0) j["iso"] = e.iso;
      if (e.f_number > 0) j["f_number"] = e.f_number;
      say(out, "  exposure    {}\n",
          e.seconds ? fmt::format("{:g} s{}{}", *e.seconds, e.iso > 0 ? fmt::format(", ISO {:g}", e.iso) : "",
                                  e.f_number > 0 ? fmt::format(", f/{:g}", e.f_number) : "")
                    : std::string("none in EXIF (hdr fuse needs --exposure-times)"));
    }
  } else {
    std::vector<float> y;
    for (size_t i = 0; i < n; ++i)
      if (img.valid.empty() || img.valid[i]) {
        const float* p = &img.rgb[3 * i];
        y.push_back(luminance(p[0], p[1], p[2]));
      }
    std::sort(y.begin(), y.end());
    const auto positive = std::upper_bound(y.begin(), y.end(), 0.0f);
    const double min_positive = positive != y.end() ? *positive : 0.0, max = y.empty() ? 0.0 : y.back();
    const double median = y.empty() ? 0.0 : y[y.size() / 2];
    const double stops = min_positive > 0 && max > 0 ? std::log2(max / min_positive) : 0.0;
    j["units"] = std::string(to_string(img.units));
    j["luminance"] = {{"min_positive", min_positive}, {"median", median}, {"max", max}};
    j["range_stops"] = stops;
    say(out, "  radiance    {}; luminance min>0 {:.4g}  median {:.4g}  max {:.4g}; {:.1f} stops\n", to_string(img.units),
        min_positive, median, max, stops);
  }
  j["exif_orientation"] = img.orientation;
  if (img.orientation != 1)
    say(out, "  turned      {} by EXIF Orientation {}\n", img.code_bits > 0 ? "shown" : "fused as shown", img.orientation);
  if (img.mirror_ball) {
    j["mirror_ball"] = *img.mirror_ball;
    say(out, "  ball        at ({:.2f}, {:.2f}) r {:.2f} px, recorded by probe register (probe unwrap takes it)\n",
        (*img.mirror_ball)[0], (*img.mirror_ball)[1], (*img.mirror_ball)[2]);
  }
  j["vignetting_corrected"] = img.vignetting_corrected;
  if (img.vignetting_corrected) say(out, "  lens        vignetting divided out (--vignetting)\n");
  return j;
}

}  // namespace

int run_info(const InfoArgs& args, const Output& out) {
  nlohmann::json all = nlohmann::json::array();
  for (const std::string& path : args.files) {
    ReadMapOptions ro;
    ro.layout = optional_layout(args.layout, "--layout");
    // A photo is described as one; a radiance file is a map when its layout is recorded or its
    // shape is a map's (read_envmap's rule), else read as a photo.
    if (!ro.layout && is_camera_image_file(path)) {
      all.push_back(photo_info(path, out));
      continue;
    }
    EnvMap map;
    try {
      map = read_envmap(path, ro);
    } catch (const InputError& e) {
      // read_envmap's refusal of a radiance file with no layout recorded and no map's shape.
      if (ro.layout || !is_radiance_file(path) || std::string(e.what()).find("no layout recorded") == std::string::npos)
        throw;
      all.push_back(photo_info(path, out));
      continue;
    }
    const MapStatistics s = map_statistics(map);
    nlohmann::json j = s.to_json(map);
    j["file"] = path;
    j["kind"] = "map";
    if (map.world_from_probe) {
      j["world_from_probe"] = map.world_from_probe->m;
      j["probe_yaw_pitch_roll_deg"] = yaw_pitch_roll_deg(*map.world_from_probe);
    }
    j["vignetting_corrected"] = map.vignetting_corrected;
    all.push_back(j);
    const Vec3 b = s.brightest_direction;
    say(out,
        "{}\n  layout      {} ({})\n  valid       {:.1f} % of {} pixels\n"
        "  luminance   min>0 {:.4g}  median {:.4g}  mean {:.4g}  p99 {:.4g}  max {:.4g}\n"
        "  range       {:.1f} stops\n  power       rgb ({:.5g}, {:.5g}, {:.5g})  luminance {:.5g}\n"
        "  brightest   theta {:.2f} deg, phi {:.2f} deg; top 0.1 % of pixels hold {:.1f} % of the power\n",
        path, describe_size(map), to_string(map.units), 100.0 * j["valid_fraction"].get<double>(), s.pixels,
        s.min_positive, s.median, s.mean, s.p99, s.max, s.range_stops, s.power_rgb[0], s.power_rgb[1], s.power_rgb[2],
        s.power_luminance, zenith_of(b) * 180 / M_PI, azimuth_of(b) * 180 / M_PI, 100 * s.top_power_share);
    if (map.world_from_probe) {
      // Rounding residue (1e-15 deg) printed as the 0 it is.
      const auto deg = [](double v) { return std::abs(v) < 5e-10 ? 0.0 : v; };
      const auto ypr = yaw_pitch_roll_deg(*map.world_from_probe);
      say(out, "  probe       unwrapped turned by yaw {:.4g}, pitch {:.4g}, roll {:.4g} deg (--rotation)\n", deg(ypr[0]),
          deg(ypr[1]), deg(ypr[2]));
    }
    if (map.vignetting_corrected) say(out, "  lens        vignetting divided out (--vignetting)\n");
  }
  emit_json(out, all.size() == 1 ? all[0] : nlohmann::json{{"maps", all}});
  return 0;
}

int run_convert(const ConvertArgs& args, const Output& out) {
  check_target_flags(args.size, args.nside);  // before reading what may be a large input
  ReadMapOptions ro;
  ro.layout = optional_layout(args.in_layout, "--in-layout");
  const auto t0 = Clock::now();
  // A directory (or a pattern with {face}) holds the six faces of a cube map:
  // assemble them into a latlong map at about the cube's resolution first.
  std::error_code ec;
  const bool cube = std::filesystem::is_directory(args.input, ec) || args.input.find("{face}") != std::string::npos;
  // Options that the input or the output never reads are refused, not ignored.
  if (cube && ro.layout)
    throw InputError(fmt::format("--in-layout reads a map file; {} is a cube map's six faces", args.input));
  if (args.half && lower_extension(args.output) != ".exr")
    throw InputError(fmt::format("--half writes EXR half floats; {} is not an .exr", args.output));
  const EnvMap src = [&] {
    if (!cube) return read_envmap(args.input, ro);
    const CubeFaces faces = read_cube_faces(args.input);
    const int h = 2 * faces.face_size;
    EnvMap m = cube_map_to_envmap(faces.rgb, faces.face_size, Layout::LatLong, 2 * h, h);
    m.units = faces.units;
    return m;
  }();
  const Layout layout = optional_layout(args.layout, "--layout").value_or(src.layout);
  refuse_misplaced_geometry(layout, args.size, args.nside);
  int w = 0, h = 0;
  target_geometry(layout, args.size, args.nside, &src, &w, &h);
  ResampleOptions options;
  if (!args.rotation.empty()) options.world_from_source = parse_rotation(args.rotation);
  const EnvMap dst = resample(src, layout, w, h, options);
  WriteMapOptions wo;
  wo.exr_pixel_type = args.half ? ExrPixelType::Half : ExrPixelType::Float;
  write_envmap(args.output, dst, wo);
  const double seconds = seconds_since(t0);
  const double p_in = total_luminance_power(src), p_out = total_luminance_power(dst);
  // A hemisphere holds the upper half only: what lay below the horizon is gone, said rather
  // than printed only as a power change (README promises power kept to 1e-4 otherwise).
  if (dst.layout == Layout::Hemisphere && src.layout != Layout::Hemisphere && p_in > 0 && (p_in - p_out) / p_in > 1e-3)
    warn(fmt::format("{}: a hemisphere map holds the upper half only; the {:.1f} % of {}'s power below the horizon "
                     "is not in it",
                     args.output, 100 * (p_in - p_out) / p_in, args.input));
  say(out, "{} ({}) -> {} ({}); power {:.6g} -> {:.6g} ({:+.2e} relative), {:.2f} s\n", args.input,
      describe_size(src), args.output, describe_size(dst), p_in, p_out, p_in > 0 ? (p_out - p_in) / p_in : 0.0,
      seconds);
  emit_json(out, {{"input", args.input},
                  {"output", args.output},
                  {"layout", std::string(to_string(dst.layout))},
                  {"width", dst.width},
                  {"height", dst.height},
                  {"power_in", p_in},
                  {"power_out", p_out},
                  {"seconds", seconds}});
  return 0;
}

int run_preview(const PreviewArgs& args, const Output& out) {
  // Any radiance image or map file as stored (no unwrapping), tone-mapped for people.
  const RgbImage img = read_rgb_image(args.input);
  ToneMapOptions o;
  if (!(args.percentile > 0 && args.percentile <= 1)) throw InputError("--percentile must be in (0, 1]");
  o.percentile = args.percentile;
  write_display_image(args.output, img.width, img.height, tone_map(image_view(img), o));
  say(out, "{} -> {} ({}x{})\n", args.input, args.output, img.width, img.height);
  emit_json(out, {{"input", args.input}, {"output", args.output}, {"width", img.width}, {"height", img.height}});
  return 0;
}

std::vector<Command> map_commands() {
  return {
      {"info", "Layout, size, dynamic range, power and luminance of maps; what a probe photo holds and records",
       "lightprobe info probe.exr\nlightprobe info scene.exr probe.hdr --json\nlightprobe info fused_ball.exr registered/ball_1-10s.png",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<InfoArgs>();
         f.arg("FILE", a->files, "Environment maps (.exr, .hdr, .pfm), or photos (PNG, JPEG, a fused .exr)").required();
         f.opt("--layout", a->layout, "Read as this layout: latlong|hemisphere|healpix");
         return [a](const Output& out) { return run_info(*a, out); };
       }},
      {"convert", "Convert a map between layouts, sizes, formats and frames",
       "lightprobe convert probe.hdr probe_polar.exr --layout hemisphere --size 360x90\nlightprobe convert probe.exr probe_hp.exr --layout healpix --nside 128 --rotation 90,0,0\nlightprobe convert pisa_cube/ pisa.exr --layout latlong --size 512x256",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<ConvertArgs>();
         f.arg("IN", a->input, "Input map, or a directory of cube faces px nx py ny pz nz").required();
         f.arg("OUT", a->output, "Output map (.exr, .hdr, .pfm)").required();
         f.opt("--layout", a->layout, "Target layout: latlong|hemisphere|healpix (default: the input's)");
         f.opt("--size", a->size, "Target size WxH (latlong, hemisphere)");
         f.opt("--nside", a->nside, "Target HEALPix nside (power of two)");
         f.opt("--in-layout", a->in_layout, "Read the input as this layout");
         f.opt("--rotation", a->rotation, "Turn the map into the world: 'yaw,pitch,roll' in degrees or 9 numbers (row-major)");
         f.flag("--half", a->half, "Write EXR as half floats");
         return [a](const Output& out) { return run_convert(*a, out); };
       }},
      {"preview", "Tone-mapped PNG/JPEG of a radiance image or map, as stored",
       "lightprobe preview probe.exr -o probe.png",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<PreviewArgs>();
         f.arg("IMAGE", a->input, "Radiance image or map (.exr, .hdr, .pfm) or a camera image").required();
         f.output(a->output, "PNG or JPEG");
         f.opt("--percentile", a->percentile, "Luminance percentile shown at 0.8 after Reinhard");
         return [a](const Output& out) { return run_preview(*a, out); };
       }},
  };
}

}  // namespace lp::cli
