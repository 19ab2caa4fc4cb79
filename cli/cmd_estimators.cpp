// eval estimators: MIS, BIS and SMC estimates of reflected radiance at shading points lit
// by live maps (Kronander et al. 2015, seed 002), against the exact pixel-sum reference:
// error (RMSE, variance across independent runs), frame-to-frame error (temporal noise)
// and time per estimate, per estimator x sample budget x glossiness, plus a sweep of the
// SMC parameters the paper calls sensitive.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>

#include <time.h>

#include "cli/commands.h"
#include "cli/eval_handlers.h"
#include "cli/report.h"
#include "eval/svg_chart.h"
#include "core/error.h"
#include "core/limits.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "core/resample.h"
#include "eval/synthetic_scene.h"
#include "eval/synthetic_sequence.h"
#include "render/estimators.h"
#include "render/smc.h"

namespace lp::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Lobe {
  std::string name;
  Brdf brdf;
};
// Glossiness levels: diffuse, rough, glossy, near mirror.
std::vector<Lobe> lobes() {
  return {{"lambertian", Brdf{LobeType::Lambertian, {0.8, 0.8, 0.8}, 0}},
          {"blinn-phong-10", Brdf{LobeType::BlinnPhong, {0.9, 0.9, 0.9}, 10}},
          {"blinn-phong-100", Brdf{LobeType::BlinnPhong, {0.9, 0.9, 0.9}, 100}},
          {"blinn-phong-1000", Brdf{LobeType::BlinnPhong, {0.9, 0.9, 0.9}, 1000}}};
}

// Fixed normals: up, two tilted ones (one towards the sequences' added light at azimuth
// 200 deg, elevation 40 deg), one near the horizon; the view 35 deg off each normal.
std::vector<std::pair<Vec3, Vec3>> normals_and_views() {
  const std::vector<Vec3> normals{{0, 0, 1}, normalize(Vec3{0.5, 0.3, 0.8}), normalize(Vec3{-0.72, -0.26, 0.64}),
                                  normalize(Vec3{0.8, -0.5, 0.3})};
  std::vector<std::pair<Vec3, Vec3>> out;
  for (Vec3 n : normals) {
    Vec3 t, b;
    orthonormal_basis(n, &t, &b);
    const double a = 35 * M_PI / 180;
    out.push_back({n, normalize(std::cos(a) * n + std::sin(a) * t)});
  }
  return out;
}

bool is_map_file(const fs::path& p) {
  const std::string e = p.extension().string();
  return e == ".exr" || e == ".hdr" || e == ".pfm";
}

struct Sequence {
  std::string name;
  std::vector<std::shared_ptr<const EnvDistribution>> frames;
};

EnvMap to_eval_size(const EnvMap& m, int w, int h) {
  if (m.layout == Layout::LatLong && m.width == w && m.height == h) return m;
  return resample(m, Layout::LatLong, w, h);
}

std::shared_ptr<const EnvDistribution> distribution(EnvMap map, const std::string& source) {
  try {
    return std::make_shared<const EnvDistribution>(std::move(map));
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", source, e.what()));
  }
}

std::vector<Scenario> parse_scenarios(const std::string& text) {
  std::vector<Scenario> out;
  if (text == "all") return all_scenarios();
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string name = text.substr(start, comma - start);
    const auto s = scenario_from_string(name);
    if (!s) throw InputError(fmt::format("--scenarios: unknown scenario '{}'", name));
    out.push_back(*s);
    start = comma + 1;
  }
  return out;
}

enum class Kind { Mis, Bis, BisMix, Smc, SmcMix };

struct Config {
  std::string estimator, variant;  // variant: "" for the main comparison
  Kind kind = Kind::Mis;
  int budget = 0;
  SmcOptions smc;
};

// Accumulated errors of one config on one lobe (and over all lobes).
struct Acc {
  double sq = 0, sum = 0;
  long n = 0;
  double var = 0;
  long var_n = 0;
  double temporal = 0;
  long temporal_n = 0;
  double seconds = 0;
  long estimates = 0;
  double rays = 0;  // visibility tests
  double ray_cost_s = 0;  // modelled seconds per visibility test
  void merge(const Acc& o) {
    sq += o.sq, sum += o.sum, n += o.n, var += o.var, var_n += o.var_n, rays += o.rays, ray_cost_s = o.ray_cost_s;
    temporal += o.temporal, temporal_n += o.temporal_n, seconds += o.seconds, estimates += o.estimates;
  }
  double rmse() const { return n ? std::sqrt(sq / double(n)) : NAN; }
  double mean_error() const { return n ? sum / double(n) : NAN; }
  double variance() const { return var_n ? var / double(var_n) : NAN; }
  double temporal_noise() const { return temporal_n ? temporal / double(temporal_n) : NAN; }
  // Measured CPU time plus the modelled cost of the visibility tests (--ray-cost-us).
  double us() const { return estimates ? 1e6 * (seconds + rays * ray_cost_s) / double(estimates) : NAN; }
  double rays_per_estimate() const { return estimates ? rays / double(estimates) : NAN; }
};

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string("nan"); }
nlohmann::json jnum(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

double thread_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

uint64_t mix(uint64_t a, uint64_t b) { return (a ^ (b + 0x9E3779B97F4A7C15ull + (a << 6) + (a >> 2))) * 0xBF58476D1CE4E5B9ull; }

}  // namespace

int run_eval_estimators(const EvalEstimatorsArgs& args_in, const Output& out) {
  EvalEstimatorsArgs args = args_in;
  if (args.quick) {
    args.frames = std::min(args.frames, 4);
    args.repeats = 2;
    if (args.budgets == EvalEstimatorsArgs{}.budgets) args.budgets = "4,16,64";
    args.sweep = false;
  }
  if (args.inputs.empty()) throw InputError("eval estimators: give at least one map, sequence directory or 'scene'");
  if (args.frames < 2) throw InputError(fmt::format("--frames must be at least 2 (temporal noise needs two), got {}", args.frames));
  check_frame_count("--frames", args.frames);
  if (args.repeats < 2)
    throw InputError(fmt::format("--repeats must be at least 2 (the variance is measured across runs), got {}", args.repeats));
  if (!(args.ray_cost_us >= 0)) throw InputError(fmt::format("--ray-cost-us must be >= 0, got {}", args.ray_cost_us));
  if (args.bis_m < 1) throw InputError(fmt::format("--bis-m must be positive, got {}", args.bis_m));
  const std::vector<int> budgets = parse_int_list(args.budgets, "--budgets");
  std::vector<Kind> kinds;
  std::vector<std::string> names;
  {
    size_t start = 0;
    while (start <= args.estimators.size()) {
      const size_t comma = std::min(args.estimators.find(',', start), args.estimators.size());
      const std::string name = args.estimators.substr(start, comma - start);
      if (name == "mis") kinds.push_back(Kind::Mis);
      else if (name == "bis") kinds.push_back(Kind::Bis);
      else if (name == "bis-mix") kinds.push_back(Kind::BisMix);
      else if (name == "smc") kinds.push_back(Kind::Smc);
      else if (name == "smc-mix") kinds.push_back(Kind::SmcMix);
      else throw InputError(fmt::format("--estimators: unknown estimator '{}' (mis, bis, bis-mix, smc, smc-mix)", name));
      names.push_back(name);
      start = comma + 1;
    }
  }
  int width = 0, height = 0;
  parse_image_size(args.size, "--size", &width, &height);
  if (width != 2 * height) throw InputError(fmt::format("--size must be a latlong size 2H x H, got {}", args.size));
  const std::vector<Scenario> scenarios = parse_scenarios(args.scenarios);

  // The maps: a directory is a recorded sequence; a file or 'scene' is a base for scenarios.
  std::vector<Sequence> sequences;
  for (const std::string& in : args.inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      std::vector<std::string> files;
      for (const auto& entry : fs::directory_iterator(in))
        if (entry.is_regular_file() && is_map_file(entry.path())) files.push_back(entry.path().string());
      std::sort(files.begin(), files.end());
      if (files.size() < 2) throw InputError(fmt::format("{}: a sequence needs at least 2 .exr/.hdr/.pfm maps", in));
      if (files.size() > size_t(args.frames)) files.resize(size_t(args.frames));
      Sequence s{fs::path(in).filename().string(), {}};
      for (const std::string& f : files) s.frames.push_back(distribution(to_eval_size(read_envmap(f), width, height), f));
      sequences.push_back(std::move(s));
      continue;
    }
    if (in != "scene" && !fs::exists(in, ec)) throw InputError(fmt::format("{}: no such file", in));
    const EnvMap base = to_eval_size(
        in == "scene" ? render_scene(describe_scene(), Layout::LatLong, width, height) : read_envmap(in), width, height);
    const std::string base_name = in == "scene" ? "scene" : fs::path(in).stem().string();
    distribution(base, in);  // a black or broken base fails here, naming the file
    for (Scenario sc : scenarios) {
      SequenceOptions so;
      so.scenario = sc;
      so.frames = args.frames;
      validate(so);
      Sequence s{fmt::format("{}/{}", base_name, to_string(sc)), {}};
      for (int f = 0; f < so.frames; ++f) s.frames.push_back(distribution(render_sequence_frame(base, so, f), in));
      sequences.push_back(std::move(s));
    }
  }

  // What runs: every estimator at every budget; the SMC sweep varies one parameter at a
  // time, at budget 16, from smc-mix (SMC initialised by BIS with half its proposals from
  // the map: the paper's lobe-only initialisation inherits BIS's misses on small bright
  // lights, which would drown every other parameter's effect).
  std::vector<Config> configs;
  for (size_t e = 0; e < kinds.size(); ++e)
    for (int b : budgets) {
      Config c{names[e], "", kinds[e], b, {}};
      if (c.kind == Kind::SmcMix) c.smc.init_proposal_map_share = 0.5, c.kind = Kind::Smc;
      configs.push_back(c);
    }
  const size_t main_configs = configs.size();
  if (args.sweep) {
    const int b = 16;
    auto add = [&](const std::string& variant, auto change) {
      Config c{"smc-mix", variant, Kind::Smc, b, {}};
      c.smc.init_proposal_map_share = 0.5;
      change(c.smc);
      configs.push_back(c);
    };
    add("default", [](SmcOptions&) {});
    add("local-moves-0.1", [](SmcOptions& o) { o.local_move_probability = 0.1; });
    add("local-moves-0.9", [](SmcOptions& o) { o.local_move_probability = 0.9; });
    add("local-cap-1deg", [](SmcOptions& o) { o.local_move_deg = 1; });
    add("local-cap-10deg", [](SmcOptions& o) { o.local_move_deg = 10; });
    add("mh-moves-0", [](SmcOptions& o) { o.mh_moves = 0; });
    add("mh-moves-3", [](SmcOptions& o) { o.mh_moves = 3; });
    add("intermediate-2", [](SmcOptions& o) { o.intermediate = 2; });
    add("no-resets", [](SmcOptions& o) { o.reset_ratio = 0, o.map_power_reset_ratio = 0; });
    add("z-reset-only", [](SmcOptions& o) { o.map_power_reset_ratio = 0; });
    add("init-lobe-only", [](SmcOptions& o) { o.init_proposal_map_share = 0; });
    add("map-reset-1.5", [](SmcOptions& o) { o.map_power_reset_ratio = 1.5; });
    add("intermediate-3", [](SmcOptions& o) { o.intermediate = 3; });  // the paper's figure 3
    add("reset-every-4", [](SmcOptions& o) { o.reset_every = 4; });
    add("ess-1/3", [](SmcOptions& o) { o.ess_fraction = 1.0 / 3.0; });
  }

  const std::vector<Lobe> lobe_list = lobes();
  const auto nv = normals_and_views();
  // Every point has an occluder beside it (a cap of half-angle 30 deg centred 45 deg off
  // the normal, like a box on the floor), so visibility matters; each point counts its
  // visibility tests (the ray casts of a renderer).
  const size_t np = lobe_list.size() * nv.size();
  std::vector<long> ray_count(np, 0);
  std::vector<ShadingPoint> points;
  std::vector<size_t> lobe_of;
  for (size_t l = 0; l < lobe_list.size(); ++l)
    for (const auto& [n, v] : nv) {
      Vec3 t, b;
      orthonormal_basis(n, &t, &b);
      const Vec3 cap = normalize(n + t);
      const double cos_cap = std::cos(30 * M_PI / 180);
      long* counter = &ray_count[points.size()];
      points.push_back({n, v, lobe_list[l].brdf, [cap, cos_cap, counter](Vec3 w) {
                          ++*counter;
                          return dot(w, cap) < cos_cap;
                        }});
      lobe_of.push_back(l);
    }
  const int reps = args.repeats;

  std::vector<std::vector<Acc>> acc(configs.size(), std::vector<Acc>(lobe_list.size()));
  // Over all lobes, per sequence: where each estimator gains or loses.
  std::vector<std::vector<Acc>> acc_seq(configs.size(), std::vector<Acc>(sequences.size()));
  size_t total_frames = 0;
  for (const Sequence& s : sequences) total_frames += s.frames.size();
  Progress progress("eval estimators", total_frames * configs.size(), out.progress);
  const auto t_start = Clock::now();
  double reference_seconds = 0;
  for (size_t si = 0; si < sequences.size(); ++si) {
    const Sequence& seq = sequences[si];
    const size_t nf = seq.frames.size();
    // Reference (luminance) per frame and point, and each point's normaliser.
    const auto t_ref = Clock::now();
    std::vector<std::vector<double>> ref(nf, std::vector<double>(np));
    for (size_t f = 0; f < nf; ++f)
      for (size_t p = 0; p < np; ++p) {
        const Rgb r = reference_reflected(seq.frames[f]->map(), points[p]);
        ref[f][p] = luminance(r.data());
      }
    reference_seconds += std::chrono::duration<double>(Clock::now() - t_ref).count();
    std::vector<double> norm(np, 0.0);
    for (size_t p = 0; p < np; ++p) {
      for (size_t f = 0; f < nf; ++f) norm[p] += ref[f][p];
      norm[p] /= double(nf);
    }
    for (size_t ci = 0; ci < configs.size(); ++ci) {
      const Config& c = configs[ci];
      // est[r][f][p], luminance
      std::vector<std::vector<std::vector<double>>> est(size_t(reps), std::vector<std::vector<double>>(nf, std::vector<double>(np)));
      std::vector<double> seconds(lobe_list.size(), 0.0);
      std::fill(ray_count.begin(), ray_count.end(), 0L);
      const uint64_t key = mix(mix(args.seed, si), mix(ci, uint64_t(c.budget)));
      // Timed per lobe over its normals in CPU time of this thread, so that other
      // processes on a shared machine do not inflate the numbers.
      const size_t per_lobe = nv.size();
      if (c.kind == Kind::Smc) {
        SmcOptions o = c.smc;
        o.particles = c.budget;
        o.proposals_per_particle = args.bis_m;
        for (int r = 0; r < reps; ++r) {
          std::vector<SmcEstimator> chains;
          chains.reserve(np);
          for (size_t p = 0; p < np; ++p) chains.emplace_back(points[p], o, mix(key, mix(uint64_t(r), p)));
          for (size_t f = 0; f < nf; ++f)
            for (size_t l = 0; l < lobe_list.size(); ++l) {
              const double t0 = thread_seconds();
              for (size_t p = l * per_lobe; p < (l + 1) * per_lobe; ++p) {
                const Rgb v = chains[p].step(seq.frames[f]);
                est[size_t(r)][f][p] = luminance(v.data());
              }
              seconds[l] += thread_seconds() - t0;
            }
        }
      } else {
        const MisOptions mis{c.budget / 2, c.budget - c.budget / 2};
        const BisOptions bis{c.budget, args.bis_m, c.kind == Kind::BisMix ? 0.5 : 0.0};
        std::vector<Rng> rngs;
        for (int r = 0; r < reps; ++r)
          for (size_t f = 0; f < nf; ++f)
            for (size_t l = 0; l < lobe_list.size(); ++l) {
              rngs.clear();
              for (size_t p = l * per_lobe; p < (l + 1) * per_lobe; ++p) rngs.emplace_back(key, mix(mix(uint64_t(r), f), p));
              const double t0 = thread_seconds();
              for (size_t p = l * per_lobe, k = 0; p < (l + 1) * per_lobe; ++p, ++k) {
                const Rgb v = c.kind == Kind::Mis ? estimate_mis(*seq.frames[f], points[p], mis, rngs[k])
                                                  : estimate_bis(*seq.frames[f], points[p], bis, rngs[k]);
                est[size_t(r)][f][p] = luminance(v.data());
              }
              seconds[l] += thread_seconds() - t0;
            }
      }
      for (size_t p = 0; p < np; ++p) {
        if (!(norm[p] > 0)) continue;  // a point the map does not light at all
        Acc a;  // this point's errors, merged below into its lobe and its sequence
        for (size_t f = 0; f < nf; ++f) {
          double m = 0;
          for (int r = 0; r < reps; ++r) {
            const double e = (est[size_t(r)][f][p] - ref[f][p]) / norm[p];
            a.sq += e * e;
            a.sum += e;
            ++a.n;
            m += est[size_t(r)][f][p];
            if (f > 0) {
              const double d = (est[size_t(r)][f][p] - est[size_t(r)][f - 1][p]) - (ref[f][p] - ref[f - 1][p]);
              a.temporal += std::abs(d) / norm[p];
              ++a.temporal_n;
            }
          }
          m /= reps;
          double v = 0;
          for (int r = 0; r < reps; ++r) v += (est[size_t(r)][f][p] - m) * (est[size_t(r)][f][p] - m);
          a.var += v / double(reps - 1) / (norm[p] * norm[p]);
          ++a.var_n;
        }
        acc[ci][lobe_of[p]].merge(a);
        acc_seq[ci][si].merge(a);
      }
      for (size_t l = 0; l < lobe_list.size(); ++l) {
        acc[ci][l].seconds += seconds[l];
        acc[ci][l].estimates += long(nf) * long(reps) * long(nv.size());
        for (size_t p = l * per_lobe; p < (l + 1) * per_lobe; ++p) {
          acc[ci][l].rays += double(ray_count[p]);
          acc_seq[ci][si].rays += double(ray_count[p]);
        }
        acc[ci][l].ray_cost_s = acc_seq[ci][si].ray_cost_s = 1e-6 * args.ray_cost_us;
        acc_seq[ci][si].seconds += seconds[l];
        acc_seq[ci][si].estimates += long(nf) * long(reps) * long(nv.size());
      }
      progress.advance(nf);
    }
  }
  progress.finish();
  const double total_seconds = std::chrono::duration<double>(Clock::now() - t_start).count();

  make_output_directory(args.output_dir);

  // Rows: per config x lobe, and over all lobes.
  struct Row {
    std::string estimator, variant, lobe;
    int budget;
    Acc a;
  };
  std::vector<Row> rows, sweep_rows;
  for (size_t ci = 0; ci < configs.size(); ++ci) {
    Acc all;
    auto& dest = ci < main_configs ? rows : sweep_rows;
    for (size_t l = 0; l < lobe_list.size(); ++l) {
      dest.push_back({configs[ci].estimator, configs[ci].variant, lobe_list[l].name, configs[ci].budget, acc[ci][l]});
      all.merge(acc[ci][l]);
    }
    dest.push_back({configs[ci].estimator, configs[ci].variant, "all", configs[ci].budget, all});
  }
  const std::string header =
      "estimator,variant,lobe,budget,rel_rmse,rel_variance,rel_mean_error,temporal_noise,us_per_estimate,rays_per_estimate,estimates\n";
  auto csv_of = [&](const std::vector<Row>& rs) {
    std::string csv = header;
    for (const Row& r : rs)
      csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", r.estimator, r.variant.empty() ? "-" : r.variant, r.lobe,
                         r.budget, num(r.a.rmse()), num(r.a.variance()), num(r.a.mean_error()),
                         num(r.a.temporal_noise()), num(r.a.us()), num(r.a.rays_per_estimate()), r.a.estimates);
    return csv;
  };
  const std::string csv_path = (fs::path(args.output_dir) / "estimators.csv").string();
  write_file_atomically(csv_path, csv_of(rows));
  {
    std::string csv = "estimator,variant,sequence,budget,rel_rmse,rel_variance,rel_mean_error,temporal_noise,us_per_estimate\n";
    for (size_t ci = 0; ci < configs.size(); ++ci)
      for (size_t si = 0; si < sequences.size(); ++si) {
        const Acc& a = acc_seq[ci][si];
        csv += fmt::format("{},{},{},{},{},{},{},{},{}\n", configs[ci].estimator,
                           configs[ci].variant.empty() ? "-" : configs[ci].variant, sequences[si].name, configs[ci].budget,
                           num(a.rmse()), num(a.variance()), num(a.mean_error()), num(a.temporal_noise()), num(a.us()));
      }
    write_file_atomically((fs::path(args.output_dir) / "estimators_by_sequence.csv").string(), csv);
  }
  std::string sweep_path;
  if (!sweep_rows.empty()) {
    sweep_path = (fs::path(args.output_dir) / "smc_sweep.csv").string();
    write_file_atomically(sweep_path, csv_of(sweep_rows));
  }

  // Chart: error against time, one panel per glossiness; a second row with temporal noise.
  std::vector<ChartPanel> panels;
  for (int metric = 0; metric < 2; ++metric)
    for (size_t l = 0; l < lobe_list.size(); ++l) {
      ChartPanel panel{fmt::format("{} ({})", lobe_list[l].name, metric == 0 ? "error" : "temporal noise"),
                       "time per estimate (us)", metric == 0 ? "relative RMSE" : "frame-to-frame error", {}};
      for (const std::string& name : names) {
        ChartSeries s{name, {}, {}, {}};
        for (const Row& r : rows)
          if (r.estimator == name && r.lobe == lobe_list[l].name) {
            s.x.push_back(r.a.us());
            s.y.push_back(metric == 0 ? r.a.rmse() : r.a.temporal_noise());
            s.labels.push_back(std::to_string(r.budget));
          }
        panel.series.push_back(std::move(s));
      }
      panels.push_back(std::move(panel));
    }
  const std::string svg_path = (fs::path(args.output_dir) / "estimators.svg").string();
  write_file_atomically(svg_path, svg_chart("Reflected radiance estimators: error against time (labels: samples per estimate)" +
                                                (args.ray_cost_us > 0 ? fmt::format(", {:g} us per visibility test", args.ray_cost_us) : std::string()),
                                            panels, int(lobe_list.size())));
  if (!sweep_rows.empty()) {
    std::vector<ChartPanel> sp;
    for (size_t l = 0; l <= lobe_list.size(); ++l) {
      const std::string lobe = l < lobe_list.size() ? lobe_list[l].name : "all";
      ChartPanel panel{lobe, "time per estimate (us)", "relative RMSE", {}};
      ChartSeries variants{"smc variants", {}, {}, {}};
      variants.lines = false;
      for (const Row& r : sweep_rows)
        if (r.lobe == lobe) {
          variants.x.push_back(r.a.us());
          variants.y.push_back(r.a.rmse());
          variants.labels.push_back(r.variant);
        }
      panel.series.push_back(variants);
      for (const Row& r : rows)
        if (r.lobe == lobe && r.budget == 16 && r.estimator.rfind("smc", 0) != 0) {
          ChartSeries s{r.estimator + " (16)", {r.a.us()}, {r.a.rmse()}, {r.estimator}};
          s.lines = false;
          panel.series.push_back(s);
        }
      sp.push_back(std::move(panel));
    }
    write_file_atomically((fs::path(args.output_dir) / "smc_sweep.svg").string(),
                          svg_chart("SMC parameter sweep at 16 particles (one change at a time from smc-mix)", sp, 3));
  }

  say(out, "{:<8} {:<18} {:<17} {:>6} {:>9} {:>10} {:>9} {:>10} {:>9} {:>6}\n", "est", "variant", "lobe", "budget", "rmse",
      "variance", "bias", "temporal", "us/est", "rays");
  auto print = [&](const std::vector<Row>& rs) {
    for (const Row& r : rs)
      say(out, "{:<8} {:<18} {:<17} {:>6} {:>8.2f}% {:>10.2e} {:>8.2f}% {:>9.2f}% {:>9.2f} {:>6.1f}\n", r.estimator,
          r.variant.empty() ? "-" : r.variant, r.lobe, r.budget, 100 * r.a.rmse(), r.a.variance(),
          100 * r.a.mean_error(), 100 * r.a.temporal_noise(), r.a.us(), r.a.rays_per_estimate());
  };
  print(rows);
  print(sweep_rows);
  std::string seq_names;
  for (const Sequence& s : sequences) seq_names += (seq_names.empty() ? "" : ", ") + s.name;
  say(out, "sequences: {}\n", seq_names);
  say(out, "{} sequences x {} frames, {} shading points, {} runs; reference {:.1f} s, total {:.1f} s -> {}, {}{}\n",
      sequences.size(), args.frames, np, reps, reference_seconds, total_seconds, csv_path, svg_path,
      sweep_path.empty() ? "" : ", " + sweep_path);

  auto json_rows = [&](const std::vector<Row>& rs) {
    nlohmann::json j = nlohmann::json::array();
    for (const Row& r : rs)
      j.push_back({{"estimator", r.estimator}, {"variant", r.variant}, {"lobe", r.lobe}, {"budget", r.budget},
                   {"rel_rmse", jnum(r.a.rmse())}, {"rel_variance", jnum(r.a.variance())},
                   {"rel_mean_error", jnum(r.a.mean_error())}, {"temporal_noise", jnum(r.a.temporal_noise())},
                   {"us_per_estimate", jnum(r.a.us())}, {"rays_per_estimate", jnum(r.a.rays_per_estimate())},
                   {"estimates", r.a.estimates}});
    return j;
  };
  nlohmann::json seqs = nlohmann::json::array();
  for (const Sequence& s : sequences) seqs.push_back({{"name", s.name}, {"frames", s.frames.size()}});
  nlohmann::json report = {{"ray_cost_us", args.ray_cost_us}, {"csv", csv_path},        {"chart", svg_path},          {"sequences", seqs},
                           {"shading_points", np},   {"repeats", reps},            {"rows", json_rows(rows)},
                           {"seconds", total_seconds}, {"reference_seconds", reference_seconds}};
  if (!sweep_rows.empty()) {
    report["sweep_csv"] = sweep_path;
    report["sweep"] = json_rows(sweep_rows);
  }
  emit_json(out, report);
  return 0;
}

}  // namespace lp::cli
