#include "eval/estimators_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>

#include <time.h>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/resample.h"
#include "eval/svg_chart.h"
#include "eval/synthetic_scene.h"
#include "render/estimators.h"
#include "render/smc.h"

namespace lp {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Lobe {
  std::string name;
  Brdf brdf;
};
// Glossiness levels: diffuse, rough, glossy, near mirror.
std::vector<Lobe> glossiness_lobes() {
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

enum class Kind { Mis, Bis, BisMix, Smc, SmcMix };

Kind kind_of(const std::string& name) {
  if (name == "mis") return Kind::Mis;
  if (name == "bis") return Kind::Bis;
  if (name == "bis-mix") return Kind::BisMix;
  if (name == "smc") return Kind::Smc;
  if (name == "smc-mix") return Kind::SmcMix;
  throw InputError(fmt::format("--estimators: unknown estimator '{}' (mis, bis, bis-mix, smc, smc-mix)", name));
}

struct Config {
  std::string estimator, variant;  // variant: "" for the main comparison
  Kind kind = Kind::Mis;
  int budget = 0;
  SmcOptions smc;
};

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string("nan"); }
nlohmann::json jnum(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

double thread_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

uint64_t mix(uint64_t a, uint64_t b) { return (a ^ (b + 0x9E3779B97F4A7C15ull + (a << 6) + (a >> 2))) * 0xBF58476D1CE4E5B9ull; }

// A directory is a recorded sequence; a file or "scene" is a base for the scenarios.
std::vector<Sequence> load_sequences(const EvalEstimatorsOptions& o) {
  std::vector<Sequence> sequences;
  for (const std::string& in : o.inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      std::vector<std::string> files;
      for (const auto& entry : fs::directory_iterator(in))
        if (entry.is_regular_file() && is_map_file(entry.path())) files.push_back(entry.path().string());
      std::sort(files.begin(), files.end(), [](const std::string& a, const std::string& b) {
        return frame_name_less(fs::path(a).filename().string(), fs::path(b).filename().string());
      });
      if (files.size() < 2) throw InputError(fmt::format("{}: a sequence needs at least 2 .exr/.hdr/.pfm maps", in));
      if (files.size() > size_t(o.frames)) files.resize(size_t(o.frames));
      Sequence s{fs::path(in).filename().string(), {}};
      for (const std::string& f : files) s.frames.push_back(distribution(to_eval_size(read_envmap(f), o.width, o.height), f));
      sequences.push_back(std::move(s));
      continue;
    }
    if (in != "scene" && !fs::exists(in, ec)) throw InputError(fmt::format("{}: no such file", in));
    const EnvMap base = to_eval_size(
        in == "scene" ? render_scene(describe_scene(), Layout::LatLong, o.width, o.height) : read_envmap(in), o.width,
        o.height);
    const std::string base_name = in == "scene" ? "scene" : fs::path(in).stem().string();
    distribution(base, in);  // a black or broken base fails here, naming the file
    for (Scenario sc : o.scenarios) {
      SequenceOptions so;
      so.scenario = sc;
      so.frames = o.frames;
      validate(so);
      Sequence s{fmt::format("{}/{}", base_name, to_string(sc)), {}};
      for (int f = 0; f < so.frames; ++f) s.frames.push_back(distribution(render_sequence_frame(base, so, f), in));
      sequences.push_back(std::move(s));
    }
  }
  return sequences;
}

// Every estimator at every budget; the SMC sweep varies one parameter at a time, at budget
// 16, from smc-mix (SMC initialised by BIS with half its proposals from the map: the
// paper's lobe-only initialisation inherits BIS's misses on small bright lights, which
// would drown every other parameter's effect).
std::vector<Config> make_configs(const EvalEstimatorsOptions& o, size_t* main_configs) {
  std::vector<Config> configs;
  for (const std::string& name : o.estimators)
    for (int b : o.budgets) {
      Config c{name, "", kind_of(name), b, {}};
      if (c.kind == Kind::SmcMix) c.smc.init_proposal_map_share = 0.5, c.kind = Kind::Smc;
      configs.push_back(c);
    }
  *main_configs = configs.size();
  if (!o.sweep) return configs;
  const int b = 16;
  auto add = [&](const std::string& variant, auto change) {
    Config c{"smc-mix", variant, Kind::Smc, b, {}};
    c.smc.init_proposal_map_share = 0.5;
    change(c.smc);
    configs.push_back(c);
  };
  add("default", [](SmcOptions&) {});
  add("local-moves-0.1", [](SmcOptions& s) { s.local_move_probability = 0.1; });
  add("local-moves-0.9", [](SmcOptions& s) { s.local_move_probability = 0.9; });
  add("local-cap-1deg", [](SmcOptions& s) { s.local_move_deg = 1; });
  add("local-cap-10deg", [](SmcOptions& s) { s.local_move_deg = 10; });
  add("mh-moves-0", [](SmcOptions& s) { s.mh_moves = 0; });
  add("mh-moves-3", [](SmcOptions& s) { s.mh_moves = 3; });
  add("intermediate-2", [](SmcOptions& s) { s.intermediate = 2; });
  add("no-resets", [](SmcOptions& s) { s.reset_ratio = 0, s.map_power_reset_ratio = 0; });
  add("z-reset-only", [](SmcOptions& s) { s.map_power_reset_ratio = 0; });
  add("init-lobe-only", [](SmcOptions& s) { s.init_proposal_map_share = 0; });
  add("map-reset-1.5", [](SmcOptions& s) { s.map_power_reset_ratio = 1.5; });
  add("intermediate-3", [](SmcOptions& s) { s.intermediate = 3; });  // the paper's figure 3
  add("reset-every-4", [](SmcOptions& s) { s.reset_every = 4; });
  add("ess-1/3", [](SmcOptions& s) { s.ess_fraction = 1.0 / 3.0; });
  return configs;
}

// The shading points: every lobe at every normal. Each has an occluder beside it (a cap of
// half-angle 30 deg centred 45 deg off the normal, like a box on the floor), so visibility
// matters, and counts its visibility tests (the ray casts of a renderer) in ray_count.
struct Scene {
  std::vector<Lobe> lobes = glossiness_lobes();
  std::vector<std::pair<Vec3, Vec3>> nv = normals_and_views();
  std::vector<long> ray_count;
  std::vector<ShadingPoint> points;  // lobe-major: lobe l holds points [l nv, (l + 1) nv)
  std::vector<size_t> lobe_of;
  Scene() {
    ray_count.assign(lobes.size() * nv.size(), 0);
    for (size_t l = 0; l < lobes.size(); ++l)
      for (const auto& [n, v] : nv) {
        Vec3 t, b;
        orthonormal_basis(n, &t, &b);
        const Vec3 cap = normalize(n + t);
        const double cos_cap = std::cos(30 * M_PI / 180);
        long* counter = &ray_count[points.size()];
        points.push_back({n, v, lobes[l].brdf, [cap, cos_cap, counter](Vec3 w) {
                            ++*counter;
                            return dot(w, cap) < cos_cap;
                          }});
        lobe_of.push_back(l);
      }
  }
  Scene(const Scene&) = delete;  // the visibility tests point into ray_count
};

using Estimates = std::vector<std::vector<std::vector<double>>>;  // [run][frame][point], luminance

// Runs one configuration on one sequence: every estimate, and the CPU time per lobe in
// `seconds` (timed per lobe over its normals in CPU time of this thread, so that other
// processes on a shared machine do not inflate the numbers).
Estimates run_config(const Config& c, const Sequence& seq, Scene& scene, int reps, int bis_m, uint64_t key,
                     std::vector<double>* seconds) {
  const size_t nf = seq.frames.size(), np = scene.points.size(), per_lobe = scene.nv.size();
  Estimates est(size_t(reps), std::vector<std::vector<double>>(nf, std::vector<double>(np)));
  seconds->assign(scene.lobes.size(), 0.0);
  std::fill(scene.ray_count.begin(), scene.ray_count.end(), 0L);
  if (c.kind == Kind::Smc) {
    SmcOptions o = c.smc;
    o.particles = c.budget;
    o.proposals_per_particle = bis_m;
    for (int r = 0; r < reps; ++r) {
      std::vector<SmcEstimator> chains;
      chains.reserve(np);
      for (size_t p = 0; p < np; ++p) chains.emplace_back(scene.points[p], o, mix(key, mix(uint64_t(r), p)));
      for (size_t f = 0; f < nf; ++f)
        for (size_t l = 0; l < scene.lobes.size(); ++l) {
          const double t0 = thread_seconds();
          for (size_t p = l * per_lobe; p < (l + 1) * per_lobe; ++p) {
            const Rgb v = chains[p].step(seq.frames[f]);
            est[size_t(r)][f][p] = luminance(v.data());
          }
          (*seconds)[l] += thread_seconds() - t0;
        }
    }
    return est;
  }
  const MisOptions mis{c.budget / 2, c.budget - c.budget / 2};
  const BisOptions bis{c.budget, bis_m, c.kind == Kind::BisMix ? 0.5 : 0.0};
  std::vector<Rng> rngs;
  for (int r = 0; r < reps; ++r)
    for (size_t f = 0; f < nf; ++f)
      for (size_t l = 0; l < scene.lobes.size(); ++l) {
        rngs.clear();
        for (size_t p = l * per_lobe; p < (l + 1) * per_lobe; ++p) rngs.emplace_back(key, mix(mix(uint64_t(r), f), p));
        const double t0 = thread_seconds();
        for (size_t p = l * per_lobe, k = 0; p < (l + 1) * per_lobe; ++p, ++k) {
          const Rgb v = c.kind == Kind::Mis ? estimate_mis(*seq.frames[f], scene.points[p], mis, rngs[k])
                                            : estimate_bis(*seq.frames[f], scene.points[p], bis, rngs[k]);
          est[size_t(r)][f][p] = luminance(v.data());
        }
        (*seconds)[l] += thread_seconds() - t0;
      }
  return est;
}

// One point's errors over the frames and runs, relative to norm (its mean reference).
EstimatorErrors point_errors(const Estimates& est, const std::vector<std::vector<double>>& ref, size_t p, double norm) {
  const int reps = int(est.size());
  EstimatorErrors a;
  for (size_t f = 0; f < ref.size(); ++f) {
    double m = 0;
    for (int r = 0; r < reps; ++r) {
      const double e = (est[size_t(r)][f][p] - ref[f][p]) / norm;
      a.sq += e * e;
      a.sum += e;
      ++a.n;
      m += est[size_t(r)][f][p];
      if (f > 0) {
        const double d = (est[size_t(r)][f][p] - est[size_t(r)][f - 1][p]) - (ref[f][p] - ref[f - 1][p]);
        a.temporal += std::abs(d) / norm;
        ++a.temporal_n;
      }
    }
    m /= reps;
    double v = 0;
    for (int r = 0; r < reps; ++r) v += (est[size_t(r)][f][p] - m) * (est[size_t(r)][f][p] - m);
    a.var += v / double(reps - 1) / (norm * norm);
    ++a.var_n;
  }
  return a;
}

// Accumulated errors per configuration and lobe, and per configuration and sequence.
struct Accumulated {
  std::vector<std::vector<EstimatorErrors>> by_lobe, by_sequence;
  double reference_seconds = 0;
};

Accumulated run_all(const EvalEstimatorsOptions& o, const std::vector<Sequence>& sequences,
                    const std::vector<Config>& configs, Scene& scene, const EvalProgress& on_progress) {
  const size_t np = scene.points.size();
  const int reps = o.repeats;
  Accumulated acc{std::vector<std::vector<EstimatorErrors>>(configs.size(), std::vector<EstimatorErrors>(scene.lobes.size())),
                  std::vector<std::vector<EstimatorErrors>>(configs.size(), std::vector<EstimatorErrors>(sequences.size())),
                  0};
  size_t total_frames = 0;
  for (const Sequence& s : sequences) total_frames += s.frames.size();
  ProgressSteps progress(on_progress, total_frames * configs.size());
  for (size_t si = 0; si < sequences.size(); ++si) {
    const Sequence& seq = sequences[si];
    const size_t nf = seq.frames.size();
    // Reference (luminance) per frame and point, and each point's normaliser.
    const auto t_ref = Clock::now();
    std::vector<std::vector<double>> ref(nf, std::vector<double>(np));
    for (size_t f = 0; f < nf; ++f)
      for (size_t p = 0; p < np; ++p) ref[f][p] = luminance(reference_reflected(seq.frames[f]->map(), scene.points[p]).data());
    acc.reference_seconds += std::chrono::duration<double>(Clock::now() - t_ref).count();
    std::vector<double> norm(np, 0.0);
    for (size_t p = 0; p < np; ++p) {
      for (size_t f = 0; f < nf; ++f) norm[p] += ref[f][p];
      norm[p] /= double(nf);
    }
    for (size_t ci = 0; ci < configs.size(); ++ci) {
      std::vector<double> seconds;
      const uint64_t key = mix(mix(o.seed, si), mix(ci, uint64_t(configs[ci].budget)));
      const Estimates est = run_config(configs[ci], seq, scene, reps, o.bis_m, key, &seconds);
      EstimatorErrors& by_seq = acc.by_sequence[ci][si];
      for (size_t p = 0; p < np; ++p) {
        if (!(norm[p] > 0)) continue;  // a point the map does not light at all
        const EstimatorErrors a = point_errors(est, ref, p, norm[p]);
        acc.by_lobe[ci][scene.lobe_of[p]].merge(a);
        by_seq.merge(a);
      }
      const size_t per_lobe = scene.nv.size();
      for (size_t l = 0; l < scene.lobes.size(); ++l) {
        EstimatorErrors& by_lobe = acc.by_lobe[ci][l];
        by_lobe.seconds += seconds[l];
        by_lobe.estimates += long(nf) * long(reps) * long(per_lobe);
        for (size_t p = l * per_lobe; p < (l + 1) * per_lobe; ++p) {
          by_lobe.rays += double(scene.ray_count[p]);
          by_seq.rays += double(scene.ray_count[p]);
        }
        by_lobe.ray_cost_s = by_seq.ray_cost_s = 1e-6 * o.ray_cost_us;
        by_seq.seconds += seconds[l];
        by_seq.estimates += long(nf) * long(reps) * long(per_lobe);
      }
      progress.advance(nf);
    }
  }
  return acc;
}

const char* kCsvHeader =
    "estimator,variant,lobe,budget,rel_rmse,rel_variance,rel_mean_error,temporal_noise,us_per_estimate,rays_per_estimate,"
    "estimates\n";

std::string rows_csv(const std::vector<EstimatorsRow>& rs) {
  std::string csv = kCsvHeader;
  for (const EstimatorsRow& r : rs)
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", r.estimator, r.variant.empty() ? "-" : r.variant, r.group,
                       r.budget, num(r.errors.rmse()), num(r.errors.variance()), num(r.errors.mean_error()),
                       num(r.errors.temporal_noise()), num(r.errors.us()), num(r.errors.rays_per_estimate()),
                       r.errors.estimates);
  return csv;
}

std::string by_sequence_csv(const std::vector<EstimatorsRow>& rs) {
  std::string csv = "estimator,variant,sequence,budget,rel_rmse,rel_variance,rel_mean_error,temporal_noise,us_per_estimate\n";
  for (const EstimatorsRow& r : rs)
    csv += fmt::format("{},{},{},{},{},{},{},{},{}\n", r.estimator, r.variant.empty() ? "-" : r.variant, r.group, r.budget,
                       num(r.errors.rmse()), num(r.errors.variance()), num(r.errors.mean_error()),
                       num(r.errors.temporal_noise()), num(r.errors.us()));
  return csv;
}

// Error against time, one panel per glossiness; a second row with temporal noise.
std::string main_chart(const EvalEstimatorsReport& report, const std::vector<std::string>& lobe_names) {
  std::vector<ChartPanel> panels;
  for (int metric = 0; metric < 2; ++metric)
    for (const std::string& lobe : lobe_names) {
      ChartPanel panel{fmt::format("{} ({})", lobe, metric == 0 ? "error" : "temporal noise"), "time per estimate (us)",
                       metric == 0 ? "relative RMSE" : "frame-to-frame error", {}};
      for (const std::string& name : report.estimators) {
        ChartSeries s{name, {}, {}, {}};
        for (const EstimatorsRow& r : report.rows)
          if (r.estimator == name && r.group == lobe) {
            s.x.push_back(r.errors.us());
            s.y.push_back(metric == 0 ? r.errors.rmse() : r.errors.temporal_noise());
            s.labels.push_back(std::to_string(r.budget));
          }
        panel.series.push_back(std::move(s));
      }
      panels.push_back(std::move(panel));
    }
  return svg_chart("Reflected radiance estimators: error against time (labels: samples per estimate)" +
                       (report.ray_cost_us > 0 ? fmt::format(", {:g} us per visibility test", report.ray_cost_us)
                                               : std::string()),
                   panels, int(lobe_names.size()));
}

// The sweep's variants as points, next to the other estimators at budget 16, per lobe.
std::string sweep_chart(const EvalEstimatorsReport& report, std::vector<std::string> groups) {
  groups.push_back("all");
  std::vector<ChartPanel> sp;
  for (const std::string& lobe : groups) {
    ChartPanel panel{lobe, "time per estimate (us)", "relative RMSE", {}};
    ChartSeries variants{"smc variants", {}, {}, {}};
    variants.lines = false;
    for (const EstimatorsRow& r : report.sweep)
      if (r.group == lobe) {
        variants.x.push_back(r.errors.us());
        variants.y.push_back(r.errors.rmse());
        variants.labels.push_back(r.variant);
      }
    panel.series.push_back(variants);
    for (const EstimatorsRow& r : report.rows)
      if (r.group == lobe && r.budget == 16 && r.estimator.rfind("smc", 0) != 0) {
        ChartSeries s{r.estimator + " (16)", {r.errors.us()}, {r.errors.rmse()}, {r.estimator}};
        s.lines = false;
        panel.series.push_back(s);
      }
    sp.push_back(std::move(panel));
  }
  return svg_chart("SMC parameter sweep at 16 particles (one change at a time from smc-mix)", sp, 3);
}

void write_files(EvalEstimatorsReport& report, const std::string& dir, const std::vector<std::string>& lobe_names) {
  make_output_directory(dir);
  report.csv_path = (fs::path(dir) / "estimators.csv").string();
  write_file_atomically(report.csv_path, rows_csv(report.rows));
  write_file_atomically((fs::path(dir) / "estimators_by_sequence.csv").string(), by_sequence_csv(report.by_sequence));
  if (!report.sweep.empty()) {
    report.sweep_csv_path = (fs::path(dir) / "smc_sweep.csv").string();
    write_file_atomically(report.sweep_csv_path, rows_csv(report.sweep));
  }
  report.chart_path = (fs::path(dir) / "estimators.svg").string();
  write_file_atomically(report.chart_path, main_chart(report, lobe_names));
  if (!report.sweep.empty())
    write_file_atomically((fs::path(dir) / "smc_sweep.svg").string(), sweep_chart(report, lobe_names));
}

nlohmann::json rows_json(const std::vector<EstimatorsRow>& rs) {
  nlohmann::json j = nlohmann::json::array();
  for (const EstimatorsRow& r : rs)
    j.push_back({{"estimator", r.estimator}, {"variant", r.variant}, {"lobe", r.group}, {"budget", r.budget},
                 {"rel_rmse", jnum(r.errors.rmse())}, {"rel_variance", jnum(r.errors.variance())},
                 {"rel_mean_error", jnum(r.errors.mean_error())}, {"temporal_noise", jnum(r.errors.temporal_noise())},
                 {"us_per_estimate", jnum(r.errors.us())}, {"rays_per_estimate", jnum(r.errors.rays_per_estimate())},
                 {"estimates", r.errors.estimates}});
  return j;
}

}  // namespace

void EstimatorErrors::merge(const EstimatorErrors& o) {
  sq += o.sq, sum += o.sum, n += o.n, var += o.var, var_n += o.var_n, rays += o.rays, ray_cost_s = o.ray_cost_s;
  temporal += o.temporal, temporal_n += o.temporal_n, seconds += o.seconds, estimates += o.estimates;
}

void validate(const EvalEstimatorsOptions& o) {
  if (o.inputs.empty()) throw InputError("eval estimators: give at least one map, sequence directory or 'scene'");
  if (o.frames < 2) throw InputError(fmt::format("--frames must be at least 2 (temporal noise needs two), got {}", o.frames));
  if (o.repeats < 2)
    throw InputError(fmt::format("--repeats must be at least 2 (the variance is measured across runs), got {}", o.repeats));
  if (!(o.ray_cost_us >= 0)) throw InputError(fmt::format("--ray-cost-us must be >= 0, got {}", o.ray_cost_us));
  if (o.bis_m < 1) throw InputError(fmt::format("--bis-m must be positive, got {}", o.bis_m));
  if (o.budgets.empty()) throw InputError("--budgets is empty");
  for (int b : o.budgets)
    if (b <= 0) throw InputError(fmt::format("--budgets must be positive, got {}", b));
  for (const std::string& name : o.estimators) kind_of(name);
  if (o.width != 2 * o.height || o.height <= 0)
    throw InputError(fmt::format("--size must be a latlong size 2H x H, got {}x{}", o.width, o.height));
}

EvalEstimatorsReport evaluate_estimators(const EvalEstimatorsOptions& options, const EvalProgress& progress) {
  validate(options);
  const std::vector<Sequence> sequences = load_sequences(options);
  size_t main_configs = 0;
  const std::vector<Config> configs = make_configs(options, &main_configs);
  Scene scene;
  const auto t_start = Clock::now();
  const Accumulated acc = run_all(options, sequences, configs, scene, progress);

  EvalEstimatorsReport report;
  report.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
  report.reference_seconds = acc.reference_seconds;
  for (const Sequence& s : sequences) report.sequences.push_back({s.name, s.frames.size()});
  report.estimators = options.estimators;
  report.frames = options.frames;
  report.shading_points = scene.points.size();
  report.repeats = options.repeats;
  report.ray_cost_us = options.ray_cost_us;
  // Rows: per configuration x lobe, then over all lobes; per configuration x sequence.
  std::vector<std::string> lobe_names;
  for (const Lobe& l : scene.lobes) lobe_names.push_back(l.name);
  for (size_t ci = 0; ci < configs.size(); ++ci) {
    const Config& c = configs[ci];
    EstimatorErrors all;
    auto& dest = ci < main_configs ? report.rows : report.sweep;
    for (size_t l = 0; l < lobe_names.size(); ++l) {
      dest.push_back({c.estimator, c.variant, lobe_names[l], c.budget, acc.by_lobe[ci][l]});
      all.merge(acc.by_lobe[ci][l]);
    }
    dest.push_back({c.estimator, c.variant, "all", c.budget, all});
    for (size_t si = 0; si < sequences.size(); ++si)
      report.by_sequence.push_back({c.estimator, c.variant, sequences[si].name, c.budget, acc.by_sequence[ci][si]});
  }
  write_files(report, options.output_dir, lobe_names);
  return report;
}

std::string EvalEstimatorsReport::summary() const {
  std::string s = fmt::format("{:<8} {:<18} {:<17} {:>6} {:>9} {:>10} {:>9} {:>10} {:>9} {:>6}\n", "est", "variant", "lobe",
                              "budget", "rmse", "variance", "bias", "temporal", "us/est", "rays");
  for (const auto* rs : {&rows, &sweep})
    for (const EstimatorsRow& r : *rs)
      s += fmt::format("{:<8} {:<18} {:<17} {:>6} {:>8.2f}% {:>10.2e} {:>8.2f}% {:>9.2f}% {:>9.2f} {:>6.1f}\n", r.estimator,
                       r.variant.empty() ? "-" : r.variant, r.group, r.budget, 100 * r.errors.rmse(),
                       r.errors.variance(), 100 * r.errors.mean_error(), 100 * r.errors.temporal_noise(), r.errors.us(),
                       r.errors.rays_per_estimate());
  std::string names;
  for (const Sequence& q : sequences) names += (names.empty() ? "" : ", ") + q.name;
  s += fmt::format("sequences: {}\n", names);
  s += fmt::format("{} sequences x {} frames, {} shading points, {} runs; reference {:.1f} s, total {:.1f} s -> {}, {}{}\n",
                   sequences.size(), frames, shading_points, repeats, reference_seconds, seconds, csv_path, chart_path,
                   sweep_csv_path.empty() ? "" : ", " + sweep_csv_path);
  return s;
}

nlohmann::json EvalEstimatorsReport::to_json() const {
  nlohmann::json seqs = nlohmann::json::array();
  for (const Sequence& s : sequences) seqs.push_back({{"name", s.name}, {"frames", s.frames}});
  nlohmann::json j = {{"ray_cost_us", ray_cost_us},         {"csv", csv_path},     {"chart", chart_path},
                      {"sequences", seqs},                  {"shading_points", shading_points},
                      {"repeats", repeats},                 {"rows", rows_json(rows)},
                      {"seconds", seconds},                 {"reference_seconds", reference_seconds}};
  if (!sweep.empty()) {
    j["sweep_csv"] = sweep_csv_path;
    j["sweep"] = rows_json(sweep);
  }
  return j;
}

}  // namespace lp
