// synth sequence and eval temporal: dynamic scenes with ground truth, and where each
// method breaks on them (flicker, jitter, lag; CONVENTIONS.md "Temporal").
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>

#include "cli/commands.h"
#include "cli/eval_handlers.h"
#include "cli/report.h"
#include "eval/svg_chart.h"
#include "core/accuracy.h"
#include "core/error.h"
#include "core/limits.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "core/resample.h"
#include "eval/synthetic_scene.h"
#include "eval/synthetic_sequence.h"
#include "eval/temporal_accuracy.h"
#include "sampling/frame_pipeline.h"

namespace lp::cli {

namespace {

namespace fs = std::filesystem;


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

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / double(v.size());
}

}  // namespace

int run_eval_temporal(const EvalTemporalArgs& args, const Output& out) {
  const std::vector<Method> methods = parse_method_list(args.methods);
  const std::vector<Scenario> scenarios = parse_scenarios(args.scenarios);
  if (args.n <= 0) throw InputError(fmt::format("--n must be positive, got {}", args.n));
  check_light_count("--n", args.n);
  check_frame_count("--frames", args.frames);
  make_output_directory(args.output_dir);

  struct Row {
    std::string map, scenario, method;
    TemporalReport report;
    double ms_per_frame = 0;
    int delay = 0;
  };
  std::vector<Row> rows;
  std::vector<ChartPanel> panels;
  Progress progress("eval temporal", args.maps.size() * scenarios.size() * size_t(args.frames), out.progress);
  AccuracyOptions ao;
  ao.shadowed = false;
  ao.glossy_exponents.clear();
  for (const std::string& map_path : args.maps) {
    const EnvMap base = map_or_scene(map_path, 512);
    for (Scenario scenario : scenarios) {
      SequenceOptions so;
      so.scenario = scenario;
      so.frames = args.frames;
      so.frame_rate_hz = args.fps;
      validate(so);
      std::vector<FramePipeline> pipelines;
      std::vector<TemporalScorer> scorers(methods.size());
      std::vector<double> ms(methods.size(), 0.0);
      for (Method m : methods) {
        FramePipelineOptions po;
        po.method = m;
        po.count = args.n;
        po.frame_rate_hz = args.fps;
        po.filter = args.filter == "on" ? FilterMode::On : args.filter == "off" ? FilterMode::Off : FilterMode::Auto;
        pipelines.emplace_back(po);
      }
      ChartPanel panel{fmt::format("{}: {} (power)", map_label(map_path), to_string(scenario)), "frame",
                       "mean irradiance over 256 normals", {}};
      panel.log_x = panel.log_y = false;
      ChartPanel error_panel{fmt::format("{}: {} (error)", map_label(map_path), to_string(scenario)), "frame",
                             "diffuse error of the frame", {}};
      error_panel.log_x = false;
      ChartSeries truth{"reference", {}, {}, {}};
      std::vector<ChartSeries> series, errors;
      for (Method m : methods) series.push_back({std::string(to_string(m)), {}, {}, {}});
      errors = series;
      for (int f = 0; f < so.frames; ++f) {
        const EnvMap frame = render_sequence_frame(base, so, f);
        const std::vector<double> e_ref = make_accuracy_reference(frame, ao).diffuse;
        truth.x.push_back(f);
        truth.y.push_back(mean(e_ref));
        for (size_t i = 0; i < methods.size(); ++i) {
          const auto t0 = std::chrono::steady_clock::now();
          const LightList lights = pipelines[i].process(frame, f, f / so.frame_rate_hz);
          ms[i] += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
          scorers[i].add_frame(e_ref, lights.lights);
          series[i].x.push_back(f);
          const std::vector<double>& e_lights = scorers[i].lights_irradiance(f);
          series[i].y.push_back(mean(e_lights));
          double sq = 0;
          for (size_t k = 0; k < e_ref.size(); ++k) sq += (e_lights[k] - e_ref[k]) * (e_lights[k] - e_ref[k]);
          errors[i].x.push_back(f);
          errors[i].y.push_back(std::sqrt(sq / double(e_ref.size())) / mean(e_ref));
        }
        progress.advance();
      }
      const std::optional<int> step =
          scenario == Scenario::AbruptSwitch ? std::optional<int>(step_frame(so)) : std::nullopt;
      for (size_t i = 0; i < methods.size(); ++i)
        rows.push_back({map_label(map_path), std::string(to_string(scenario)), std::string(to_string(methods[i])),
                        scorers[i].report(step), ms[i] / so.frames, pipelines[i].delay_frames()});
      for (auto& s : series) panel.series.push_back(std::move(s));
      panel.series.push_back(truth);  // last, so the truth is drawn on top
      for (auto& s : errors) error_panel.series.push_back(std::move(s));
      panels.push_back(std::move(panel));
      panels.push_back(std::move(error_panel));
    }
  }
  progress.finish();

  auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string("nan"); };
  std::string csv = "map,scenario,method,flicker,jitter_deg,lag_frames,mean_diffuse_error,ms_per_frame,filter_delay_frames\n";
  for (const Row& r : rows)
    csv += fmt::format("{},{},{},{},{},{},{},{},{}\n", r.map, r.scenario, r.method, num(r.report.flicker),
                       num(r.report.jitter_deg), num(r.report.lag_frames), num(r.report.mean_diffuse_error),
                       num(r.ms_per_frame), r.delay);
  const std::string csv_path = (fs::path(args.output_dir) / "temporal.csv").string();
  write_file_atomically(csv_path, csv);
  const std::string svg_path = (fs::path(args.output_dir) / "temporal.svg").string();
  write_file_atomically(svg_path, svg_chart(fmt::format("Per frame: power (mean irradiance) and diffuse error, n = {}", args.n), panels, 2));

  say(out, "{:<10} {:<14} {:<10} {:>9} {:>10} {:>5} {:>9} {:>9}\n", "map", "scenario", "method", "flicker",
      "jitter deg", "lag", "diffuse", "ms/frame");
  for (const Row& r : rows)
    say(out, "{:<10} {:<14} {:<10} {:>8.3f}% {:>10.3f} {:>5} {:>8.2f}% {:>9.3f}\n", r.map, r.scenario, r.method,
        100 * r.report.flicker, r.report.jitter_deg,
        std::isfinite(r.report.lag_frames) ? fmt::format("{:g}", r.report.lag_frames) : std::string("-"),
        100 * r.report.mean_diffuse_error, r.ms_per_frame);
  say(out, "{} rows -> {}, {}\n", rows.size(), csv_path, svg_path);
  nlohmann::json jrows = nlohmann::json::array();
  for (const Row& r : rows)
    jrows.push_back({{"map", r.map}, {"scenario", r.scenario}, {"method", r.method}, {"flicker", r.report.flicker},
                     {"jitter_deg", r.report.jitter_deg},
                     {"lag_frames", std::isfinite(r.report.lag_frames) ? nlohmann::json(r.report.lag_frames) : nlohmann::json()},
                     {"mean_diffuse_error", r.report.mean_diffuse_error}, {"ms_per_frame", r.ms_per_frame},
                     {"filter_delay_frames", r.delay}});
  emit_json(out, {{"csv", csv_path}, {"chart", svg_path}, {"rows", jrows}});
  return 0;
}

}  // namespace lp::cli
