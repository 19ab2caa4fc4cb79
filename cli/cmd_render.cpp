// eval shading: what angular-region culling, glossy two-strata sets and clustering
// (Havran et al. 2005, section 4) buy in shading speed and cost in accuracy, per map and
// light count; and `tables`: export one frame's tables for a renderer.
//
// Timing: one thread's CPU time, the same compiled loops for every variant
// (reference_shader.h), random normals and reflected view directions from a fixed seed,
// the best of five interleaved runs;
// table building is timed separately. Errors: CONVENTIONS.md diffuse and glossy measures
// against the map's own integral.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <memory>

#include <algorithm>
#include <chrono>
#include <filesystem>

#include <time.h>

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
#include "render/reference_shader.h"
#include "sampling/sampler.h"
#include "render/shading_tables.h"

namespace lp::cli {

struct TablesArgs {
  std::string input;                // a map
  std::string layout;               // input layout override
  ShadingTableArgs tables;
  std::string output;               // .json, or the binary texture (.lpst / anything else)
};
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr float kTimingExponent = 100;  // Phong s of the timed material

Method progressive_method(const std::string& name) {
  auto m = method_from_string(name);
  if (!m || (*m != Method::Pharr && *m != Method::Hemigon))
    throw InputError(fmt::format("--method: '{}' is not a progressive sampler (pharr or hemigon)", name));
  return *m;
}

// Validates the table options with messages that name the option.
ShadingOptions shading_options(const ShadingTableArgs& a) {
  if (a.regions < 1) throw InputError(fmt::format("--regions must be at least 1, got {}", a.regions));
  if (a.cone_regions < 1) throw InputError(fmt::format("--cone-regions must be at least 1, got {}", a.cone_regions));
  if (a.lut < 1) throw InputError(fmt::format("--lut must be at least 1, got {}", a.lut));
  if (a.low_per_high < 1) throw InputError(fmt::format("--low-per-high must be at least 1, got {}", a.low_per_high));
  if (a.k < 1) throw InputError(fmt::format("--k must be at least 1, got {}", a.k));
  if (a.q < 0) throw InputError(fmt::format("--q must be at least 1 (or 0 for |H| / 4), got {}", a.q));
  check_count("--lut", a.lut, limits().max_lut, "texels a face edge", "the LUT is built texel by texel and exported");
  // A region needs a texel: more regions than the LUT has texels are empty and only cost time.
  const long long texels = 6LL * a.lut * a.lut;
  check_count("--regions", a.regions, texels, "regions", "the 6 lut^2 texels of the LUT");
  check_count("--cone-regions", a.cone_regions, texels, "regions", "the 6 lut^2 texels of the LUT");
  check_light_count("--n", a.n);
  check_light_count("--low-per-high", (long long)a.n * a.low_per_high);
  if (!(a.cone_deg > 0 && a.cone_deg <= 90))
    throw InputError(fmt::format("--cone must be in (0, 90] degrees, got {}", a.cone_deg));
  ShadingOptions o;
  o.regions = {a.regions, a.lut};
  o.glossy.low_per_high = a.low_per_high;
  o.glossy.cone_half_angle_deg = a.cone_deg;
  o.glossy.max_cone_lights = a.k;
  o.glossy.cone_regions = {a.cone_regions, a.lut};
  o.cluster_max_lights = a.q;
  o.region_copies = a.region_copies;
  return o;
}

EnvMap load_map(const std::string& path, const std::string& layout = {}) {
  if (path == "scene") return render_scene(describe_scene(), Layout::LatLong, 1024, 512);
  ReadMapOptions ro;
  if (!layout.empty()) {
    ro.layout = layout_from_string(layout);
    if (!ro.layout) throw InputError(fmt::format("--layout: unknown layout '{}'", layout));
  }
  return read_envmap(path, ro);
}

std::string map_name(const std::string& path) { return path == "scene" ? "scene" : fs::path(path).stem().string(); }

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

struct Row {
  std::string map, variant;
  int n = 0;
  int lights = 0;          // lights the variant holds (c: |H| + |L|)
  double visits = 0;       // mean lights visited per point (diffuse + glossy loops)
  double ns = 0;           // ns per shaded point
  double speedup = 0;      // all-lights time / this time
  double visit_ratio = 0;  // all-lights visits / these visits: the speed-up if time were visits
  double build_ms = 0;     // table build time this variant needs beyond the light list
  double diffuse = 0, glossy10 = 0, glossy100 = 0;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

std::vector<ChartPanel> panels_for(const std::vector<Row>& rows) {
  std::vector<ChartPanel> panels;
  // Clustering's speed-up (an order of magnitude) would flatten the others: it shows in
  // the error panels, where its time per point places it.
  ChartPanel speed{"speed-up over all lights: measured and ideal (lights visited)", "lights |H|", "speed-up (x)", {}};
  speed.log_y = false;
  for (ShadingVariant v : {ShadingVariant::Culled, ShadingVariant::Glossy}) {
    ChartSeries measured{std::string(to_string(v)), {}, {}, {}};
    ChartSeries ideal{std::string(to_string(v)) + " ideal", {}, {}, {}};
    for (const Row& r : rows)
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
    double Row::*field;
  };
  for (const Metric& m : {Metric{"diffuse error", &Row::diffuse}, Metric{"glossy error (s = 10)", &Row::glossy10},
                          Metric{"glossy error (s = 100)", &Row::glossy100}}) {
    ChartPanel p{m.title, "time per shaded point, ns (1 thread)", "relative RMS error", {}};
    for (ShadingVariant v : all_shading_variants()) {
      ChartSeries s{std::string(to_string(v)), {}, {}, {}};
      for (const Row& r : rows)
        if (r.variant == s.name) s.x.push_back(r.ns), s.y.push_back(r.*(m.field)), s.labels.push_back(fmt::format("n={}", r.n));
      p.series.push_back(std::move(s));
    }
    panels.push_back(std::move(p));
  }
  return panels;
}

}  // namespace

int run_eval_shading(const EvalShadingArgs& args, const Output& out) {
  const std::vector<int> counts = parse_light_counts(args.counts, "--n");
  for (int n : counts)
    if (n < 1) throw InputError(fmt::format("--n: light counts must be positive, got {}", n));
  if (args.points < 0) throw InputError(fmt::format("--points must be positive (or 0: automatic), got {}", args.points));
  const ShadingOptions options = shading_options(args.tables);
  const Method method = progressive_method(args.tables.method);
  make_output_directory(args.output_dir);

  // Regions and LUTs are fixed for a renderer: built once, shared by every map and count.
  auto t0 = Clock::now();
  auto regions = std::make_shared<const AngularRegions>(options.regions);
  auto cones = std::make_shared<const AngularRegions>(options.glossy.cone_regions);
  const double regions_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();

  AccuracyOptions ao;
  ao.shadowed = false;  // the shader has no occluders; the shadowed measure does not apply
  std::vector<Row> rows;
  Progress progress("eval shading", args.maps.size() * counts.size(), out.progress);
  for (const std::string& path : args.maps) {
    const EnvMap map = load_map(path);
    const AccuracyReference reference = make_accuracy_reference(map, ao);
    auto sampler = make_sampler(method);
    try {
      sampler->prepare(map);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", path, e.what()));
    }
    for (int n : counts) {
      progress.advance();
      const ShadingScene s = prepare_shading(sampler->place(n * options.glossy.low_per_high), n, regions, cones, options);
      // ~8M light evaluations per all-lights run: stable times, a few ms each.
      const int points = args.points > 0 ? args.points : std::clamp((1 << 22) / n, 256, 32768);
      std::vector<Vec3> normals, reflections;
      make_shading_points(points, 20051 + uint64_t(n), normals, reflections);
      if (args.coherent)  // neighbouring pixels of a smooth surface: normals in region order
        sort_by_normal_region(*regions, normals, reflections);
      const std::vector<double> times = ns_per_point(s, normals, reflections);
      double all_ns = 0, all_visits = 0;
      for (ShadingVariant v : all_shading_variants()) {
        Row r;
        r.map = map_name(path);
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
  }
  progress.finish();

  std::string csv = "map,n,variant,lights,visits,ns_per_point,speedup,visit_ratio,build_ms,diffuse,glossy10,glossy100\n";
  for (const Row& r : rows)
    csv += fmt::format("{},{},{},{},{:.1f},{:.1f},{:.4f},{:.4f},{:.4g},{:.6g},{:.6g},{:.6g}\n", r.map, r.n, r.variant,
                       r.lights, r.visits, r.ns, r.speedup, r.visit_ratio, r.build_ms, r.diffuse, r.glossy10,
                       r.glossy100);
  const std::string csv_path = (fs::path(args.output_dir) / "shading.csv").string();
  write_file_atomically(csv_path, csv);

  // Medians over maps per (variant, n).
  std::vector<Row> summary;
  for (ShadingVariant v : all_shading_variants())
    for (int n : counts) {
      std::vector<double> f[9];
      for (const Row& r : rows)
        if (r.variant == to_string(v) && r.n == n) {
          const double vals[9] = {double(r.lights), r.visits, r.ns, r.speedup, r.visit_ratio, r.build_ms,
                                  r.diffuse, r.glossy10, r.glossy100};
          for (int k = 0; k < 9; ++k) f[k].push_back(vals[k]);
        }
      if (f[0].empty()) continue;
      summary.push_back({"median", std::string(to_string(v)), n, int(median(f[0])), median(f[1]), median(f[2]),
                         median(f[3]), median(f[4]), median(f[5]), median(f[6]), median(f[7]), median(f[8])});
    }
  const std::string title = args.maps.size() == 1
                                ? fmt::format("Many-light shading: {}", map_name(args.maps[0]))
                                : fmt::format("Many-light shading: median over {} maps", args.maps.size());
  const std::string svg_path = (fs::path(args.output_dir) / "shading.svg").string();
  write_file_atomically(svg_path, svg_chart(title, panels_for(summary)));

  say(out, "regions: {} culling (max radius {:.2f} deg), {} cone (max radius {:.2f} deg), LUT {}x{}x6, built in {:.1f} ms\n",
      regions->count(), regions->max_radius() * 180 / M_PI, cones->count(), cones->max_radius() * 180 / M_PI,
      regions->face_size(), regions->face_size(), regions_ms);
  say(out, "{:<10} {:>5} {:>7} {:>9} {:>9} {:>8} {:>8} {:>9} {:>8} {:>9} {:>9}\n", "variant", "n", "lights", "visits",
      "ns/point", "speedup", "ideal", "build ms", "diffuse", "glossy10", "glossy100");
  for (const Row& r : summary)
    say(out, "{:<10} {:>5} {:>7} {:>9.0f} {:>9.0f} {:>7.2f}x {:>7.2f}x {:>9.2f} {:>7.2f}% {:>8.2f}% {:>8.2f}%\n",
        r.variant, r.n, r.lights, r.visits, r.ns, r.speedup, r.visit_ratio, r.build_ms, 100 * r.diffuse,
        100 * r.glossy10, 100 * r.glossy100);
  say(out, "{} rows on {} maps -> {}, {}\n", rows.size(), args.maps.size(), csv_path, svg_path);

  auto row_json = [](const Row& r) {
    return nlohmann::json{{"map", r.map},         {"n", r.n},           {"variant", r.variant},
                          {"lights", r.lights},   {"visits", r.visits}, {"ns_per_point", r.ns},
                          {"speedup", r.speedup}, {"visit_ratio", r.visit_ratio}, {"build_ms", r.build_ms},
                          {"diffuse", r.diffuse}, {"glossy10", r.glossy10}, {"glossy100", r.glossy100}};
  };
  nlohmann::json jrows = nlohmann::json::array(), jsum = nlohmann::json::array();
  for (const Row& r : rows) jrows.push_back(row_json(r));
  for (const Row& r : summary) jsum.push_back(row_json(r));
  emit_json(out, {{"csv", csv_path},
                  {"chart", svg_path},
                  {"regions", regions->count()},
                  {"region_max_radius_deg", regions->max_radius() * 180 / M_PI},
                  {"cone_regions", cones->count()},
                  {"regions_build_ms", regions_ms},
                  {"summary", jsum},
                  {"points", jrows}});
  return 0;
}

int run_tables(const TablesArgs& args, const Output& out) {
  const ShadingOptions options = shading_options(args.tables);
  const Method method = progressive_method(args.tables.method);
  if (args.tables.n < 1) throw InputError(fmt::format("--n must be at least 1, got {}", args.tables.n));
  const EnvMap map = load_map(args.input, args.layout);
  const auto t0 = Clock::now();
  auto sampler = make_sampler(method);
  try {
    sampler->prepare(map);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", args.input, e.what()));
  }
  auto regions = std::make_shared<const AngularRegions>(options.regions);
  auto cones = std::make_shared<const AngularRegions>(options.glossy.cone_regions);
  const ShadingScene s = prepare_shading(sampler->place(args.tables.n * options.glossy.low_per_high), args.tables.n,
                                         regions, cones, options);
  const bool json = fs::path(args.output).extension() == ".json";
  LightList meta;
  meta.method = std::string(to_string(method));
  meta.units = map.units;
  const std::string bytes = json ? shading_tables_json(s, meta) : shading_tables_binary(s);
  write_file_atomically(args.output, bytes);
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  const double mean_list = double(s.culled.indices.size()) / regions->count();
  say(out, "{} lights in H, {} in L, {} clustered; {} culling regions (radius <= {:.2f} deg, {:.0f} lights each on average), "
      "{} cone regions -> {} ({} bytes, {}) in {:.1f} ms\n",
      s.lights.size(), s.glossy.low.size(), s.clustered.size(), regions->count(), regions->max_radius() * 180 / M_PI,
      mean_list, cones->count(), args.output, bytes.size(), json ? "JSON" : "RGBA32F texture", ms);
  emit_json(out, {{"output", args.output},
                  {"format", json ? "json" : "texture"},
                  {"bytes", bytes.size()},
                  {"high", s.lights.size()},
                  {"low", s.glossy.low.size()},
                  {"clustered", s.clustered.size()},
                  {"regions", regions->count()},
                  {"cone_regions", cones->count()},
                  {"region_max_radius_deg", regions->max_radius() * 180 / M_PI},
                  {"mean_region_lights", mean_list},
                  {"time_ms", ms}});
  return 0;
}

std::vector<Command> render_commands() {
  return {
      {"tables", "Shading tables of a map for a renderer (angular regions, glossy sets, clusters)",
       "lightprobe tables probe.exr --n 1024 -o tables.lpst",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<TablesArgs>();
         f.arg("MAP", a->input, "Environment map").required();
         f.opt("--layout", a->layout, "Read the map as this layout");
         f.opt("--n", a->tables.n, "Lights |H| of the diffuse tables");
         declare_table_options(f, a->tables);
         f.output(a->output, "Output: .json, or the RGBA32F texture file (any other name)");
         return [a](const Output& out) { return run_tables(*a, out); };
       }},
  };
}

}  // namespace lp::cli
