// tables: one frame's shading tables (angular regions, glossy sets, clusters; Havran et
// al. 2005, section 4) exported for a renderer. `eval shading` measures what they buy
// (cli/cmd_eval.cpp, eval/shading_eval.h).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <memory>

#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "eval/harness.h"
#include "render/reference_shader.h"
#include "render/shading_tables.h"
#include "sampling/sampler.h"

namespace lp::cli {

struct TablesArgs {
  std::string input;                // a map
  std::string layout;               // input layout override
  ShadingTableArgs tables;
  std::string output;               // .json, or the binary texture (.lpst / anything else)
};

int run_tables(const TablesArgs& args, const Output& out) {
  const ShadingOptions options = shading_options(args.tables);
  const Method method = progressive_method(args.tables.method);
  if (args.tables.n < 1) throw InputError(fmt::format("--n must be at least 1, got {}", args.tables.n));
  ReadMapOptions ro;
  ro.layout = optional_layout(args.layout, "--layout");
  if (args.input == "scene" && ro.layout) throw InputError("--layout reads a map file; 'scene' is made as a latlong map");
  // The tables are a raw RGBA32F texture (or JSON): under an image's name they read as a broken image.
  if (is_radiance_file(args.output) || is_camera_image_file(args.output))
    throw InputError(fmt::format("{}: the tables are a raw RGBA32F texture (or .json), not an image file; name it "
                                 "e.g. tables.lpst",
                                 args.output));
  const EnvMap map = args.input == "scene" ? map_or_scene(args.input, 1024) : read_envmap(args.input, ro);
  const auto t0 = Clock::now();
  auto sampler = make_sampler(method);
  try {
    sampler->prepare(map);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", args.input, e.what()));
  }
  auto regions = std::make_shared<const AngularRegions>(options.regions);
  auto cones = std::make_shared<const AngularRegions>(options.glossy.cone_regions);
  const ShadingScene s = prepare_shading(sampler->place(args.tables.n * options.glossy.low_per_high), args.tables.n,
                                         regions, cones, options);
  const bool json = lower_extension(args.output) == ".json";
  LightList meta;
  meta.method = std::string(to_string(method));
  meta.units = map.units;
  const std::string bytes = json ? shading_tables_json(s, meta) : shading_tables_binary(s);
  write_file_atomically(args.output, bytes);
  const double ms = 1e3 * seconds_since(t0);
  const double mean_list = double(s.culled.indices.size()) / regions->count();
  say(out, "{} lights in H, {} in L, {} clustered; {} culling regions (radius <= {:.2f} deg, {:.0f} lights each on average), "
      "{} cone regions -> {} ({} bytes, {}) in {:.1f} ms\n",
      s.lights.size(), s.glossy.low.size(), s.clustered.size(), regions->count(), regions->max_radius() * 180 / M_PI,
      mean_list, cones->count(), args.output, bytes.size(), json ? "JSON" : "RGBA32F texture", ms);
  emit_json(out, {{"output", args.output},
                  {"format", json ? "json" : "texture"},
                  {"bytes", bytes.size()},
                  {"high", s.lights.size()},
                  {"low", s.glossy.low.size()},
                  {"clustered", s.clustered.size()},
                  {"regions", regions->count()},
                  {"cone_regions", cones->count()},
                  {"region_max_radius_deg", regions->max_radius() * 180 / M_PI},
                  {"mean_region_lights", mean_list},
                  {"time_ms", ms}});
  return 0;
}

std::vector<Command> render_commands() {
  return {
      {"tables", "Shading tables of a map for a renderer (angular regions, glossy sets, clusters)",
       "lightprobe tables probe.exr --n 1024 -o tables.lpst",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<TablesArgs>();
         f.arg("MAP", a->input, "Environment map").required();
         f.opt("--layout", a->layout, "Read the map as this layout");
         f.opt("--n", a->tables.n, "Lights |H| of the diffuse tables");
         declare_table_options(f, a->tables);
         f.output(a->output, "Output: .json, or the RGBA32F texture file (any other name)");
         return [a](const Output& out) { return run_tables(*a, out); };
       }},
  };
}

}  // namespace lp::cli
