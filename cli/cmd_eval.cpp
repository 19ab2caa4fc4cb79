// eval sampling: time and error of every method at every light count, on every map.
// Times are medians of repeated runs with the map already in memory, split into
// pre-processing (prepare) and placement (place).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <memory>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>

#include "cli/commands.h"
#include "cli/eval_handlers.h"
#include "cli/report.h"
#include "eval/svg_chart.h"
#include "core/accuracy.h"
#include "core/error.h"
#include "core/limits.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "eval/synthetic_scene.h"
#include "sampling/sampler.h"

namespace lp::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Point {
  std::string map, method;
  int n = 0, lights = 0;
  double prepare_ms = 0, place_ms = 0;
  double diffuse = 0, glossy10 = 0, glossy100 = 0, shadowed = 0;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

// Runs f at least 5 times and until ~budget seconds are spent (or `fixed` times); median in ms.
template <typename F>
double median_ms(F&& f, int fixed, double budget_s) {
  std::vector<double> t;
  const auto start = Clock::now();
  for (int i = 0;; ++i) {
    const auto t0 = Clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    if (fixed > 0 ? i + 1 >= fixed
                  : (i + 1 >= 5 && std::chrono::duration<double>(Clock::now() - start).count() > budget_s) || i >= 400)
      break;
  }
  return median(t);
}

std::string map_name(const std::string& path) { return path == "scene" ? "scene" : fs::path(path).stem().string(); }

std::vector<ChartPanel> panels_for(const std::vector<Point>& points, const std::vector<Method>& methods) {
  struct Metric {
    const char* title;
    double Point::*field;
  };
  const Metric metrics[] = {{"diffuse error", &Point::diffuse},
                            {"glossy error (s = 10)", &Point::glossy10},
                            {"glossy error (s = 100)", &Point::glossy100},
                            {"shadowed error (60 deg caps)", &Point::shadowed}};
  std::vector<ChartPanel> panels;
  for (const Metric& m : metrics) {
    ChartPanel panel{m.title, "time per frame, ms (prepare + place, median)", "relative RMS error", {}};
    for (Method method : methods) {
      ChartSeries s{std::string(to_string(method)), {}, {}, {}};
      for (const Point& p : points)
        if (p.method == s.name) {
          s.x.push_back(p.prepare_ms + p.place_ms);
          s.y.push_back(p.*(m.field));
          s.labels.push_back(fmt::format("n={}", p.n));
        }
      panel.series.push_back(std::move(s));
    }
    panels.push_back(std::move(panel));
  }
  return panels;
}

}  // namespace

int run_eval_sampling(const EvalSamplingArgs& args, const Output& out) {
  const std::vector<Method> methods = parse_method_list(args.methods);
  const std::vector<int> counts = parse_light_counts(args.counts, "--n");
  make_output_directory(args.output_dir);

  AccuracyOptions ao;
  ao.shadowed = !args.no_shadowed;
  std::vector<Point> points;
  Progress progress("eval sampling", args.maps.size() * methods.size() * counts.size(), out.progress);
  for (const std::string& path : args.maps) {
    const EnvMap map = path == "scene" ? render_scene(describe_scene(), Layout::LatLong, 1024, 512) : read_envmap(path);
    const AccuracyReference reference = make_accuracy_reference(map, ao);
    for (Method method : methods) {
      auto sampler = make_sampler(method);
      try {
        sampler->prepare(map);
      } catch (const InputError& e) {
        throw InputError(fmt::format("{}: {}", path, e.what()));
      }
      const double prepare_ms = median_ms([&] { sampler->prepare(map); }, args.repeats, 0.3);
      for (int n : counts) {
        progress.advance();
        if (method == Method::Q2Tree && n < 12) continue;  // a Q2-tree has at least its 12 base quads
        std::vector<Light> lights;
        const double place_ms = median_ms([&] { lights = sampler->place(n); }, args.repeats, 0.1);
        const LightError e = light_error(reference, lights);
        points.push_back({map_name(path), std::string(to_string(method)), n, int(lights.size()), prepare_ms, place_ms,
                          e.diffuse, e.glossy.at(0), e.glossy.at(1), e.shadowed});
      }
    }
  }
  progress.finish();

  // CSV of every point.
  std::string csv = "map,method,n,lights,prepare_ms,place_ms,total_ms,diffuse,glossy10,glossy100,shadowed\n";
  for (const Point& p : points)
    csv += fmt::format("{},{},{},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", p.map, p.method, p.n, p.lights,
                       p.prepare_ms, p.place_ms, p.prepare_ms + p.place_ms, p.diffuse, p.glossy10, p.glossy100,
                       p.shadowed);
  const std::string csv_path = (fs::path(args.output_dir) / "sampling.csv").string();
  write_file_atomically(csv_path, csv);

  // Medians over maps per (method, n): the summary chart and table.
  std::vector<Point> summary;
  for (Method method : methods)
    for (int n : counts) {
      std::vector<double> pre, place, d, g10, g100, sh, lights;
      for (const Point& p : points)
        if (p.method == to_string(method) && p.n == n) {
          pre.push_back(p.prepare_ms), place.push_back(p.place_ms), d.push_back(p.diffuse);
          g10.push_back(p.glossy10), g100.push_back(p.glossy100), sh.push_back(p.shadowed);
          lights.push_back(p.lights);
        }
      if (d.empty()) continue;
      summary.push_back({"median", std::string(to_string(method)), n, int(median(lights)), median(pre), median(place),
                         median(d), median(g10), median(g100), median(sh)});
    }
  const std::string title = args.maps.size() == 1
                                ? fmt::format("Speed against accuracy: {}", map_name(args.maps[0]))
                                : fmt::format("Speed against accuracy: median over {} maps", args.maps.size());
  const std::string svg_path = (fs::path(args.output_dir) / "sampling.svg").string();
  write_file_atomically(svg_path, svg_chart(title, panels_for(summary, methods)));
  if (args.maps.size() > 1)
    for (const std::string& path : args.maps) {
      std::vector<Point> mine;
      for (const Point& p : points)
        if (p.map == map_name(path)) mine.push_back(p);
      write_file_atomically((fs::path(args.output_dir) / fmt::format("sampling_{}.svg", map_name(path))).string(),
                            svg_chart(fmt::format("Speed against accuracy: {}", map_name(path)), panels_for(mine, methods)));
    }

  say(out, "{:<10} {:>6} {:>7} {:>11} {:>10} {:>9} {:>9} {:>10} {:>9}\n", "method", "n", "lights", "prepare ms",
      "place ms", "diffuse", "glossy10", "glossy100", "shadowed");
  for (const Point& p : summary)
    say(out, "{:<10} {:>6} {:>7} {:>11.3f} {:>10.4f} {:>8.2f}% {:>8.2f}% {:>9.2f}% {:>8.2f}%\n", p.method, p.n, p.lights,
        p.prepare_ms, p.place_ms, 100 * p.diffuse, 100 * p.glossy10, 100 * p.glossy100, 100 * p.shadowed);
  say(out, "{} points on {} maps -> {}, {}\n", points.size(), args.maps.size(), csv_path, svg_path);

  nlohmann::json rows = nlohmann::json::array();
  for (const Point& p : points)
    rows.push_back({{"map", p.map}, {"method", p.method}, {"n", p.n}, {"lights", p.lights},
                    {"prepare_ms", p.prepare_ms}, {"place_ms", p.place_ms}, {"diffuse", p.diffuse},
                    {"glossy10", p.glossy10}, {"glossy100", p.glossy100}, {"shadowed", p.shadowed}});
  emit_json(out, {{"csv", csv_path}, {"chart", svg_path}, {"points", rows}});
  return 0;
}

std::vector<Command> eval_commands() {
  return {
      {"eval sampling", "Time and error of every sampler and light count",
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
       }},
      {"eval temporal", "Flicker, jitter and lag of every method on dynamic scenarios",
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
       }},
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
      {"eval shading", "Speed-up and error of culled, glossy two-strata and clustered many-light shading",
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
       }},
      {"eval hdr", "Error and time of HDR fusion against OpenCV on synthetic brackets",
       "lightprobe eval hdr scene probe.exr --response scurve -o eval/hdr",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EvalHdrArgs>();
         f.arg("MAP", a->maps, "Radiance maps ('scene' for the procedural scene)").required();
         f.opt("--response", a->response, "Camera response of the synthetic brackets: linear|gamma|scurve");
         f.output(a->output_dir, "Directory for hdr.csv and hdr.svg");
         return [a](const Output& out) { return run_eval_hdr(*a, out); };
       }},
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
      {"eval unwrap", "Unwrapping error and centre error on synthetic probes",
       "lightprobe eval unwrap scene probe.exr -o eval/unwrap",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EvalUnwrapArgs>();
         f.arg("MAP", a->maps, "Latlong maps ('scene' for the procedural scene)").required();
         f.output(a->output_dir, "Directory for unwrap.csv");
         return [a](const Output& out) { return run_eval_unwrap(*a, out); };
       }},
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
