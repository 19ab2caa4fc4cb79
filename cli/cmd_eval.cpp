// The eval commands: thin handlers over the harnesses in eval/, each binding its flags to
// the harness's options where names and defaults agree, and their table.
#include <fmt/format.h>

#include <algorithm>
#include <memory>

#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/heap_tuning.h"
#include "core/limits.h"
#include "core/progress.h"
#include "eval/auto_bracket_eval.h"
#include "eval/calib_eval.h"
#include "eval/estimators_eval.h"
#include "eval/hdr_eval.h"
#include "eval/merge_eval.h"
#include "eval/metadata_eval.h"
#include "eval/sampling_eval.h"
#include "eval/shading_eval.h"
#include "eval/temporal_eval.h"
#include "eval/unwrap_eval.h"

namespace lp::cli {

namespace {

// Runs a harness under a progress bar, then prints its table and (--json) its report.
template <typename Options, typename Report>
int evaluate_and_report(const char* label, const Output& out, Report (*evaluate)(const Options&, const EvalProgress&),
                        const Options& options) {
  CallbackProgress bar(label, out.progress);
  const Report report = evaluate(options, bar.callback());
  bar.finish();
  say(out, "{}", report.summary());
  emit_json(out, report.to_json());
  return 0;
}

struct EvalSamplingArgs {
  EvalSamplingOptions o;
  std::string methods = "all";
  std::string counts = "16,32,64,128,256,512,1024,2048,4096";
  bool no_shadowed = false;
};

Command eval_sampling_command() {
  return {"eval sampling", "Time and error of every sampler and light count",
          "lightprobe eval sampling probe1.exr probe2.hdr scene --methods all --n 16,64,256,1024 -o eval/",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalSamplingArgs>();
            f.arg("MAP", a->o.maps, "Maps to evaluate ('scene' for the procedural scene)").required();
            f.opt("--methods", a->methods, "Comma-separated methods or 'all'");
            f.opt("--n", a->counts, "Comma-separated light counts");
            f.output(a->o.output_dir, "Directory for sampling.csv and the charts");
            f.opt("--repeats", a->o.repeats, "Timing repeats per point (0: adaptive)");
            f.flag("--no-shadowed", a->no_shadowed, "Skip the shadowed error (its reference is the slow part)");
            return [a](const Output& out) {
              EvalSamplingOptions o = a->o;
              o.methods = parse_method_list(a->methods);
              o.counts = parse_light_counts(a->counts, "--n");
              o.shadowed = !a->no_shadowed;
              if (o.repeats < 0) throw InputError(fmt::format("--repeats must be 0 (adaptive) or more, got {}", o.repeats));
              return evaluate_and_report("eval sampling", out, evaluate_sampling, o);
            };
          }};
}

struct EvalTemporalArgs {
  EvalTemporalOptions o;
  std::string methods = "all", scenarios = "all", filter = "auto";
  std::string n = "256", error_measure = "diffuse";
};

Command eval_temporal_command() {
  return {"eval temporal", "Flicker, jitter and lag of every method on dynamic scenarios",
          "lightprobe eval temporal probe.exr scene --methods all --scenarios all -o temporal/",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalTemporalArgs>();
            f.arg("MAP", a->o.maps, "Base maps ('scene' for the procedural scene)").required();
            f.opt("--methods", a->methods, "Comma-separated methods or 'all'");
            f.opt("--scenarios", a->scenarios, "Comma-separated scenarios or 'all'");
            f.opt("--frames", a->o.frames, "Frames per scenario");
            f.opt("--n", a->n, "Lights per frame, or 'auto': the fewest within --target-error (charted per frame)");
            f.opt("--target-error", a->o.auto_options.target_error, "With --n auto: largest error (0.01 = 1 %)");
            f.opt("--error-measure", a->error_measure, "With --n auto: diffuse|glossy10|glossy100|shadowed|worst");
            f.opt("--frame-budget-ms", a->o.frame_budget_ms, "With --n auto: fewer lights when the back end takes longer");
            f.opt("--fps", a->o.frame_rate_hz, "Frame rate");
            f.opt("--filter", a->filter, "FIR filtering: auto (hemigon only), on, off");
            f.output(a->o.output_dir, "Directory for temporal.csv and temporal.svg");
            return [a](const Output& out) {
              EvalTemporalOptions o = a->o;
              o.methods = parse_method_list(a->methods);
              o.scenarios = parse_scenarios(a->scenarios);
              o.count = light_count(a->n), o.auto_count = o.count == 0;
              if (!o.auto_count) check_light_count("--n", o.count);
              o.auto_options.measure = error_measure_from_string(a->error_measure);
              const EvalTemporalArgs d;  // what only --n auto reads is refused with a fixed count
              for (const auto& [given, option] :
                   {std::pair{o.auto_options.target_error != d.o.auto_options.target_error, "--target-error"},
                    std::pair{a->error_measure != d.error_measure, "--error-measure"},
                    std::pair{o.frame_budget_ms != d.o.frame_budget_ms, "--frame-budget-ms"}})
                if (given && !o.auto_count) throw InputError(fmt::format("{} applies only with --n auto", option));
              check_frame_count("--frames", o.frames);
              // "--filter of" ran as auto: a misspelt mode is refused, as sample refuses it.
              if (a->filter != "auto" && a->filter != "on" && a->filter != "off")
                throw InputError(fmt::format("--filter must be auto, on or off, got '{}'", a->filter));
              o.filter = a->filter == "on" ? FilterMode::On : a->filter == "off" ? FilterMode::Off : FilterMode::Auto;
              return evaluate_and_report("eval temporal", out, evaluate_temporal, o);
            };
          }};
}

struct EvalEstimatorsArgs {
  EvalEstimatorsOptions o;
  std::string estimators = "mis,bis,bis-mix,smc,smc-mix", budgets = "4,16,64,256";
  std::string scenarios = "moving-light,abrupt-switch,flicker", size = "256x128";
  bool quick = false;  // demo: 4 frames, 2 repeats, budgets 4,16,64, no sweep
};

int run_eval_estimators(const EvalEstimatorsArgs& args, const Output& out) {
  EvalEstimatorsOptions o = args.o;
  check_frame_count("--frames", o.frames);
  std::string budgets = args.budgets;
  if (args.quick) {  // the demo: short, and no sweep; what the user gave stays (it was overridden)
    const EvalEstimatorsOptions d;
    if (o.frames == d.frames) o.frames = 4;
    if (o.repeats == d.repeats) o.repeats = 2;
    if (budgets == EvalEstimatorsArgs{}.budgets) budgets = "4,16,64";
    if (o.sweep == d.sweep) o.sweep = false;
  }
  o.budgets = parse_int_list(budgets, "--budgets");
  o.estimators = split_commas(args.estimators);
  parse_image_size(args.size, "--size", &o.width, &o.height);
  o.scenarios = parse_scenarios(args.scenarios);
  return evaluate_and_report("eval estimators", out, evaluate_estimators, o);
}

Command eval_estimators_command() {
  return {"eval estimators", "MIS, BIS and SMC reflected-radiance estimators: error, temporal noise, time",
          "lightprobe eval estimators probe.exr scene --repeats 8 -o eval/estimators\nlightprobe eval estimators seq/ --estimators mis,bis,smc --budgets 4,16,64 -o eval/estimators",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalEstimatorsArgs>();
            f.arg("SEQ|MAP", a->o.inputs, "Sequence directories, base maps for the scenarios, or 'scene'").required();
            f.opt("--estimators", a->estimators, "Comma-separated: mis, bis, bis-mix, smc, smc-mix (-mix: half the BIS proposals from the map)");
            f.opt("--budgets", a->budgets, "Comma-separated samples per estimate (visibility tests)");
            f.opt("--scenarios", a->scenarios, "Scenarios built on base maps (comma-separated or 'all')");
            f.opt("--frames", a->o.frames, "Frames per scenario (a directory: its first frames)");
            f.opt("--repeats", a->o.repeats, "Independent runs per estimate (variance across them)");
            f.opt("--size", a->size, "Latlong size every map is resampled to (WxH)");
            f.opt("--bis-m", a->o.bis_m, "BIS/SMC-initialisation proposals per sample (M = m N)");
            f.opt("--seed", a->o.seed, "Random seed");
            f.opt("--ray-cost-us", a->o.ray_cost_us, "Modelled microseconds per visibility test, added to the time");
            f.flag("!--no-sweep", a->o.sweep, "Skip the SMC parameter sweep");
            f.flag("--quick", a->quick, "Demo: 4 frames, 2 runs, budgets 4,16,64, no sweep (where not given)");
            f.output(a->o.output_dir, "Directory for estimators.csv/.svg and smc_sweep.csv/.svg");
            return [a](const Output& out) { return run_eval_estimators(*a, out); };
          }};
}

struct EvalShadingArgs {
  EvalShadingOptions o;
  std::string counts = "64,256,1024,4096";
  ShadingTableArgs tables;  // n is taken from counts
};

Command eval_shading_command() {
  return {"eval shading", "Speed-up and error of culled, glossy two-strata and clustered many-light shading",
          "lightprobe eval shading probe.exr scene --n 256,1024,4096 -o eval/shading",
          [](Flags& f) -> Handler {
            auto a = std::make_shared<EvalShadingArgs>();
            f.arg("MAP", a->o.maps, "Maps to evaluate ('scene' for the procedural scene)").required();
            f.opt("--n", a->counts, "Comma-separated light counts |H|");
            f.opt("--points", a->o.points, "Shading points per timing run (0: automatic)");
            f.flag("--region-copies", a->tables.region_copies, "Shade from per-region copies of the lights instead of index lists into one array");
            f.flag("--coherent", a->o.coherent, "Shade points in the order of their normal's region, as neighbouring pixels come (default: random)");
            declare_table_options(f, a->tables);
            f.output(a->o.output_dir, "Directory for shading.csv and shading.svg");
            return [a](const Output& out) {
              EvalShadingOptions o = a->o;
              o.counts = parse_light_counts(a->counts, "--n");
              if (o.points < 0)
                throw InputError(fmt::format("--points must be positive (or 0: automatic), got {}", o.points));
              o.shading = shading_options(a->tables);
              o.method = progressive_method(a->tables.method);
              return evaluate_and_report("eval shading", out, evaluate_shading, o);
            };
          }};
}

struct EvalHdrArgs {
  EvalHdrOptions o;
  std::string response = "gamma";
};

struct EvalCalibArgs {
  EvalCalibOptions o;
  std::string board = "9x6";
  double square_mm = 30;
};

struct EvalMetadataArgs {
  EvalMetadataOptions o;
  std::string fractions = "0.1,0.25,0.5,0.75,1";
};

}  // namespace

std::vector<Command> eval_commands() {
  return {
      eval_sampling_command(),
      eval_temporal_command(),
      eval_estimators_command(),
      eval_shading_command(),
      {"eval hdr", "Error and time of HDR fusion against OpenCV on synthetic brackets",
       "lightprobe eval hdr scene probe.exr --response scurve -o eval/hdr",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EvalHdrArgs>();
         f.arg("MAP", a->o.maps, "Radiance maps ('scene' for the procedural scene)").required();
         f.opt("--response", a->response, "Camera response of the synthetic brackets: linear|gamma|scurve");
         f.output(a->o.output_dir, "Directory for hdr.csv and hdr.svg");
         return [a](const Output& out) {
           EvalHdrOptions o = a->o;
           o.response = curve_from(a->response);
           return evaluate_and_report("eval hdr", out, evaluate_hdr, o);
         };
       }},
      {"eval calib", "Our geometric calibration against OpenCV run alone; synthetic sweep",
       "lightprobe eval calib views/*.jpg --board 9x6 --square 25 -o eval/calib\nlightprobe eval calib --sweep -o eval/calib",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EvalCalibArgs>();
         f.arg("IMAGE", a->o.images, "Chessboard views of one camera (optional with --sweep)");
         f.opt("--board", a->board, "COLSxROWS inner corners");
         f.opt("--square", a->square_mm, "Square size, mm");
         f.flag("--sweep", a->o.sweep, "Views 4..20 and noise 0.05..0.5 px on synthetic corners: error vs truth");
         f.output(a->o.output_dir, "Directory for calib_compare.csv, calib_sweep.csv/.svg");
         return [a](const Output& out) {
           EvalCalibOptions o = a->o;
           // The sweep renders its own board: without images, --board and --square said nothing.
           const EvalCalibArgs d;
           if (o.images.empty() && (a->board != d.board || a->square_mm != d.square_mm))
             throw InputError("--board and --square describe the images given; the sweep alone uses its own 10x7, 40 mm board");
           parse_size(a->board, "--board", &o.board.cols, &o.board.rows);
           o.board.square_mm = a->square_mm;
           keep_heap_for_reuse();
           return evaluate_and_report("eval calib", out, evaluate_calib, o);
         };
       }},
      {"eval unwrap", "Unwrapping error and centre error on synthetic probes",
       "lightprobe eval unwrap scene probe.exr -o eval/unwrap",
       [](Flags& f) -> Handler {
         auto o = std::make_shared<EvalUnwrapOptions>();
         f.arg("MAP", o->maps, "Latlong maps ('scene' for the procedural scene)").required();
         f.output(o->output_dir, "Directory for unwrap.csv");
         return [o](const Output& out) {
           keep_heap_for_reuse();  // a ball found in every probe: the images reused
           return evaluate_and_report("eval unwrap", out, evaluate_unwrap, *o);
         };
       }},
      {"eval merge", "Merging four displaced cameras: position weights against equal ones at a camera placed at the target",
       "lightprobe eval merge -o eval/merge",
       [](Flags& f) -> Handler {
         auto o = std::make_shared<EvalMergeOptions>();
         f.opt("--grid", o->grid, "Targets per side of the cameras' square");
         f.opt("--n", o->n, "Lights per camera and of the merge");
         f.output(o->output_dir, "Directory for merge.csv and merge.svg");
         return [o](const Output& out) { return evaluate_and_report("eval merge", out, evaluate_merge, *o); };
       }},
      {"eval auto-bracket", "Auto-bracketing against fixed 3- and 5-exposure brackets: a lamp, a window, a cloud",
       "lightprobe eval auto-bracket -o eval/auto_bracket", [](Flags& f) -> Handler {
         auto o = std::make_shared<EvalAutoBracketOptions>();
         f.output(o->output_dir, "Directory for auto_bracket.csv (every frame of every bracket)");
         return [o](const Output& out) { return evaluate_and_report("eval auto-bracket", out, evaluate_auto_bracket, *o); };
       }},
      {"eval metadata", "Diffuse error of the metadata model against real probes along a walk",
       "lightprobe synth walkthrough -o walk/ && lightprobe eval metadata walk/ -o eval/metadata",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EvalMetadataArgs>();
         f.arg("DIR", a->o.input_dir, "Directory from synth walkthrough").required();
         f.output(a->o.output_dir, "Directory for metadata.csv and metadata.svg");
         f.opt("--fractions", a->fractions, "Parts of the path to build the model from");
         f.opt("--root-size", a->o.root_size, "Root cell side, m (0: twice the room's larger side)");
         f.opt("--min-size", a->o.min_size, "Smallest cell side, m");
         return [a](const Output& out) {
           EvalMetadataOptions o = a->o;
           o.fractions = parse_numbers(a->fractions, "--fractions");
           return evaluate_and_report("eval metadata", out, evaluate_metadata, o);
         };
       }},
  };
}

}  // namespace lp::cli
