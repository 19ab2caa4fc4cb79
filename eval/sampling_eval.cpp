#include "eval/sampling_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include "core/accuracy.h"
#include "core/error.h"
#include "core/image_io.h"
#include "eval/svg_chart.h"
#include "sampling/lights_and_ambient.h"

namespace lp {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

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

// An error not measured (--no-shadowed): NaN, which the CSV writes as nan, JSON as null and
// the table as a dash; it was 0, a perfect score.
constexpr double kNotMeasured = std::numeric_limits<double>::quiet_NaN();
std::string percent_or_dash(double x) { return std::isfinite(x) ? fmt::format("{:.2f}%", 100 * x) : "-"; }
nlohmann::json finite_or_null(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); }

std::vector<ChartPanel> panels_for(const std::vector<SamplingPoint>& points, const std::vector<Method>& methods) {
  struct Metric {
    const char* title;
    double SamplingPoint::*field;
  };
  const Metric metrics[] = {{"diffuse error", &SamplingPoint::diffuse},
                            {"glossy error (s = 10)", &SamplingPoint::glossy10},
                            {"glossy error (s = 100)", &SamplingPoint::glossy100},
                            {"shadowed error (60 deg caps)", &SamplingPoint::shadowed}};
  std::vector<ChartPanel> panels;
  for (const Metric& m : metrics) {
    if (std::none_of(points.begin(), points.end(), [&](const SamplingPoint& p) { return std::isfinite(p.*(m.field)); }))
      continue;  // not measured (--no-shadowed): no panel of zeros
    ChartPanel panel{m.title, "time per frame, ms (prepare + place, median)", "relative RMS error", {}};
    for (Method method : methods) {
      ChartSeries s{std::string(to_string(method)), {}, {}, {}};
      for (const SamplingPoint& p : points)
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

// n lights + SH9, n lights alone, SH9 alone on one map (reference shared with the samplers).
void measure_ambient(const std::string& path, const EnvMap& map, const AccuracyReference& reference,
                     const EvalSamplingOptions& options, std::vector<AmbientPoint>& points) {
  for (int n : options.ambient_counts) {
    AmbientComparison c;
    try {
      c = compare_lights_and_sh9(map, reference, n, options.ambient_method);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", path, e.what()));
    }
    auto point = [&](const char* variant, const LightError& e, double share) {
      points.push_back({map_label(path), variant, n, e.diffuse, e.glossy.at(0), e.glossy.at(1),
                        options.shadowed ? e.shadowed : kNotMeasured, share});
    };
    point("lights+sh9", c.lights_and_sh9, c.light_power_share);
    point("lights", c.lights_only, 1);
    point("sh9", c.sh9_only, 0);
  }
}

// Every method at every count on one map.
void measure_map(const std::string& path, const EvalSamplingOptions& options, ProgressSteps& steps,
                 std::vector<SamplingPoint>& points, std::vector<AmbientPoint>& ambient) {
  AccuracyOptions ao;
  ao.shadowed = options.shadowed;
  const EnvMap map = map_or_scene(path, 1024);
  const AccuracyReference reference = make_accuracy_reference(map, ao);
  for (Method method : options.methods) {
    auto sampler = make_sampler(method);
    try {
      sampler->prepare(map);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", path, e.what()));
    }
    const double prepare_ms = median_ms([&] { sampler->prepare(map); }, options.repeats, 0.3);
    for (int n : options.counts) {
      steps.advance();
      if (method == Method::Q2Tree && n < 12) continue;  // a Q2-tree has at least its 12 base quads
      std::vector<Light> lights;
      const double place_ms = median_ms([&] { lights = sampler->place(n); }, options.repeats, 0.1);
      const LightError e = light_error(reference, lights);
      points.push_back({map_label(path), std::string(to_string(method)), n, int(lights.size()), prepare_ms, place_ms,
                        e.diffuse, e.glossy.at(0), e.glossy.at(1), options.shadowed ? e.shadowed : kNotMeasured});
    }
  }
  measure_ambient(path, map, reference, options, ambient);
}

std::vector<AmbientPoint> ambient_medians(const std::vector<AmbientPoint>& points, const EvalSamplingOptions& options) {
  std::vector<AmbientPoint> out;
  for (int n : options.ambient_counts)
    for (const char* variant : {"lights+sh9", "lights", "sh9"}) {
      std::vector<double> d, g10, g100, sh, share;
      for (const AmbientPoint& p : points)
        if (p.n == n && p.variant == variant) {
          d.push_back(p.diffuse), g10.push_back(p.glossy10), g100.push_back(p.glossy100);
          sh.push_back(p.shadowed), share.push_back(p.light_power_share);
        }
      if (!d.empty())
        out.push_back({"median", variant, n, median(d), median(g10), median(g100),
                       options.shadowed ? median(sh) : kNotMeasured, median(share)});
    }
  return out;
}

// sampling_ambient.csv (every point) and sampling_ambient.svg (medians: error against n).
void write_ambient_files(EvalSamplingReport& report, const EvalSamplingOptions& options) {
  std::string csv = "map,variant,n,diffuse,glossy10,glossy100,shadowed,light_power_share\n";
  for (const AmbientPoint& p : report.ambient)
    csv += fmt::format("{},{},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", p.map, p.variant, p.n, p.diffuse, p.glossy10,
                       p.glossy100, p.shadowed, p.light_power_share);
  report.ambient_csv_path = (fs::path(options.output_dir) / "sampling_ambient.csv").string();
  write_file_atomically(report.ambient_csv_path, csv);
  std::vector<ChartPanel> panels;
  const struct {
    const char* title;
    double AmbientPoint::*field;
  } measures[] = {{"diffuse", &AmbientPoint::diffuse},
                  {"glossy s = 10", &AmbientPoint::glossy10},
                  {"glossy s = 100", &AmbientPoint::glossy100},
                  {"shadowed (60 deg caps)", &AmbientPoint::shadowed}};
  for (const auto& m : measures) {
    if (m.field == &AmbientPoint::shadowed && !options.shadowed) continue;
    ChartPanel panel{m.title, "lights n", "relative RMS error", {}};
    for (const char* variant : {"lights+sh9", "lights", "sh9"}) {
      ChartSeries s{variant, {}, {}, {}};
      for (const AmbientPoint& p : report.ambient_medians)
        if (p.variant == variant) s.x.push_back(p.n), s.y.push_back(p.*m.field);
      panel.series.push_back(s);
    }
    panels.push_back(panel);
  }
  report.ambient_svg_path = (fs::path(options.output_dir) / "sampling_ambient.svg").string();
  write_file_atomically(report.ambient_svg_path,
                        svg_chart(fmt::format("n lights + SH9 ambient, n lights alone, SH9 alone ({}, median over {} maps)",
                                              to_string(options.ambient_method), options.maps.size()),
                                  panels));
}

// Medians over maps per (method, n): the summary chart and table.
std::vector<SamplingPoint> medians_over_maps(const std::vector<SamplingPoint>& points, const EvalSamplingOptions& options) {
  std::vector<SamplingPoint> medians;
  for (Method method : options.methods)
    for (int n : options.counts) {
      std::vector<double> pre, place, d, g10, g100, sh, lights;
      for (const SamplingPoint& p : points)
        if (p.method == to_string(method) && p.n == n) {
          pre.push_back(p.prepare_ms), place.push_back(p.place_ms), d.push_back(p.diffuse);
          g10.push_back(p.glossy10), g100.push_back(p.glossy100), sh.push_back(p.shadowed);
          lights.push_back(p.lights);
        }
      if (d.empty()) continue;
      medians.push_back({"median", std::string(to_string(method)), n, int(median(lights)), median(pre), median(place),
                         median(d), median(g10), median(g100), options.shadowed ? median(sh) : kNotMeasured});
    }
  return medians;
}

// sampling.csv, sampling.svg and, with several maps, one chart per map.
void write_sampling_files(EvalSamplingReport& report, const EvalSamplingOptions& options) {
  std::string csv = "map,method,n,lights,prepare_ms,place_ms,total_ms,diffuse,glossy10,glossy100,shadowed\n";
  for (const SamplingPoint& p : report.points)
    csv += fmt::format("{},{},{},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", p.map, p.method, p.n, p.lights,
                       p.prepare_ms, p.place_ms, p.prepare_ms + p.place_ms, p.diffuse, p.glossy10, p.glossy100,
                       p.shadowed);
  report.csv_path = (fs::path(options.output_dir) / "sampling.csv").string();
  write_file_atomically(report.csv_path, csv);

  const std::string title = options.maps.size() == 1
                                ? fmt::format("Speed against accuracy: {}", map_label(options.maps[0]))
                                : fmt::format("Speed against accuracy: median over {} maps", options.maps.size());
  report.svg_path = (fs::path(options.output_dir) / "sampling.svg").string();
  write_file_atomically(report.svg_path, svg_chart(title, panels_for(report.medians, options.methods)));
  if (options.maps.size() > 1)
    for (const std::string& path : options.maps) {
      std::vector<SamplingPoint> mine;
      for (const SamplingPoint& p : report.points)
        if (p.map == map_label(path)) mine.push_back(p);
      write_file_atomically((fs::path(options.output_dir) / fmt::format("sampling_{}.svg", map_label(path))).string(),
                            svg_chart(fmt::format("Speed against accuracy: {}", map_label(path)),
                                      panels_for(mine, options.methods)));
    }
}

}  // namespace

EvalSamplingReport evaluate_sampling(const EvalSamplingOptions& options, const EvalProgress& progress) {
  make_output_directory(options.output_dir);
  EvalSamplingReport report;
  report.maps = options.maps.size();
  {
    ProgressSteps steps(progress, options.maps.size() * options.methods.size() * options.counts.size());
    for (const std::string& path : options.maps) measure_map(path, options, steps, report.points, report.ambient);
  }
  report.medians = medians_over_maps(report.points, options);
  write_sampling_files(report, options);
  if (!options.ambient_counts.empty()) {
    report.ambient_medians = ambient_medians(report.ambient, options);
    write_ambient_files(report, options);
  }
  return report;
}

std::string EvalSamplingReport::summary() const {
  std::string s = fmt::format("{:<10} {:>6} {:>7} {:>11} {:>10} {:>9} {:>9} {:>10} {:>9}\n", "method", "n", "lights",
                              "prepare ms", "place ms", "diffuse", "glossy10", "glossy100", "shadowed");
  for (const SamplingPoint& p : medians)
    s += fmt::format("{:<10} {:>6} {:>7} {:>11.3f} {:>10.4f} {:>8.2f}% {:>8.2f}% {:>9.2f}% {:>9}\n", p.method, p.n,
                     p.lights, p.prepare_ms, p.place_ms, 100 * p.diffuse, 100 * p.glossy10, 100 * p.glossy100,
                     percent_or_dash(p.shadowed));
  s += fmt::format("{} points on {} maps -> {}, {}\n", points.size(), maps, csv_path, svg_path);
  if (ambient_medians.empty()) return s;
  s += fmt::format("\n{:<11} {:>4} {:>9} {:>9} {:>10} {:>9} {:>12}\n", "lighting", "n", "diffuse", "glossy10",
                   "glossy100", "shadowed", "light share");
  for (const AmbientPoint& p : ambient_medians)
    s += fmt::format("{:<11} {:>4} {:>8.2f}% {:>8.2f}% {:>9.2f}% {:>9} {:>11.1f}%\n", p.variant, p.n,
                     100 * p.diffuse, 100 * p.glossy10, 100 * p.glossy100, percent_or_dash(p.shadowed),
                     100 * p.light_power_share);
  s += fmt::format("-> {}, {}\n", ambient_csv_path, ambient_svg_path);
  return s;
}

nlohmann::json EvalSamplingReport::to_json() const {
  nlohmann::json rows = nlohmann::json::array();
  for (const SamplingPoint& p : points)
    rows.push_back({{"map", p.map}, {"method", p.method}, {"n", p.n}, {"lights", p.lights},
                    {"prepare_ms", p.prepare_ms}, {"place_ms", p.place_ms}, {"diffuse", p.diffuse},
                    {"glossy10", p.glossy10}, {"glossy100", p.glossy100}, {"shadowed", finite_or_null(p.shadowed)}});
  nlohmann::json ambient_rows = nlohmann::json::array();
  for (const AmbientPoint& p : ambient)
    ambient_rows.push_back({{"map", p.map}, {"variant", p.variant}, {"n", p.n}, {"diffuse", p.diffuse},
                            {"glossy10", p.glossy10}, {"glossy100", p.glossy100}, {"shadowed", finite_or_null(p.shadowed)},
                            {"light_power_share", p.light_power_share}});
  return {{"csv", csv_path},
          {"chart", svg_path},
          {"points", rows},
          {"ambient", {{"csv", ambient_csv_path}, {"chart", ambient_svg_path}, {"points", ambient_rows}}}};
}

}  // namespace lp
