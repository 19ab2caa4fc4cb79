#include "eval/temporal_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>

#include "core/accuracy.h"
#include "core/image_io.h"
#include "eval/svg_chart.h"

namespace lp {

namespace {

namespace fs = std::filesystem;

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / double(v.size());
}

// The rows and the chart panels (power, error per frame; with auto_count also the light
// count and the time per frame) of one scenario on one map.
struct ScenarioResult {
  std::vector<TemporalRow> rows;
  ChartPanel power, error, lights, time;
};

ScenarioResult run_scenario(const EnvMap& base, const std::string& label, Scenario scenario,
                            const EvalTemporalOptions& options, ProgressSteps& steps) {
  const std::vector<Method>& methods = options.methods;
  SequenceOptions so;
  so.scenario = scenario;
  so.frames = options.frames;
  so.frame_rate_hz = options.frame_rate_hz;
  validate(so);
  AccuracyOptions ao;
  ao.shadowed = false;
  ao.glossy_exponents.clear();
  std::vector<FramePipeline> pipelines;
  std::vector<TemporalScorer> scorers(methods.size());
  std::vector<double> ms(methods.size(), 0.0);
  for (Method m : methods) {
    FramePipelineOptions po;
    po.method = m;
    po.count = options.count;
    po.auto_count = options.auto_count;
    po.auto_options = options.auto_options;
    po.budget.budget_ms = options.auto_count ? options.frame_budget_ms : 0;
    po.frame_rate_hz = options.frame_rate_hz;
    po.filter = options.filter;
    pipelines.emplace_back(po);
  }
  ScenarioResult result{{},
                        {fmt::format("{}: {} (power)", label, to_string(scenario)), "frame",
                         "mean irradiance over 256 normals", {}},
                        {fmt::format("{}: {} (error)", label, to_string(scenario)), "frame",
                         "diffuse error of the frame", {}},
                        {fmt::format("{}: {} (lights)", label, to_string(scenario)), "frame", "lights placed", {}},
                        {fmt::format("{}: {} (time)", label, to_string(scenario)), "frame", "back end, ms", {}}};
  result.power.log_x = result.power.log_y = false;
  result.error.log_x = result.lights.log_x = result.time.log_x = false;
  std::vector<double> light_sum(methods.size(), 0.0);
  ChartSeries truth{"reference", {}, {}, {}};
  std::vector<ChartSeries> series, errors;
  for (Method m : methods) series.push_back({std::string(to_string(m)), {}, {}, {}});
  errors = series;
  std::vector<ChartSeries> counts = series, times = series;
  for (int f = 0; f < so.frames; ++f) {
    const EnvMap frame = render_sequence_frame(base, so, f);
    const std::vector<double> e_ref = make_accuracy_reference(frame, ao).diffuse;
    truth.x.push_back(f);
    truth.y.push_back(mean(e_ref));
    for (size_t i = 0; i < methods.size(); ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      const LightList lights = pipelines[i].process(frame, f, f / so.frame_rate_hz);
      const double frame_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      ms[i] += frame_ms;
      const int placed = pipelines[i].last_count().count;
      light_sum[i] += placed;
      counts[i].x.push_back(f), counts[i].y.push_back(placed);
      times[i].x.push_back(f), times[i].y.push_back(frame_ms);
      scorers[i].add_frame(e_ref, lights.lights);
      series[i].x.push_back(f);
      const std::vector<double>& e_lights = scorers[i].lights_irradiance(f);
      series[i].y.push_back(mean(e_lights));
      double sq = 0;
      for (size_t k = 0; k < e_ref.size(); ++k) sq += (e_lights[k] - e_ref[k]) * (e_lights[k] - e_ref[k]);
      errors[i].x.push_back(f);
      errors[i].y.push_back(std::sqrt(sq / double(e_ref.size())) / mean(e_ref));
    }
    steps.advance();
  }
  const std::optional<int> step = scenario == Scenario::AbruptSwitch ? std::optional<int>(step_frame(so)) : std::nullopt;
  for (size_t i = 0; i < methods.size(); ++i)
    result.rows.push_back({label, std::string(to_string(scenario)), std::string(to_string(methods[i])),
                           scorers[i].report(step), ms[i] / so.frames, pipelines[i].delay_frames(),
                           light_sum[i] / so.frames});
  for (auto& s : series) result.power.series.push_back(std::move(s));
  result.power.series.push_back(truth);  // last, so the truth is drawn on top
  for (auto& s : errors) result.error.series.push_back(std::move(s));
  for (auto& s : counts) result.lights.series.push_back(std::move(s));
  for (auto& s : times) result.time.series.push_back(std::move(s));
  return result;
}

std::string number_or_nan(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string("nan"); }

}  // namespace

EvalTemporalReport evaluate_temporal(const EvalTemporalOptions& options, const EvalProgress& progress) {
  make_output_directory(options.output_dir);
  EvalTemporalReport report;
  std::vector<ChartPanel> panels;
  {
    ProgressSteps steps(progress, options.maps.size() * options.scenarios.size() * size_t(options.frames));
    for (const std::string& path : options.maps) {
      const EnvMap base = map_or_scene(path, 512);
      for (Scenario scenario : options.scenarios) {
        ScenarioResult r = run_scenario(base, map_label(path), scenario, options, steps);
        for (TemporalRow& row : r.rows) report.rows.push_back(std::move(row));
        panels.push_back(std::move(r.power));
        panels.push_back(std::move(r.error));
        if (options.auto_count) panels.push_back(std::move(r.lights)), panels.push_back(std::move(r.time));
      }
    }
  }

  std::string csv =
      "map,scenario,method,flicker,jitter_deg,lag_frames,mean_diffuse_error,ms_per_frame,filter_delay_frames,mean_lights\n";
  for (const TemporalRow& r : report.rows)
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{}\n", r.map, r.scenario, r.method, number_or_nan(r.report.flicker),
                       number_or_nan(r.report.jitter_deg), number_or_nan(r.report.lag_frames),
                       number_or_nan(r.report.mean_diffuse_error), number_or_nan(r.ms_per_frame), r.delay,
                       number_or_nan(r.mean_lights));
  report.csv_path = (fs::path(options.output_dir) / "temporal.csv").string();
  write_file_atomically(report.csv_path, csv);
  report.svg_path = (fs::path(options.output_dir) / "temporal.svg").string();
  write_file_atomically(report.svg_path,
                        svg_chart(options.auto_count
                                      ? fmt::format("Per frame: power, diffuse error, lights and time; n auto within {:g} {}{}",
                                                    options.auto_options.target_error, to_string(options.auto_options.measure),
                                                    options.frame_budget_ms > 0
                                                        ? fmt::format(", budget {:g} ms", options.frame_budget_ms)
                                                        : std::string())
                                      : fmt::format("Per frame: power (mean irradiance) and diffuse error, n = {}", options.count),
                                  panels, options.auto_count ? 4 : 2));
  return report;
}

std::string EvalTemporalReport::summary() const {
  std::string s = fmt::format("{:<10} {:<14} {:<10} {:>9} {:>10} {:>5} {:>9} {:>9} {:>7}\n", "map", "scenario", "method",
                              "flicker", "jitter deg", "lag", "diffuse", "ms/frame", "lights");
  for (const TemporalRow& r : rows)
    s += fmt::format("{:<10} {:<14} {:<10} {:>8.3f}% {:>10.3f} {:>5} {:>8.2f}% {:>9.3f} {:>7.1f}\n", r.map, r.scenario, r.method,
                     100 * r.report.flicker, r.report.jitter_deg,
                     std::isfinite(r.report.lag_frames) ? fmt::format("{:g}", r.report.lag_frames) : std::string("-"),
                     100 * r.report.mean_diffuse_error, r.ms_per_frame, r.mean_lights);
  s += fmt::format("{} rows -> {}, {}\n", rows.size(), csv_path, svg_path);
  return s;
}

nlohmann::json EvalTemporalReport::to_json() const {
  nlohmann::json jrows = nlohmann::json::array();
  for (const TemporalRow& r : rows)
    jrows.push_back({{"map", r.map}, {"scenario", r.scenario}, {"method", r.method}, {"flicker", r.report.flicker},
                     {"jitter_deg", r.report.jitter_deg},
                     {"lag_frames", std::isfinite(r.report.lag_frames) ? nlohmann::json(r.report.lag_frames) : nlohmann::json()},
                     {"mean_diffuse_error", r.report.mean_diffuse_error}, {"ms_per_frame", r.ms_per_frame},
                     {"filter_delay_frames", r.delay}, {"mean_lights", r.mean_lights}});
  return {{"csv", csv_path}, {"chart", svg_path}, {"rows", jrows}};
}

}  // namespace lp
