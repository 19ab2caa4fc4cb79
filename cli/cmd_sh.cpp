// sh, prefilter: a map -> what engines light with (SH9 ambient; GGX specular cube and DFG).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <memory>

#include "cli/commands.h"
#include "cli/report.h"
#include "core/accuracy.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/warnings.h"
#include "core/spherical_harmonics.h"
#include "eval/harness.h"
#include "render/prefilter.h"
#include "sampling/light_units.h"

namespace lp::cli {

struct ShArgs {
  std::string input;
  std::string output;
  int order = kSh9Order;
  std::string layout;  // input layout override
  UnitFlags units;     // of a relative map
};

int run_sh(const ShArgs& args, const Output& out) {
  if (args.order != kSh9Order)
    throw InputError(fmt::format("--order: only order {} (9 coefficients) is supported, got {}", kSh9Order, args.order));
  check_light_units_options(args.units.options());
  ReadMapOptions read;
  read.layout = optional_layout(args.layout, "--layout");
  if (args.input == "scene" && read.layout) throw InputError("--layout reads a map file; 'scene' is made as a latlong map");
  // The coefficients are JSON: `-o sh.exr` wrote JSON text into a file named as an image.
  if (lower_extension(args.output) != ".json")
    throw InputError(fmt::format("{}: sh writes its coefficients as JSON; name the output .json", args.output));
  const EnvMap map = args.input == "scene" ? map_or_scene(args.input, 1024) : read_envmap(args.input, read);

  // The SH9's own irradiance facing up is what --normalize-illuminance scales to (what an
  // engine lighting with the coefficients gives), but on a map that sends no light upwards
  // it is only the projection's ringing: city black above the horizon was scaled x636 by it.
  if (args.units.options().normalize_illuminance_lux && map.units == Units::Relative &&
      !(map_irradiance(map, {0, 0, 1}) > 0))
    throw InputError(fmt::format("--normalize-illuminance: {} gives no illuminance on an upward-facing surface",
                                 args.input));
  const auto start = Clock::now();
  LightList ambient;  // a list of no lights but its SH9: scaled as `sample` scales a list
  ambient.sh9 = project_sh9(map, args.input);
  ambient.sh9_content = Sh9Content::Residual;
  ambient.units = map.units;
  const double ms = 1e3 * seconds_since(start);
  const LightUnitsResult scaled = apply_light_units(std::move(ambient), args.units.options(), args.output);
  if (!scaled.warning.empty()) std::fprintf(stderr, "warning: %s\n", scaled.warning.c_str());
  // SH9 has no "unknown": what the map does not hold (a hemisphere's lower half, a fisheye's
  // ground, beyond a mask) is black light to the engine that reads it.
  double covered = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (map.is_valid(i)) covered += pixel_solid_angle(map, i);
  covered /= 4 * M_PI;
  if (covered < 0.9)
    warn(fmt::format("{}: the map holds {:.0f} % of the sphere ({}): SH9 takes the rest as black", args.output,
                     100 * covered, map.layout == Layout::Hemisphere ? "a hemisphere map" : "its valid pixels"));
  const Sh9& sh = *scaled.list.sh9;
  write_file_atomically(args.output, sh9_to_json(sh, scaled.list.units));

  const auto up = sh9_irradiance(sh, {0, 0, 1});
  const auto down = sh9_irradiance(sh, {0, 0, -1});
  if (!out.json)
    say(out, "{}: SH9 of {} in {:.2f} ms -> {}; irradiance (luminance) facing up {:.4g}, down {:.4g} ({})\n",
        args.input, describe_size(map), ms, args.output, luminance(up.data()), luminance(down.data()),
        to_string(scaled.list.units));
  nlohmann::json coefficients = nlohmann::json::array();
  for (const auto& row : sh.coefficients) coefficients.push_back(row);
  // Irradiance per channel facing each axis: numbers a consumer's own SH code can check.
  nlohmann::json axes;
  const std::pair<const char*, Vec3> kAxes[] = {{"+x", {1, 0, 0}}, {"-x", {-1, 0, 0}}, {"+y", {0, 1, 0}},
                                               {"-y", {0, -1, 0}}, {"+z", {0, 0, 1}}, {"-z", {0, 0, -1}}};
  for (const auto& [name, axis] : kAxes) axes[name] = sh9_irradiance(sh, axis);
  emit_json(out, {{"input", args.input},
                  {"output", args.output},
                  {"units", std::string(to_string(scaled.list.units))},
                  {"scale_factor", scaled.factor},
                  {"project_ms", ms},
                  {"sphere_covered", covered},
                  {"irradiance_up", luminance(up.data())},
                  {"irradiance_down", luminance(down.data())},
                  {"irradiance_axes", axes},
                  {"coefficients", coefficients}});
  return 0;
}

struct PrefilterArgs {
  std::string input, output, lut;
  PrefilterOptions options;
  int lut_size = 128;
};

int run_prefilter(const PrefilterArgs& args, const Output& out) {
  check_prefiltered_cube_path(args.output);
  // The DFG table's B channel is far below A: an RGBE .hdr's shared exponent zeroed a quarter
  // of it. And its size without the table was never read.
  if (!args.lut.empty() && lower_extension(args.lut) != ".exr")
    throw InputError(fmt::format("--lut {}: the DFG table is written as OpenEXR floats; name it .exr", args.lut));
  if (args.lut.empty() && args.lut_size != PrefilterArgs{}.lut_size)
    throw InputError("--lut-size is the size of the DFG table that --lut FILE writes; give --lut");
  const EnvMap map = map_or_scene(args.input, 1024);
  const auto start = Clock::now();
  const PrefilteredCube cube = prefilter_ggx(map, args.options, args.input);
  const double ms = 1e3 * seconds_since(start);
  write_prefiltered_cube(args.output, cube);
  if (!args.lut.empty()) write_dfg_table(args.lut, compute_dfg_table(args.lut_size));
  say(out, "{}: GGX chain of {} levels ({}-texel faces down to {}) in {:.0f} ms -> {}{}\n", args.input, cube.levels.size(),
      cube.levels.front().face_size, cube.levels.back().face_size, ms, args.output, args.lut.empty() ? "" : ", DFG -> " + args.lut);
  nlohmann::json roughness = nlohmann::json::array();
  for (const CubeLevel& l : cube.levels) roughness.push_back(l.roughness);
  emit_json(out, {{"input", args.input}, {"output", args.output}, {"lut", args.lut}, {"prefilter_ms", ms},
                  {"roughness", roughness}, {"units", std::string(to_string(cube.units))}});
  return 0;
}

std::vector<Command> sh_commands() {
  return {
      {"sh", "Environment map -> spherical harmonics (SH9) of its radiance",
       "lightprobe sh probe.exr -o sh.json\nlightprobe sh scene -o sh.json --json",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<ShArgs>();
         f.arg("MAP", a->input, "A map file, or 'scene' (the procedural scene)").required();
         f.output(a->output, "sh.json: {\"format\": \"lightprobe.sh/1\", \"order\": 2, ..., \"coefficients\": [[r, g, b] x 9]}");
         f.opt("--order", a->order, "SH order (only 2: 9 coefficients, bands 0-2)");
         f.opt("--layout", a->layout, "Read the input as this layout");
         a->units.declare(f);
         return [a](const Output& out) { return run_sh(*a, out); };
       }},
      {"prefilter", "Environment map -> GGX prefiltered specular cube (OpenEXR mip chain) and DFG table",
       "lightprobe prefilter probe.exr -o specular.exr --lut dfg.exr\nlightprobe prefilter scene -o specular.exr --size 64",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<PrefilterArgs>();
         f.arg("MAP", a->input, "A whole-sphere map file, or 'scene' (the procedural scene)").required();
         f.output(a->output, "specular.exr: tiled mip chain, envmap = cube, level k at roughness k / (levels - 1)");
         f.opt("--size", a->options.face_size, "Face size of level 0 (roughness 0), a power of two");
         f.opt("--min-size", a->options.min_face_size, "Face size of the last level (roughness 1)");
         f.opt("--lut", a->lut, "Also write the split-sum DFG table (R = A, G = B) to this EXR");
         f.opt("--lut-size", a->lut_size, "DFG table size (n.v x roughness)");
         return [a](const Output& out) { return run_prefilter(*a, out); };
       }},
  };
}

}  // namespace lp::cli
