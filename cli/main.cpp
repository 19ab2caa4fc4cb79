// lightprobe: cameras into live light probes. Subcommands by pipeline stage; see
// ../shared/CONVENTIONS.md "The command line" for the shapes scripts rely on.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <exception>

#include "cli/commands.h"
#include "core/error.h"

namespace {

constexpr const char* kDescription =
    "lightprobe: calibrate cameras, capture HDR light probes and turn them into\n"
    "directional lights for renderers, live.\n\n"
    "Example session:\n"
    "  lightprobe synth scene -o scene.exr --size 1024x512\n"
    "  lightprobe info scene.exr\n"
    "  lightprobe sample scene.exr --method q2tree --n 256 -o lights.json --overlay lights.png\n"
    "  lightprobe eval sampling scene.exr --methods all -o eval/\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace lp::cli;
  CLI::App app{kDescription, "lightprobe"};
  app.set_version_flag("--version", std::string("lightprobe ") + LIGHTPROBE_VERSION);
  app.require_subcommand(1);
  Output out;
  app.add_flag("--json", out.json, "Print the report as one JSON object on stdout")->configurable(false);
  app.add_flag("!--no-progress", out.progress, "Never draw progress bars");

  // info
  InfoArgs info;
  auto* c_info = app.add_subcommand("info", "Layout, size, dynamic range, power and luminance of maps");
  c_info->add_option("FILE", info.files, "Environment maps (.exr, .hdr, .pfm)")->required();
  c_info->add_option("--layout", info.layout, "Read as this layout: latlong|hemisphere|healpix");
  c_info->add_flag("--json", out.json, "Print the report as JSON");

  // convert
  ConvertArgs conv;
  auto* c_conv = app.add_subcommand("convert", "Convert a map between layouts, sizes, formats and frames");
  c_conv->add_option("IN", conv.input, "Input map, or a directory of cube faces px nx py ny pz nz")->required();
  c_conv->add_option("OUT", conv.output, "Output map (.exr, .hdr, .pfm)")->required();
  c_conv->add_option("--layout", conv.layout, "Target layout: latlong|hemisphere|healpix (default: the input's)");
  c_conv->add_option("--size", conv.size, "Target size WxH (latlong, hemisphere)");
  c_conv->add_option("--nside", conv.nside, "Target HEALPix nside (power of two)");
  c_conv->add_option("--in-layout", conv.in_layout, "Read the input as this layout");
  c_conv->add_option("--rotation", conv.rotation,
                     "Turn the map into the world: 'yaw,pitch,roll' in degrees or 9 numbers (row-major)");
  c_conv->add_flag("--half", conv.half, "Write EXR as half floats");
  c_conv->add_flag("--json", out.json, "Print the report as JSON");

  // synth
  auto* c_synth = app.add_subcommand("synth", "Ground-truth makers");
  c_synth->require_subcommand(1);
  SynthSceneArgs scene;
  auto* c_scene = c_synth->add_subcommand("scene", "The procedural sky + sun + area lights scene");
  c_scene->add_option("-o,--output", scene.output, "Output map")->required();
  c_scene->add_option("--layout", scene.layout, "latlong|hemisphere|healpix");
  c_scene->add_option("--size", scene.size, "WxH (latlong, hemisphere)");
  c_scene->add_option("--nside", scene.nside, "HEALPix nside");
  c_scene->add_option("--sun-scale", scene.sun_scale, "Multiply the sun's radiance");
  c_scene->add_flag("--no-sun", scene.no_sun, "Leave the sun out");
  c_scene->add_flag("--json", out.json, "Print the report as JSON");

  SynthSequenceArgs seq;
  auto* c_seq = c_synth->add_subcommand("sequence", "A dynamic sequence with ground truth, one EXR per frame");
  c_seq->add_option("--scenario", seq.scenario,
                    "static-noise|moving-light|swinging-bulb|abrupt-switch|flicker|rising-light|camera-turn");
  c_seq->add_option("--base", seq.base, "Base map file, or 'scene' (the procedural scene at 512x256)");
  c_seq->add_option("--frames", seq.frames, "Number of frames");
  c_seq->add_option("--fps", seq.fps, "Frame rate (flicker aliasing depends on it)");
  c_seq->add_option("--seed", seq.seed, "Noise seed");
  c_seq->add_option("--size", seq.size, "Resample the base to WxH first");
  c_seq->add_option("-o,--output", seq.output_dir, "Output directory (frame_0000.exr ..., truth.json)")->required();
  c_seq->add_flag("--json", out.json, "Print the report as JSON");

  // sample
  SampleArgs samp;
  auto* c_samp = app.add_subcommand("sample", "Environment map -> directional lights");
  c_samp->add_option("MAP", samp.inputs, "A map, several maps (a sequence: NDJSON, one frame each) or a directory")
      ->required();
  c_samp->add_option("--method", samp.method, "pharr|hemigon|q2tree|mediancut");
  c_samp->add_option("--n", samp.n, "Number of lights, or 'auto' with --target-error");
  c_samp->add_option("--target-error", samp.target_error, "With --n auto: largest diffuse error (0.01 = 1 %)");
  c_samp->add_option("--format", samp.format, "json|ndjson|pbrt|mitsuba|gltf|csv (default: from -o's extension)");
  c_samp->add_option("-o,--output", samp.output, "Output file")->required();
  c_samp->add_option("--overlay", samp.overlay, "Also draw the lights on the tone-mapped map (PNG)");
  c_samp->add_option("--layout", samp.layout, "Read the input as this layout");
  c_samp->add_flag("--upper-only", samp.upper_only, "hemigon: sample only the upper hemisphere (sky probes)");
  c_samp->add_flag("--lloyd", samp.lloyd, "hemigon: Lloyd-relaxed Halton points");
  c_samp->add_option("--q2-a", samp.q2_a, "q2tree: luminance exponent a of p = L^a dw^b");
  c_samp->add_option("--q2-b", samp.q2_b, "q2tree: solid-angle exponent b of p = L^a dw^b");
  c_samp->add_flag("--q2-jitter", samp.q2_jitter, "q2tree: deterministic jitter instead of leaf centroids");
  c_samp->add_option("--q2-nside", samp.q2_nside, "q2tree: HEALPix resolution to bin to (0: from the input)");
  c_samp->add_option("--filter", samp.filter,
                     "Temporal FIR filter on power and directions: auto (hemigon only), on, off");
  c_samp->add_option("--fps", samp.fps, "Frame rate of a sequence (the FIR filter is designed for it)");
  c_samp->add_option("--cluster", samp.cluster, "Cluster the lights to at most this many (Havran 2005 4.3)");
  c_samp->add_flag("--json", out.json, "Print the report as JSON");

  // eval
  auto* c_eval = app.add_subcommand("eval", "Speed against accuracy of each method");
  c_eval->require_subcommand(1);
  EvalSamplingArgs evs;
  auto* c_evs = c_eval->add_subcommand("sampling", "Time and error of every sampler and light count");
  c_evs->add_option("MAP", evs.maps, "Maps to evaluate ('scene' for the procedural scene)")->required();
  c_evs->add_option("--methods", evs.methods, "Comma-separated methods or 'all'");
  c_evs->add_option("--n", evs.counts, "Comma-separated light counts");
  c_evs->add_option("-o,--output", evs.output_dir, "Directory for sampling.csv and the charts")->required();
  c_evs->add_option("--repeats", evs.repeats, "Timing repeats per point (0: adaptive)");
  c_evs->add_flag("--no-shadowed", evs.no_shadowed, "Skip the shadowed error (its reference is the slow part)");
  c_evs->add_flag("--json", out.json, "Print the report as JSON");

  EvalTemporalArgs evt;
  auto* c_evt = c_eval->add_subcommand("temporal", "Flicker, jitter and lag of every method on dynamic scenarios");
  c_evt->add_option("MAP", evt.maps, "Base maps ('scene' for the procedural scene)")->required();
  c_evt->add_option("--methods", evt.methods, "Comma-separated methods or 'all'");
  c_evt->add_option("--scenarios", evt.scenarios, "Comma-separated scenarios or 'all'");
  c_evt->add_option("--frames", evt.frames, "Frames per scenario");
  c_evt->add_option("--n", evt.n, "Lights per frame");
  c_evt->add_option("--fps", evt.fps, "Frame rate");
  c_evt->add_option("--filter", evt.filter, "FIR filtering: auto (hemigon only), on, off");
  c_evt->add_option("-o,--output", evt.output_dir, "Directory for temporal.csv and temporal.svg")->required();
  c_evt->add_flag("--json", out.json, "Print the report as JSON");

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  }

  try {
    if (*c_info) return run_info(info, out);
    if (*c_conv) return run_convert(conv, out);
    if (*c_scene) return run_synth_scene(scene, out);
    if (*c_samp) return run_sample(samp, out);
    if (*c_evs) return run_eval_sampling(evs, out);
    if (*c_seq) return run_synth_sequence(seq, out);
    if (*c_evt) return run_eval_temporal(evt, out);
  } catch (const lp::InputError& e) {
    std::fprintf(stderr, "lightprobe: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lightprobe: internal error: %s\n", e.what());
    return 1;
  }
  return 1;
}
