// sample: environment map(s) -> light list in the chosen format.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <memory>
#include <stdexcept>

#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/limits.h"
#include "core/image_io.h"
#include "core/map_sequence.h"
#include "core/progress.h"
#include "core/spherical_harmonics.h"
#include "sampling/exporters.h"
#include "sampling/light_units.h"
#include "sampling/lights_and_ambient.h"
#include "sampling/sample_maps.h"
#include "sampling/overlay.h"
#include "sampling/sampler.h"

namespace lp::cli {

struct SampleArgs {
  std::vector<std::string> inputs;  // one map, several maps (a sequence) or a directory
  std::string method = "pharr";
  std::string n = "256";            // a count or "auto"
  std::string error_measure = "diffuse";  // what --target-error holds (sampling/auto_count.h)
  std::string format;               // json|ndjson|pbrt|mitsuba|gltf|glb|csv (default from -o)
  std::string output;
  std::string overlay;              // PNG of the lights on the map
  std::string layout;               // input layout override
  FramePipelineOptions pipeline;    // the hemigon and q2tree flags, --fps and --cluster, bound directly
  std::string filter = "auto";      // FIR filtering of power and directions: auto|on|off
  std::string residual;             // "sh9": n lights + SH9 of what they leave out
  bool sh9 = false;                 // also carry the whole map's SH9 ("content": "map")
  bool glossy_errors = false;       // also score the glossy lobes (SampleMapsOptions)
  LightsAndAmbientOptions ambient;  // --light-cap, bound directly
  UnitFlags units;                  // of a relative map (one of three)
};

namespace {

FilterMode filter_mode(const std::string& name) {
  if (name == "auto") return FilterMode::Auto;
  if (name == "on") return FilterMode::On;
  if (name == "off") return FilterMode::Off;
  throw InputError(fmt::format("--filter must be auto, on or off, got '{}'", name));
}

// Formats whose consumers read the numbers as physical (the csv records no units at all).
bool has_physical_units(ExportFormat f) {
  return f == ExportFormat::Gltf || f == ExportFormat::Glb || f == ExportFormat::Pbrt || f == ExportFormat::Mitsuba ||
         f == ExportFormat::Csv;
}

// pbrt, Mitsuba and csv hold lights only: an SH9 asked for was dropped without a word, and
// with --residual a third of the power with it.
void refuse_sh9_the_format_drops(ExportFormat f, const std::string& output, const char* option) {
  if (f == ExportFormat::Pbrt || f == ExportFormat::Mitsuba || f == ExportFormat::Csv)
    throw InputError(fmt::format("{}: {} cannot carry the SH9 of {}; write .json, .ndjson, .gltf or .glb", output,
                                 to_string(f), option));
}

// The lists in the units of the output format; the warning of a relative list, once.
void apply_units(std::vector<LightList>& lists, const SampleArgs& args, ExportFormat format) {
  const LightUnitsOptions u = args.units.options();
  std::string warning;
  for (LightList& l : lists) {
    LightUnitsResult r = apply_light_units(std::move(l), u, args.output);
    l = std::move(r.list);
    warning = r.warning;
  }
  if (!warning.empty() && has_physical_units(format)) std::fprintf(stderr, "warning: %s\n", warning.c_str());
}

// --residual sh9: one map, n lights for its peaks + SH9 of the rest, scored three ways.
int run_sample_residual(const SampleArgs& args, const Output& out, Method method) {
  if (args.residual != "sh9") throw InputError(fmt::format("--residual must be sh9, got '{}'", args.residual));
  if (args.inputs.size() != 1) throw InputError("--residual sh9 takes one map, not a sequence");
  if (args.sh9) throw InputError("--residual sh9 and --sh9: give one (the list carries one SH9)");
  const int n = light_count(args.n);
  if (n == 0) throw InputError("--residual sh9 needs a light count, not --n auto");
  ReadMapOptions read;
  read.layout = optional_layout(args.layout, "--layout");
  const EnvMap map = read_envmap(args.inputs[0], read);
  const ExportFormat format = export_format_for(args.format, args.output, false);
  refuse_sh9_the_format_drops(format, args.output, "--residual sh9");
  SamplerOptions so = args.pipeline.sampler;
  so.lloyd_relaxed = so.q2_jitter = false;  // the residual's lights are the plain samplers'
  const LightsAndAmbientOptions& ao = args.ambient;
  if (!(ao.light_cap_deg > 0 && ao.light_cap_deg <= 180))
    throw InputError(fmt::format("--light-cap must be in (0, 180] degrees, got {}", ao.light_cap_deg));
  const auto t0 = Clock::now();  // what a renderer waits for: the split, the lights and the SH9, no scoring
  sample_lights_and_sh9(map, n, method, so, ao);
  const double ms = 1e3 * seconds_since(t0);
  const AccuracyReference ref = make_accuracy_reference(map);
  const AmbientComparison c = compare_lights_and_sh9(map, ref, n, method, so, ao);
  std::vector<LightList> lists{c.list};
  apply_units(lists, args, format);
  write_file_atomically(args.output, export_lights(lists[0], format));
  auto row = [](const LightError& e) {
    return nlohmann::json{{"diffuse", e.diffuse}, {"glossy", e.glossy}, {"shadowed", e.shadowed}};
  };
  if (!out.json)
    say(out, "{}: {} lights ({:.1f} % of the power) + SH9 ambient in {:.2f} ms -> {}; diffuse error {:.2f} % (lights alone "
             "{:.2f} %, SH9 alone {:.2f} %), shadowed {:.2f} % ({:.2f} %, {:.2f} %)\n",
        args.inputs[0], lists[0].lights.size(), 100 * c.light_power_share, ms, args.output, 100 * c.lights_and_sh9.diffuse,
        100 * c.lights_only.diffuse, 100 * c.sh9_only.diffuse, 100 * c.lights_and_sh9.shadowed,
        100 * c.lights_only.shadowed, 100 * c.sh9_only.shadowed);
  emit_json(out, {{"method", args.method},
                  {"n", n},
                  {"lights", lists[0].lights.size()},
                  {"output", args.output},
                  {"format", std::string(to_string(format))},
                  {"light_power_share", c.light_power_share},
                  {"milliseconds", ms},
                  {"error", row(c.lights_and_sh9)},
                  {"error_lights_only", row(c.lights_only)},
                  {"error_sh9_only", row(c.sh9_only)}});
  return 0;
}

// Options that do nothing for the chosen method are refused, not ignored: `--method pharr
// --q2-a 2` or `--light-cap 10` without --residual ran with exit 0 and lists that the
// user believed shaped by the option. Compared against the defaults, so a config file
// may still spell a default out.
void refuse_unused_options(const SampleArgs& args, Method method, bool residual, bool auto_count) {
  const SampleArgs d;
  const SamplerOptions &s = args.pipeline.sampler, &ds = d.pipeline.sampler;
  auto refuse_unless = [](bool applies, const char* option, const std::string& where) {
    if (!applies) throw InputError(fmt::format("{} applies only {}", option, where));
  };
  const std::string name(to_string(method));
  const bool hemigon = method == Method::Hemigon, q2tree = method == Method::Q2Tree;
  if (s.upper_only != ds.upper_only) refuse_unless(hemigon, "--upper-only", "to --method hemigon, not " + name);
  if (s.lloyd_relaxed != ds.lloyd_relaxed)
    refuse_unless(hemigon && !residual, "--lloyd", residual ? "without --residual" : "to --method hemigon, not " + name);
  if (s.q2_jitter != ds.q2_jitter)
    refuse_unless(q2tree && !residual, "--q2-jitter", residual ? "without --residual" : "to --method q2tree, not " + name);
  if (s.q2_luminance_exponent != ds.q2_luminance_exponent) refuse_unless(q2tree, "--q2-a", "to --method q2tree, not " + name);
  if (s.q2_solid_angle_exponent != ds.q2_solid_angle_exponent)
    refuse_unless(q2tree, "--q2-b", "to --method q2tree, not " + name);
  if (s.q2_nside != ds.q2_nside) refuse_unless(q2tree, "--q2-nside", "to --method q2tree, not " + name);
  if (args.ambient.light_cap_deg != d.ambient.light_cap_deg) refuse_unless(residual, "--light-cap", "with --residual sh9");
  const auto& ao = args.pipeline.auto_options;
  if (ao.target_error != d.pipeline.auto_options.target_error) refuse_unless(auto_count, "--target-error", "with --n auto");
  if (args.error_measure != d.error_measure) refuse_unless(auto_count, "--error-measure", "with --n auto");
  if (!residual) return;
  const FramePipelineOptions &p = args.pipeline, &dp = d.pipeline;
  refuse_unless(p.cluster_max_lights == dp.cluster_max_lights, "--cluster", "without --residual");
  refuse_unless(args.filter == d.filter, "--filter", "without --residual (it filters sequences)");
  refuse_unless(p.frame_rate_hz == dp.frame_rate_hz, "--fps", "without --residual (it times sequences)");
  refuse_unless(args.overlay.empty(), "--overlay", "without --residual");
  refuse_unless(!args.glossy_errors, "--glossy-errors", "without --residual (it scores the glossy errors already)");
}

}  // namespace

int run_sample(const SampleArgs& args, const Output& out) {
  const auto method = method_from_string(args.method);
  if (!method) throw InputError(fmt::format("--method: unknown method '{}' (pharr, hemigon, q2tree, mediancut)", args.method));
  refuse_unused_options(args, *method, !args.residual.empty(), args.n == "auto");
  check_light_units_options(args.units.options());  // before any work: a refusal after the report read as success
  if (!args.residual.empty()) return run_sample_residual(args, out, *method);
  SampleMapsOptions o;
  o.pipeline = args.pipeline;
  FramePipelineOptions& po = o.pipeline;
  po.method = *method;
  po.count = light_count(args.n);
  po.auto_count = po.count == 0;
  po.auto_options.measure = error_measure_from_string(args.error_measure);
  check_nside("--q2-nside", po.sampler.q2_nside);
  po.filter = filter_mode(args.filter);
  if (!(po.frame_rate_hz > 0)) throw InputError(fmt::format("--fps must be positive, got {}", po.frame_rate_hz));
  check_light_count("--cluster", po.cluster_max_lights);
  o.read.layout = optional_layout(args.layout, "--layout");
  o.glossy_errors = args.glossy_errors;

  const MapSequence maps = find_map_sequence(args.inputs);
  const bool sequence = maps.is_sequence();
  const ExportFormat format = export_format_for(args.format, args.output, sequence);
  // A csv has no frame column: a sequence's frames ran together, its ids repeated.
  if (sequence && format != ExportFormat::Ndjson)
    throw InputError(fmt::format("{} maps form a sequence: write NDJSON, one frame a line (.ndjson, .jsonl or --format ndjson)",
                                 maps.files.size()));
  if (sequence && args.sh9) throw InputError("--sh9 takes one map, not a sequence");
  if (args.sh9) refuse_sh9_the_format_drops(format, args.output, "--sh9");

  Progress progress("sample", maps.files.size(), out.progress && sequence);
  SampleMapsResult result = sample_maps(maps, o, [&] { progress.advance(); });
  progress.finish();

  // Units first: a refusal (a calibrated map given --scale) came after each frame's line had
  // been printed, and read as a success.
  std::vector<LightList> lists;
  for (SampledFrame& f : result.frames) lists.push_back(f.list);
  if (args.sh9) {
    lists[0].sh9 = project_sh9(result.last_map, maps.files[0]);
    lists[0].sh9_content = Sh9Content::Map;
  }
  apply_units(lists, args, format);
  nlohmann::json frames = nlohmann::json::array();
  for (SampledFrame& f : result.frames) {
    if (f.target_missed)
      say(out, "{}: the target {} error {:.3g} was not reached ({} lights, {:.3g})\n", f.file, args.error_measure,
          po.auto_options.target_error, f.list.lights.size(), f.measured_error);
    if (!out.json && !sequence)
      say(out, "{}: {} {} lights in {:.3f} ms (+{:.3f} ms preparing); diffuse error {:.2f} %, {}\n", f.file,
          f.list.lights.size(), f.list.method, f.timing.place_ms + f.timing.temporal_ms, f.timing.prepare_ms,
          100 * f.error.diffuse,
          f.error.glossy.empty() ? std::string("glossy errors not scored (--glossy-errors)")
                                 : fmt::format("glossy {:.2f} % (s=10), {:.2f} % (s=100)", 100 * f.error.glossy[0],
                                               100 * f.error.glossy[1]));
    frames.push_back(f.to_json());
  }
  write_file_atomically(args.output, export_light_sequence(lists, format));
  if (!args.overlay.empty()) write_overlay_png(args.overlay, result.last_map, lists.back().lights);
  if (sequence && !out.json)
    say(out, "{} frames -> {}{}\n", maps.files.size(), args.output,
        result.filtering ? fmt::format(" (FIR-filtered: lights lag the maps by {} frames)", result.filter_delay_frames) : "");
  nlohmann::json report = {{"method", args.method},
                           {"output", args.output},
                           {"format", std::string(to_string(format))},
                           {"filter_delay_frames", result.filter_delay_frames}};
  // The report says how to get what it left out.
  if (result.frames[0].error.glossy.empty()) report["not_scored"] = "glossy10_error, glossy100_error: add --glossy-errors";
  if (sequence)
    report["frames"] = frames;
  else
    report.update(frames[0]);
  emit_json(out, report);
  return 0;
}

std::vector<Command> sample_commands() {
  return {
      {"sample", "Environment map -> directional lights",
       "lightprobe sample probe.exr --method q2tree --n 256 -o lights.json --overlay lights.png\nlightprobe sample probe.exr --method pharr --n auto --target-error 0.01 -o lights.pbrt\nlightprobe sample frames/ --method hemigon --n 300 -o lights.ndjson\nlightprobe sample probe.exr --method q2tree --n 16 --residual sh9 --normalize-illuminance 10000 -o lights.glb",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<SampleArgs>();
         f.arg("MAP", a->inputs, "A map, several maps (a sequence: NDJSON, one frame each) or a directory").required();
         f.opt("--method", a->method, "pharr|hemigon|q2tree|mediancut");
         f.opt("--n", a->n, "Number of lights, or 'auto' with --target-error");
         f.opt("--target-error", a->pipeline.auto_options.target_error, "With --n auto: largest error (0.01 = 1 %)");
         f.opt("--error-measure", a->error_measure, "What --target-error holds: diffuse|glossy10|glossy100|shadowed|worst");
         f.opt("--format", a->format, "json|ndjson|pbrt|mitsuba|gltf|glb|csv (default: from -o's extension)");
         f.output(a->output, "Output file");
         f.opt("--overlay", a->overlay, "Also draw the lights on the tone-mapped map (PNG)");
         f.opt("--layout", a->layout, "Read the input as this layout");
         f.flag("--upper-only", a->pipeline.sampler.upper_only,
                "hemigon: sample only the upper hemisphere (sky probes)");
         f.flag("--lloyd", a->pipeline.sampler.lloyd_relaxed, "hemigon: Lloyd-relaxed Halton points");
         f.opt("--q2-a", a->pipeline.sampler.q2_luminance_exponent, "q2tree: luminance exponent a of p = L^a dw^b");
         f.opt("--q2-b", a->pipeline.sampler.q2_solid_angle_exponent, "q2tree: solid-angle exponent b of p = L^a dw^b");
         f.flag("--q2-jitter", a->pipeline.sampler.q2_jitter, "q2tree: deterministic jitter instead of leaf centroids");
         f.opt("--q2-nside", a->pipeline.sampler.q2_nside, "q2tree: HEALPix resolution to bin to (0: from the input)");
         f.opt("--filter", a->filter, "Temporal FIR filter on power and directions: auto (hemigon only), on, off");
         f.opt("--fps", a->pipeline.frame_rate_hz, "Frame rate of a sequence (the FIR filter is designed for it)");
         f.opt("--cluster", a->pipeline.cluster_max_lights,
               "Cluster the lights to at most this many (Havran 2005 4.3)");
         f.opt("--residual", a->residual, "sh9: n lights for the map's peaks + SH9 ambient of the rest (one map)");
         f.opt("--light-cap", a->ambient.light_cap_deg,
               "With --residual: half-angle (deg) of the cap one light stands for");
         f.flag("--glossy-errors", a->glossy_errors,
                "Also score the glossy errors s = 10 and 100 (~25 ms at 1024x512; the diffuse error always)");
         f.flag("--sh9", a->sh9, "Also carry the whole map's SH9 (\"sh9\", content \"map\"; glTF: asset.extras)");
         a->units.declare(f);
         return [a](const Output& out) { return run_sample(*a, out); };
       }},
  };
}

}  // namespace lp::cli
