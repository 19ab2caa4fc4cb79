// eval sampling: time and error of every method at every light count, on every map.
// Times are medians of repeated runs with the map already in memory, split into
// pre-processing (prepare) and placement (place).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>

#include "cli/commands.h"
#include "cli/report.h"
#include "eval/svg_chart.h"
#include "core/accuracy.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "eval/synthetic_scene.h"
#include "sampling/sampler.h"

namespace lp::cli {

std::vector<Method> parse_method_list(const std::string& text) {
  if (text == "all") return all_methods();
  std::vector<Method> methods;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string name = text.substr(start, comma - start);
    auto m = method_from_string(name);
    if (!m) throw InputError(fmt::format("--methods: unknown method '{}' (pharr, hemigon, q2tree, mediancut, all)", name));
    methods.push_back(*m);
    start = comma + 1;
  }
  return methods;
}

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
  const std::vector<int> counts = parse_int_list(args.counts, "--n");
  std::error_code ec;
  fs::create_directories(args.output_dir, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the output directory: {}", args.output_dir, ec.message()));

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

}  // namespace lp::cli
