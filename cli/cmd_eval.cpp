// The eval commands: thin handlers over the harnesses in eval/ (sampling, temporal, hdr,
// unwrap, shading; the others beside their stages, cli/eval_handlers.h), and their table.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <memory>

#include "cli/commands.h"
#include "cli/eval_handlers.h"
#include "cli/progress_bar.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/limits.h"
#include "eval/hdr_eval.h"
#include "eval/sampling_eval.h"
#include "eval/shading_eval.h"
#include "eval/temporal_eval.h"
#include "eval/unwrap_eval.h"

namespace lp::cli {

namespace {

struct EvalSamplingArgs {
  std::vector<std::string> maps;    // "scene" renders the procedural scene
  std::string methods = "all";
  std::string counts = "16,32,64,128,256,512,1024,2048,4096";
  std::string output_dir;
  int repeats = 0;                  // 0: adaptive (at least 5, ~0.2 s per point)
  bool no_shadowed = false;
};

int run_eval_sampling(const EvalSamplingArgs& args, const Output& out) {
  EvalSamplingOptions o;
  o.maps = args.maps;
  o.methods = parse_method_list(args.methods);
  o.counts = parse_light_counts(args.counts, "--n");
  o.output_dir = args.output_dir;
  o.repeats = args.repeats;
  o.shadowed = !args.no_shadowed;
  return evaluate_and_report("eval sampling", out, [&](const EvalProgress& p) { return evaluate_sampling(o, p); });
}

Command eval_sampling_command() {
  return {"eval sampling", "Time and error of every sampler and light count",
          "lightprobe eval sampling probe1.exr probe2.hdr scene --methods all --n 16,64,256,1024 -o eval/",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalSamplingArgs>();
            f.arg("MAP", a->maps, "Maps to evaluate ('scene' for the procedural scene)").required();
            f.opt("--methods", a->methods, "Comma-separated methods or 'all'");
            f.opt("--n", a->counts, "Comma-separated light counts");
            f.output(a->output_dir, "Directory for sampling.csv and the charts");
            f.opt("--repeats", a->repeats, "Timing repeats per point (0: adaptive)");
            f.flag("--no-shadowed", a->no_shadowed, "Skip the shadowed error (its reference is the slow part)");
            return [a](const Output& out) { return run_eval_sampling(*a, out); };
          }};
}

struct EvalTemporalArgs {
  std::vector<std::string> maps;    // base maps; "scene" for the procedural scene
  std::string methods = "all";
  std::string scenarios = "all";
  int frames = 48;
  int n = 256;
  double fps = 21;
  std::string filter = "auto";
  std::string output_dir;
};

std::vector<Scenario> parse_scenarios(const std::string& text) {
  if (text == "all") return all_scenarios();
  std::vector<Scenario> out;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string name = text.substr(start, comma - start);
    auto s = scenario_from_string(name);
    if (!s) {
      std::string known;
      for (Scenario k : all_scenarios()) known += (known.empty() ? "" : ", ") + std::string(to_string(k));
      throw InputError(fmt::format("--scenarios: unknown scenario '{}' ({})", name, known));
    }
    out.push_back(*s);
    start = comma + 1;
  }
  return out;
}

int run_eval_temporal(const EvalTemporalArgs& args, const Output& out) {
  EvalTemporalOptions o;
  o.maps = args.maps;
  o.methods = parse_method_list(args.methods);
  o.scenarios = parse_scenarios(args.scenarios);
  if (args.n <= 0) throw InputError(fmt::format("--n must be positive, got {}", args.n));
  check_light_count("--n", args.n);
  check_frame_count("--frames", args.frames);
  o.frames = args.frames;
  o.count = args.n;
  o.frame_rate_hz = args.fps;
  o.filter = args.filter == "on" ? FilterMode::On : args.filter == "off" ? FilterMode::Off : FilterMode::Auto;
  o.output_dir = args.output_dir;
  return evaluate_and_report("eval temporal", out, [&](const EvalProgress& p) { return evaluate_temporal(o, p); });
}

Command eval_temporal_command() {
  return {"eval temporal", "Flicker, jitter and lag of every method on dynamic scenarios",
          "lightprobe eval temporal probe.exr scene --methods all --scenarios all -o temporal/",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalTemporalArgs>();
            f.arg("MAP", a->maps, "Base maps ('scene' for the procedural scene)").required();
            f.opt("--methods", a->methods, "Comma-separated methods or 'all'");
            f.opt("--scenarios", a->scenarios, "Comma-separated scenarios or 'all'");
            f.opt("--frames", a->frames, "Frames per scenario");
            f.opt("--n", a->n, "Lights per frame");
            f.opt("--fps", a->fps, "Frame rate");
            f.opt("--filter", a->filter, "FIR filtering: auto (hemigon only), on, off");
            f.output(a->output_dir, "Directory for temporal.csv and temporal.svg");
            return [a](const Output& out) { return run_eval_temporal(*a, out); };
          }};
}

struct EvalShadingArgs {
  std::vector<std::string> maps;    // "scene" renders the procedural scene
  std::string counts = "64,256,1024,4096";
  ShadingTableArgs tables;          // n is taken from counts
  int points = 0;                   // shading points per timing run (0: ~8M light evaluations)
  bool coherent = false;            // shade points in the order of their normal's region
  std::string output_dir;
};

int run_eval_shading(const EvalShadingArgs& args, const Output& out) {
  EvalShadingOptions o;
  o.maps = args.maps;
  o.counts = parse_light_counts(args.counts, "--n");
  if (args.points < 0) throw InputError(fmt::format("--points must be positive (or 0: automatic), got {}", args.points));
  o.points = args.points;
  o.shading = shading_options(args.tables);
  o.method = progressive_method(args.tables.method);
  o.coherent = args.coherent;
  o.output_dir = args.output_dir;
  return evaluate_and_report("eval shading", out, [&](const EvalProgress& p) { return evaluate_shading(o, p); });
}

Command eval_shading_command() {
  return {"eval shading", "Speed-up and error of culled, glossy two-strata and clustered many-light shading",
          "lightprobe eval shading probe.exr scene --n 256,1024,4096 -o eval/shading",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalShadingArgs>();
            f.arg("MAP", a->maps, "Maps to evaluate ('scene' for the procedural scene)").required();
            f.opt("--n", a->counts, "Comma-separated light counts |H|");
            f.opt("--points", a->points, "Shading points per timing run (0: automatic)");
            f.flag("--region-copies", a->tables.region_copies, "Shade from per-region copies of the lights instead of index lists into one array");
            f.flag("--coherent", a->coherent, "Shade points in the order of their normal's region, as neighbouring pixels come (default: random)");
            declare_table_options(f, a->tables);
            f.output(a->output_dir, "Directory for shading.csv and shading.svg");
            return [a](const Output& out) { return run_eval_shading(*a, out); };
          }};
}

struct EvalHdrArgs {
  std::vector<std::string> maps;    // radiance maps/images, or "scene"
  std::string response = "gamma";
  std::string output_dir;
};

int run_eval_hdr(const EvalHdrArgs& args, const Output& out) {
  EvalHdrOptions o;
  o.maps = args.maps;
  o.response = curve_from(args.response);
  o.output_dir = args.output_dir;
  return evaluate_and_report("eval hdr", out, [&](const EvalProgress& p) { return evaluate_hdr(o, p); });
}

Command eval_hdr_command() {
  return {"eval hdr", "Error and time of HDR fusion against OpenCV on synthetic brackets",
          "lightprobe eval hdr scene probe.exr --response scurve -o eval/hdr",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalHdrArgs>();
            f.arg("MAP", a->maps, "Radiance maps ('scene' for the procedural scene)").required();
            f.opt("--response", a->response, "Camera response of the synthetic brackets: linear|gamma|scurve");
            f.output(a->output_dir, "Directory for hdr.csv and hdr.svg");
            return [a](const Output& out) { return run_eval_hdr(*a, out); };
          }};
}

struct EvalUnwrapArgs {
  std::vector<std::string> maps;
  std::string output_dir;
};

int run_eval_unwrap(const EvalUnwrapArgs& args, const Output& out) {
  EvalUnwrapOptions o;
  o.maps = args.maps;
  o.output_dir = args.output_dir;
  return evaluate_and_report("eval unwrap", out, [&](const EvalProgress& p) { return evaluate_unwrap(o, p); });
}

Command eval_unwrap_command() {
  return {"eval unwrap", "Unwrapping error and centre error on synthetic probes",
          "lightprobe eval unwrap scene probe.exr -o eval/unwrap",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalUnwrapArgs>();
            f.arg("MAP", a->maps, "Latlong maps ('scene' for the procedural scene)").required();
            f.output(a->output_dir, "Directory for unwrap.csv");
            return [a](const Output& out) { return run_eval_unwrap(*a, out); };
          }};
}

}  // namespace

std::vector<Command> eval_commands() {
  return {
      eval_sampling_command(),
      eval_temporal_command(),
      {"eval estimators", "MIS, BIS and SMC reflected-radiance estimators: error, temporal noise, time",
       "lightprobe eval estimators probe.exr scene --repeats 8 -o eval/estimators\nlightprobe eval estimators seq/ --estimators mis,bis,smc --budgets 4,16,64 -o eval/estimators",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EvalEstimatorsArgs>();
         f.arg("SEQ|MAP", a->inputs, "Sequence directories, base maps for the scenarios, or 'scene'").required();
         f.opt("--estimators", a->estimators, "Comma-separated: mis, bis, bis-mix, smc, smc-mix (-mix: half the BIS proposals from the map)");
         f.opt("--budgets", a->budgets, "Comma-separated samples per estimate (visibility tests)");
         f.opt("--scenarios", a->scenarios, "Scenarios built on base maps (comma-separated or 'all')");
         f.opt("--frames", a->frames, "Frames per scenario (a directory: its first frames)");
         f.opt("--repeats", a->repeats, "Independent runs per estimate (variance across them)");
         f.opt("--size", a->size, "Latlong size every map is resampled to (WxH)");
         f.opt("--bis-m", a->bis_m, "BIS/SMC-initialisation proposals per sample (M = m N)");
         f.opt("--seed", a->seed, "Random seed");
         f.opt("--ray-cost-us", a->ray_cost_us, "Modelled microseconds per visibility test, added to the time");
         f.flag("!--no-sweep", a->sweep, "Skip the SMC parameter sweep");
         f.flag("--quick", a->quick, "Demo: 4 frames, 2 runs, budgets 4,16,64, no sweep");
         f.output(a->output_dir, "Directory for estimators.csv/.svg and smc_sweep.csv/.svg");
         return [a](const Output& out) { return run_eval_estimators(*a, out); };
       }},
      eval_shading_command(),
      eval_hdr_command(),
      {"eval calib", "Our geometric calibration against OpenCV run alone; synthetic sweep",
       "lightprobe eval calib views/*.jpg --board 9x6 --square 25 -o eval/calib\nlightprobe eval calib --sweep -o eval/calib",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EvalCalibArgs>();
         f.arg("IMAGE", a->images, "Chessboard views of one camera (optional with --sweep)");
         f.opt("--board", a->board, "COLSxROWS inner corners");
         f.opt("--square", a->square_mm, "Square size, mm");
         f.flag("--sweep", a->sweep, "Views 4..20 and noise 0.05..0.5 px on synthetic corners: error vs truth");
         f.output(a->output_dir, "Directory for calib_compare.csv, calib_sweep.csv/.svg");
         return [a](const Output& out) { return run_eval_calib(*a, out); };
       }},
      eval_unwrap_command(),
      {"eval metadata", "Diffuse error of the metadata model against real probes along a walk",
       "lightprobe synth walkthrough -o walk/ && lightprobe eval metadata walk/ -o eval/metadata",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EvalMetadataArgs>();
         f.arg("DIR", a->input_dir, "Directory from synth walkthrough").required();
         f.output(a->output_dir, "Directory for metadata.csv and metadata.svg");
         f.opt("--fractions", a->fractions, "Parts of the path to build the model from");
         f.opt("--root-size", a->root_size, "Root cell side, m (0: twice the room's larger side)");
         f.opt("--min-size", a->min_size, "Smallest cell side, m");
         return [a](const Output& out) { return run_eval_metadata(*a, out); };
       }},
  };
}

}  // namespace lp::cli
