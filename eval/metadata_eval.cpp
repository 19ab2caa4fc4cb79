#include "eval/metadata_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <sstream>

#include "core/accuracy.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/image_io.h"
#include "estimate/light_quadtree.h"
#include "estimate/metadata_track.h"
#include "estimate/walkthrough.h"
#include "estimate/white_balance_cct.h"
#include "eval/svg_chart.h"
#include "sampling/sampler.h"

namespace lp {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Mean |CCT error| (K) of six sector lights against the true map's sector colours.
double sector_cct_error(const std::vector<Light>& lights, const EnvMap& probe) {
  const std::vector<Light> truth = bipyramid_lights_of_map(probe);
  double sum = 0;
  int n = 0;
  for (const Light& l : lights)
    for (const Light& t : truth)
      if (t.id == l.id && l.luminance() > 0 && t.luminance() > 0) {
        sum += std::fabs(cct_robertson(chromaticity_of_rgb(l.rgb)).kelvin - cct_robertson(chromaticity_of_rgb(t.rgb)).kelvin);
        ++n;
      }
  return n ? sum / n : NAN;
}

struct Query {
  std::string name;
  Vec3 position;
  EnvMap probe;
  AccuracyReference reference;
  std::string standing_track;  // optional: the walk's head motion, standing at the point
};

// What synth walkthrough wrote: the truth (room, query points and their probes) and the track.
struct Walkthrough {
  nlohmann::json truth;
  Track track;
  std::vector<Query> queries;
};

Walkthrough read_walkthrough(const std::string& input_dir) {
  const fs::path dir(input_dir);
  const std::string truth_path = (dir / "truth.json").string();
  Walkthrough w;
  w.truth = read_json_file(truth_path);
  check_json_format(w.truth, truth_path, "lightprobe.walkthrough/1");  // made by synth walkthrough
  w.track = read_track((dir / "track.jsonl").string());
  validate_track(w.track);
  AccuracyOptions ao;
  ao.shadowed = false;
  ao.glossy_exponents.clear();
  for (const auto& jq : w.truth.at("queries")) {
    Query q;
    q.name = jq.at("name").get<std::string>();
    q.position = {jq.at("position").at(0).get<double>(), jq.at("position").at(1).get<double>(), jq.at("position").at(2).get<double>()};
    q.probe = read_envmap((dir / jq.at("probe").get<std::string>()).string());
    q.reference = make_accuracy_reference(q.probe, ao);
    if (jq.contains("standing_track")) q.standing_track = (dir / jq["standing_track"].get<std::string>()).string();
    w.queries.push_back(std::move(q));
  }
  if (w.queries.empty()) throw InputError(fmt::format("{}: no query points", truth_path));
  return w;
}

// Adds one query point's lights to a row: mean and max diffuse error, and the sector CCT
// error when `cct`.
void score(MetadataRow* r, const Query& q, const std::vector<Light>& lights, size_t queries, bool cct) {
  const double e = light_error(q.reference, lights).diffuse;
  r->mean_error += e / double(queries);
  r->max_error = std::max(r->max_error, e);
  if (cct) r->cct_error = (std::isnan(r->cct_error) ? 0 : r->cct_error) + sector_cct_error(lights, q.probe) / double(queries);
}

// Real probes at each query point, sampled by the existing samplers; the bipyramid filled
// with the true map's sector means; and, when the walk recorded it, the same head motion
// standing at each query point (metering from views alone).
void reference_rows(const std::vector<Query>& queries, double root_size, std::vector<MetadataRow>* rows) {
  const std::vector<std::pair<Method, int>> probe_methods{{Method::Pharr, 6}, {Method::MedianCut, 6}, {Method::Pharr, 64}, {Method::Q2Tree, 64}};
  for (const auto& [method, n] : probe_methods) {
    MetadataRow r;
    r.method = fmt::format("probe {} {}", to_string(method), n);
    double t = 0;
    for (const Query& q : queries) {
      const auto t0 = Clock::now();
      const LightList l = sample(q.probe, n, method);
      t += seconds_since(t0);
      score(&r, q, l.lights, queries.size(), false);
    }
    r.frames = 0;
    r.seconds_per_query = t / double(queries.size());
    rows->push_back(r);
  }
  MetadataRow best;
  best.method = "best six sectors";
  for (const Query& q : queries) score(&best, q, bipyramid_lights_of_map(q.probe), queries.size(), false);
  rows->push_back(best);
  if (!std::all_of(queries.begin(), queries.end(), [](const Query& q) { return !q.standing_track.empty(); })) return;
  MetadataRow r;
  r.method = "metadata, standing at the point";
  BuildModelOptions sb;
  sb.quadtree.root_size = root_size;
  sb.quadtree.min_size = root_size;  // one cell: every frame is at the point
  for (const Query& q : queries) {
    const Track standing = read_track(q.standing_track);
    const LightQuadtree model = build_model(standing, standing.camera, sb);
    score(&r, q, model.lights_at(q.position.x, q.position.y).lights, queries.size(), true);
    r.frames = standing.frames.size();
  }
  rows->push_back(r);
}

// The metadata model on a growing part of the path, in four lookup variants.
void model_rows(const Walkthrough& w, const EvalMetadataOptions& o, double root_size, const EvalProgress& on_progress,
                std::vector<MetadataRow>* rows) {
  struct Variant {
    std::string name;
    int max_depth;
    double min_frames, shrink;
  };
  const std::vector<Variant> variants{{"metadata (paper: nearest informed)", -1, 1, 0},
                                      {"metadata, >= 10 frames per sector", -1, 10, 0},
                                      {"metadata, shrinkage k = 20", -1, 1, 20},
                                      {"metadata, root only", 0, 1, 0}};
  const std::vector<Query>& queries = w.queries;
  BuildModelOptions b;
  b.quadtree.root_size = root_size;
  b.quadtree.min_size = o.min_size;
  ProgressSteps progress(on_progress, o.fractions.size());
  for (double f : o.fractions) {
    const size_t count = std::max<size_t>(1, size_t(std::llround(f * double(w.track.frames.size()))));
    const auto t0 = Clock::now();
    const LightQuadtree model = build_model(w.track, w.track.camera, b, count);
    const double build_s = seconds_since(t0);
    double distance = 0;
    for (const Query& q : queries) {
      double best = INFINITY;
      for (size_t i = 0; i < count; ++i) {
        const Vec3 p = w.track.frames[i].position;
        best = std::min(best, std::hypot(p.x - q.position.x, p.y - q.position.y));
      }
      distance += best / double(queries.size());
    }
    for (const Variant& v : variants) {
      MetadataRow r;
      r.method = v.name;
      r.fraction = f;
      r.frames = count;
      r.mean_distance = distance;
      double t = 0;
      for (const Query& q : queries) {
        const auto tq = Clock::now();
        const LightList l = v.shrink > 0 ? model.lights_shrunk(q.position.x, q.position.y, v.shrink)
                                         : model.lights_at(q.position.x, q.position.y, v.max_depth, v.min_frames);
        t += seconds_since(tq);
        score(&r, q, l.lights, queries.size(), true);
      }
      r.seconds_per_query = t / double(queries.size()) + build_s / double(count);  // + the update cost of a frame
      rows->push_back(r);
    }
    progress.advance();
  }
}

std::string rows_csv(const std::vector<MetadataRow>& rows) {
  std::string csv = "method,path_fraction,frames,mean_distance_m,diffuse_mean,diffuse_max,cct_error_k,seconds_per_query\n";
  for (const MetadataRow& r : rows)
    csv += fmt::format("\"{}\",{},{},{:.4f},{:.6f},{:.6f},{},{:.3e}\n", r.method, r.fraction, r.frames, r.mean_distance,
                       r.mean_error, r.max_error, std::isnan(r.cct_error) ? std::string() : fmt::format("{:.1f}", r.cct_error),
                       r.seconds_per_query);
  return csv;
}

std::string chart(const std::vector<MetadataRow>& rows, const std::vector<double>& fractions) {
  ChartPanel panel;
  panel.title = "Diffuse error at the query points as the walk covers the room";
  panel.x_label = "part of the path walked";
  panel.y_label = "diffuse rel. RMS error (mean over query points)";
  panel.log_x = false;
  panel.log_y = true;
  // Seven series (the chart's palette): the rest are in the table and the CSV.
  const std::vector<std::string> charted{"metadata (paper: nearest informed)", "metadata, shrinkage k = 20",
                                         "metadata, standing at the point", "best six sectors", "probe pharr 6",
                                         "probe mediancut 6", "probe q2tree 64"};
  for (const MetadataRow& r : rows) {
    if (std::find(charted.begin(), charted.end(), r.method) == charted.end()) continue;
    auto it = std::find_if(panel.series.begin(), panel.series.end(), [&](const ChartSeries& s) { return s.name == r.method; });
    if (it == panel.series.end()) {
      panel.series.push_back({r.method, {}, {}, {}, true});
      it = panel.series.end() - 1;
    }
    if (r.frames == 0 || r.method == "metadata, standing at the point") {  // flat across the walk
      it->x = {fractions.front(), fractions.back()};
      it->y = {r.mean_error, r.mean_error};
    } else {
      it->x.push_back(r.fraction);
      it->y.push_back(r.mean_error);
    }
  }
  return svg_chart("Light without a probe: camera metadata against real probes", {panel}, 1);
}

}  // namespace

void validate(const EvalMetadataOptions& o) {
  if (o.fractions.empty()) throw InputError("--fractions is empty");
  for (size_t i = 0; i < o.fractions.size(); ++i) {
    const double f = o.fractions[i];
    if (!(f > 0 && f <= 1)) throw InputError(fmt::format("--fractions: each must be in (0, 1], got {}", f));
    // The same fraction twice gave its rows twice.
    for (size_t j = 0; j < i; ++j)
      if (o.fractions[j] == f) throw InputError(fmt::format("--fractions: {} is given twice", f));
  }
  // 0 is the default (twice the room); below it was taken for the default too.
  if (!(o.root_size >= 0)) throw InputError(fmt::format("--root-size must be 0 (automatic) or a side in m, got {}", o.root_size));
}

EvalMetadataReport evaluate_metadata(const EvalMetadataOptions& options, const EvalProgress& progress) {
  validate(options);
  const Walkthrough w = read_walkthrough(options.input_dir);
  double root_size = options.root_size;
  if (root_size <= 0) {
    const auto& room = w.truth.at("room");
    root_size = 2 * std::max(room.at("width").get<double>(), room.at("depth").get<double>());
  }
  EvalMetadataReport report;
  report.queries = w.queries.size();
  report.frames = w.track.frames.size();
  reference_rows(w.queries, root_size, &report.rows);
  model_rows(w, options, root_size, progress, &report.rows);

  fs::create_directories(options.output_dir);
  report.csv_path = (fs::path(options.output_dir) / "metadata.csv").string();
  write_file_atomically(report.csv_path, rows_csv(report.rows));
  report.chart_path = (fs::path(options.output_dir) / "metadata.svg").string();
  write_file_atomically(report.chart_path, chart(report.rows, options.fractions));
  return report;
}

std::string EvalMetadataReport::summary() const {
  std::string s = fmt::format("{:<38} {:>6} {:>6} {:>8} {:>9} {:>9} {:>7} {:>11}\n", "method", "path", "frames", "dist m",
                              "diffuse", "max", "dCCT K", "s/query");
  for (const MetadataRow& r : rows)
    s += fmt::format("{:<38} {:>6.2f} {:>6} {:>8.2f} {:>9.3f} {:>9.3f} {:>7} {:>11.2e}\n", r.method, r.fraction, r.frames,
                     r.mean_distance, r.mean_error, r.max_error,
                     std::isnan(r.cct_error) ? std::string("-") : fmt::format("{:.0f}", r.cct_error), r.seconds_per_query);
  s += fmt::format("{} rows -> {}, {}\n", rows.size(), csv_path, chart_path);
  return s;
}

nlohmann::json EvalMetadataReport::to_json() const {
  nlohmann::json jrows = nlohmann::json::array();
  for (const MetadataRow& r : rows) {
    nlohmann::json jr{{"method", r.method},           {"path_fraction", r.fraction},       {"frames", r.frames},
                      {"mean_distance_m", r.mean_distance}, {"diffuse_mean", r.mean_error}, {"diffuse_max", r.max_error},
                      {"seconds_per_query", r.seconds_per_query}};
    jr["cct_error_k"] = std::isnan(r.cct_error) ? nlohmann::json() : nlohmann::json(r.cct_error);
    jrows.push_back(jr);
  }
  return {{"csv", csv_path}, {"chart", chart_path}, {"queries", queries}, {"frames", frames}, {"rows", jrows}};
}

}  // namespace lp
