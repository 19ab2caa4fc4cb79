#include "eval/shading_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>

#include <time.h>

#include "core/accuracy.h"
#include "core/error.h"
#include "core/image_io.h"
#include "eval/svg_chart.h"
#include "render/angular_regions.h"

namespace lp {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr float kTimingExponent = 100;  // Phong s of the timed material

// Lights each variant's loops visit for one point: what culling can save at most.
double visits(const ShadingScene& s, ShadingVariant v, Vec3 n, Vec3 r) {
  switch (v) {
    case ShadingVariant::All: return 2.0 * double(s.lights.size());
    case ShadingVariant::Culled: return double(s.culled.size(s.regions->region_of(n)) + s.culled.size(s.regions->region_of(r)));
    case ShadingVariant::Glossy:
      return double(s.culled.size(s.regions->region_of(n)) + s.culled.size(s.regions->region_of(r)) +
                    s.glossy.low_regions.size(s.cone_regions->region_of(r)));
    case ShadingVariant::Clustered:
      return double(s.clustered_regions.size(s.regions->region_of(n)) +
                    s.clustered_regions.size(s.regions->region_of(r)));
  }
  return 0;
}

// CPU time of this thread: time spent descheduled by other processes does not count.
double thread_cpu_ns() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e9 * double(t.tv_sec) + double(t.tv_nsec);
}

// Nanoseconds (thread CPU time) per shaded point of every variant: the best of five
// single-thread runs, the variants interleaved within each round so that load from other
// processes hits them alike.
std::vector<double> ns_per_point(const ShadingScene& s, const std::vector<Vec3>& normals,
                                 const std::vector<Vec3>& reflections) {
  const Material material;
  const auto variants = all_shading_variants();
  std::vector<double> best(variants.size(), 1e300);
  volatile float sink = 0;
  for (int rep = 0; rep < 5; ++rep)
    for (size_t k = 0; k < variants.size(); ++k) {
      const double t0 = thread_cpu_ns();
      float acc = 0;
      for (size_t i = 0; i < normals.size(); ++i)
        acc += combine(material, shade(s, variants[k], normals[i], reflections[i], kTimingExponent)).g;
      const double ns = thread_cpu_ns() - t0;
      sink = sink + acc;
      best[k] = std::min(best[k], ns / double(normals.size()));
    }
  return best;
}

void sort_by_normal_region(const AngularRegions& regions, std::vector<Vec3>& normals, std::vector<Vec3>& reflections) {
  std::vector<std::pair<int, size_t>> key(normals.size());
  for (size_t i = 0; i < normals.size(); ++i) key[i] = {regions.region_of(normals[i]), i};
  std::sort(key.begin(), key.end());
  std::vector<Vec3> n(normals.size()), r(normals.size());
  for (size_t i = 0; i < key.size(); ++i) n[i] = normals[key[i].second], r[i] = reflections[key[i].second];
  normals.swap(n);
  reflections.swap(r);
}

std::vector<ChartPanel> panels_for(const std::vector<ShadingRow>& rows) {
  std::vector<ChartPanel> panels;
  // Clustering's speed-up (an order of magnitude) would flatten the others: it shows in
  // the error panels, where its time per point places it.
  ChartPanel speed{"speed-up over all lights: measured and ideal (lights visited)", "lights |H|", "speed-up (x)", {}};
  speed.log_y = false;
  for (ShadingVariant v : {ShadingVariant::Culled, ShadingVariant::Glossy}) {
    ChartSeries measured{std::string(to_string(v)), {}, {}, {}};
    ChartSeries ideal{std::string(to_string(v)) + " ideal", {}, {}, {}};
    for (const ShadingRow& r : rows)
      if (r.variant == measured.name) {
        measured.x.push_back(r.n), measured.y.push_back(r.speedup), measured.labels.push_back(fmt::format("{}", r.n));
        ideal.x.push_back(r.n), ideal.y.push_back(r.visit_ratio), ideal.labels.push_back("");
      }
    speed.series.push_back(std::move(measured));
    speed.series.push_back(std::move(ideal));
  }
  panels.push_back(std::move(speed));
  struct Metric {
    const char* title;
    double ShadingRow::*field;
  };
  for (const Metric& m : {Metric{"diffuse error", &ShadingRow::diffuse}, Metric{"glossy error (s = 10)", &ShadingRow::glossy10},
                          Metric{"glossy error (s = 100)", &ShadingRow::glossy100}}) {
    ChartPanel p{m.title, "time per shaded point, ns (1 thread)", "relative RMS error", {}};
    for (ShadingVariant v : all_shading_variants()) {
      ChartSeries s{std::string(to_string(v)), {}, {}, {}};
      for (const ShadingRow& r : rows)
        if (r.variant == s.name) s.x.push_back(r.ns), s.y.push_back(r.*(m.field)), s.labels.push_back(fmt::format("n={}", r.n));
      p.series.push_back(std::move(s));
    }
    panels.push_back(std::move(p));
  }
  return panels;
}

// One row per variant for one light count on one map.
void measure_count(const std::string& label, const ShadingScene& s, const AccuracyReference& reference, int n,
                   const EvalShadingOptions& options, std::vector<ShadingRow>& rows) {
  // ~8M light evaluations per all-lights run: stable times, a few ms each.
  const int points = options.points > 0 ? options.points : std::clamp((1 << 22) / n, 256, 32768);
  std::vector<Vec3> normals, reflections;
  make_shading_points(points, 20051 + uint64_t(n), normals, reflections);
  if (options.coherent)  // neighbouring pixels of a smooth surface: normals in region order
    sort_by_normal_region(*s.regions, normals, reflections);
  const std::vector<double> times = ns_per_point(s, normals, reflections);
  double all_ns = 0, all_visits = 0;
  for (ShadingVariant v : all_shading_variants()) {
    ShadingRow r;
    r.map = label;
    r.variant = std::string(to_string(v));
    r.n = n;
    r.lights = v == ShadingVariant::Clustered ? int(s.clustered.size())
               : v == ShadingVariant::Glossy  ? int(s.lights.size() + s.glossy.low.size())
                                              : int(s.lights.size());
    for (size_t i = 0; i < normals.size(); ++i) r.visits += visits(s, v, normals[i], reflections[i]);
    r.visits /= double(normals.size());
    r.ns = times[size_t(v)];
    if (v == ShadingVariant::All) all_ns = r.ns, all_visits = r.visits;
    r.speedup = all_ns / r.ns;
    r.visit_ratio = all_visits / r.visits;
    r.build_ms = v == ShadingVariant::All       ? 0
                 : v == ShadingVariant::Culled  ? s.culled_ms
                 : v == ShadingVariant::Glossy  ? s.culled_ms + s.glossy_ms
                                                : s.cluster_ms;
    const ShadingError e = shading_error(reference, s, v);
    r.diffuse = e.diffuse, r.glossy10 = e.glossy.at(0), r.glossy100 = e.glossy.at(1);
    rows.push_back(r);
  }
}

// Medians over maps per (variant, n).
std::vector<ShadingRow> medians_over_maps(const std::vector<ShadingRow>& rows, const std::vector<int>& counts) {
  std::vector<ShadingRow> medians;
  for (ShadingVariant v : all_shading_variants())
    for (int n : counts) {
      std::vector<double> f[9];
      for (const ShadingRow& r : rows)
        if (r.variant == to_string(v) && r.n == n) {
          const double vals[9] = {double(r.lights), r.visits, r.ns, r.speedup, r.visit_ratio, r.build_ms,
                                  r.diffuse, r.glossy10, r.glossy100};
          for (int k = 0; k < 9; ++k) f[k].push_back(vals[k]);
        }
      if (f[0].empty()) continue;
      medians.push_back({"median", std::string(to_string(v)), n, int(median(f[0])), median(f[1]), median(f[2]),
                         median(f[3]), median(f[4]), median(f[5]), median(f[6]), median(f[7]), median(f[8])});
    }
  return medians;
}

void write_shading_files(EvalShadingReport& report, const EvalShadingOptions& options) {
  std::string csv = "map,n,variant,lights,visits,ns_per_point,speedup,visit_ratio,build_ms,diffuse,glossy10,glossy100\n";
  for (const ShadingRow& r : report.rows)
    csv += fmt::format("{},{},{},{},{:.1f},{:.1f},{:.4f},{:.4f},{:.4g},{:.6g},{:.6g},{:.6g}\n", r.map, r.n, r.variant,
                       r.lights, r.visits, r.ns, r.speedup, r.visit_ratio, r.build_ms, r.diffuse, r.glossy10,
                       r.glossy100);
  report.csv_path = (fs::path(options.output_dir) / "shading.csv").string();
  write_file_atomically(report.csv_path, csv);
  const std::string title = options.maps.size() == 1
                                ? fmt::format("Many-light shading: {}", map_label(options.maps[0]))
                                : fmt::format("Many-light shading: median over {} maps", options.maps.size());
  report.svg_path = (fs::path(options.output_dir) / "shading.svg").string();
  write_file_atomically(report.svg_path, svg_chart(title, panels_for(report.medians)));
}

}  // namespace

EvalShadingReport evaluate_shading(const EvalShadingOptions& options, const EvalProgress& progress) {
  for (int n : options.counts)
    if (n < 1) throw InputError(fmt::format("eval shading: light counts must be positive, got {}", n));
  make_output_directory(options.output_dir);
  EvalShadingReport report;
  report.maps = options.maps.size();

  // Regions and LUTs are fixed for a renderer: built once, shared by every map and count.
  const auto t0 = Clock::now();
  auto regions = std::make_shared<const AngularRegions>(options.shading.regions);
  auto cones = std::make_shared<const AngularRegions>(options.shading.glossy.cone_regions);
  report.regions_build_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  report.regions = regions->count();
  report.region_max_radius_deg = regions->max_radius() * 180 / M_PI;
  report.cone_regions = cones->count();
  report.cone_max_radius_deg = cones->max_radius() * 180 / M_PI;
  report.lut_face_size = regions->face_size();

  AccuracyOptions ao;
  ao.shadowed = false;  // the shader has no occluders; the shadowed measure does not apply
  {
    ProgressSteps steps(progress, options.maps.size() * options.counts.size());
    for (const std::string& path : options.maps) {
      const EnvMap map = map_or_scene(path, 1024);
      const AccuracyReference reference = make_accuracy_reference(map, ao);
      auto sampler = make_sampler(options.method);
      try {
        sampler->prepare(map);
      } catch (const InputError& e) {
        throw InputError(fmt::format("{}: {}", path, e.what()));
      }
      for (int n : options.counts) {
        steps.advance();
        const ShadingScene s = prepare_shading(sampler->place(n * options.shading.glossy.low_per_high), n, regions,
                                               cones, options.shading);
        measure_count(map_label(path), s, reference, n, options, report.rows);
      }
    }
  }
  report.medians = medians_over_maps(report.rows, options.counts);
  write_shading_files(report, options);
  return report;
}

std::string EvalShadingReport::summary() const {
  std::string s = fmt::format(
      "regions: {} culling (max radius {:.2f} deg), {} cone (max radius {:.2f} deg), LUT {}x{}x6, built in {:.1f} ms\n",
      regions, region_max_radius_deg, cone_regions, cone_max_radius_deg, lut_face_size, lut_face_size,
      regions_build_ms);
  s += fmt::format("{:<10} {:>5} {:>7} {:>9} {:>9} {:>8} {:>8} {:>9} {:>8} {:>9} {:>9}\n", "variant", "n", "lights",
                   "visits", "ns/point", "speedup", "ideal", "build ms", "diffuse", "glossy10", "glossy100");
  for (const ShadingRow& r : medians)
    s += fmt::format("{:<10} {:>5} {:>7} {:>9.0f} {:>9.0f} {:>7.2f}x {:>7.2f}x {:>9.2f} {:>7.2f}% {:>8.2f}% {:>8.2f}%\n",
                     r.variant, r.n, r.lights, r.visits, r.ns, r.speedup, r.visit_ratio, r.build_ms, 100 * r.diffuse,
                     100 * r.glossy10, 100 * r.glossy100);
  s += fmt::format("{} rows on {} maps -> {}, {}\n", rows.size(), maps, csv_path, svg_path);
  return s;
}

nlohmann::json EvalShadingReport::to_json() const {
  auto row_json = [](const ShadingRow& r) {
    return nlohmann::json{{"map", r.map},         {"n", r.n},           {"variant", r.variant},
                          {"lights", r.lights},   {"visits", r.visits}, {"ns_per_point", r.ns},
                          {"speedup", r.speedup}, {"visit_ratio", r.visit_ratio}, {"build_ms", r.build_ms},
                          {"diffuse", r.diffuse}, {"glossy10", r.glossy10}, {"glossy100", r.glossy100}};
  };
  nlohmann::json jrows = nlohmann::json::array(), jsum = nlohmann::json::array();
  for (const ShadingRow& r : rows) jrows.push_back(row_json(r));
  for (const ShadingRow& r : medians) jsum.push_back(row_json(r));
  return {{"csv", csv_path},
          {"chart", svg_path},
          {"regions", regions},
          {"region_max_radius_deg", region_max_radius_deg},
          {"cone_regions", cone_regions},
          {"regions_build_ms", regions_build_ms},
          {"summary", jsum},
          {"points", jrows}};
}

}  // namespace lp
