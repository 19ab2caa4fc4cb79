#include "eval/merge_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/accuracy.h"
#include "core/error.h"
#include "core/image_io.h"
#include "estimate/walkthrough.h"
#include "eval/svg_chart.h"
#include "sampling/merge_cameras.h"

namespace lp {

namespace {

namespace fs = std::filesystem;

void validate(const EvalMergeOptions& o) {
  if (o.grid < 2) throw InputError(fmt::format("eval merge: the grid needs at least 2 targets per side, got {}", o.grid));
  if (!(o.side > 0) || !std::isfinite(o.side)) throw InputError(fmt::format("eval merge: side must be positive, got {}", o.side));
  if (o.n < 12) throw InputError(fmt::format("eval merge: n must be at least 12 (a Q2-tree's base), got {}", o.n));
  if (o.methods.empty()) throw InputError("eval merge: no methods");
  for (double p : o.powers)
    if (!(p > 0) || !std::isfinite(p)) throw InputError(fmt::format("eval merge: powers must be positive, got {}", p));
}

std::string weighting_name(double power) { return power == 0 ? "equal" : fmt::format("1/d^{:g}", power); }

MergeEvalRow score(const std::string& method, const std::string& weighting, Vec3 target, double from_centre,
                   const AccuracyReference& reference, const LightList& lights) {
  const LightError e = light_error(reference, lights.lights);
  return {method, weighting, target, from_centre, e.diffuse, e.glossy[0], e.glossy[1]};
}

void summarise(EvalMergeReport& report) {
  for (const MergeEvalRow& r : report.rows) {
    auto it = std::find_if(report.summary_rows.begin(), report.summary_rows.end(),
                           [&](const MergeEvalSummary& s) { return s.method == r.method && s.weighting == r.weighting; });
    if (it == report.summary_rows.end()) {
      report.summary_rows.push_back({r.method, r.weighting});
      it = report.summary_rows.end() - 1;
    }
    if (r.distance_to_centre < 1e-9) {
      it->diffuse_at_centre = r.diffuse;
      continue;
    }
    const auto equal = std::find_if(report.rows.begin(), report.rows.end(), [&](const MergeEvalRow& e) {
      return e.method == r.method && e.weighting == "equal" && e.target.x == r.target.x && e.target.y == r.target.y;
    });
    it->wins_over_equal += equal != report.rows.end() && r.diffuse < equal->diffuse;
    ++it->targets;
    it->diffuse += r.diffuse;
    it->glossy10 += r.glossy10;
    it->glossy100 += r.glossy100;
  }
  for (MergeEvalSummary& s : report.summary_rows)
    if (s.targets) s.diffuse /= s.targets, s.glossy10 /= s.targets, s.glossy100 /= s.targets;
}

std::string rows_csv(const std::vector<MergeEvalRow>& rows) {
  std::string csv = "method,weighting,target_x,target_y,target_z,distance_to_centre_m,diffuse,glossy10,glossy100\n";
  for (const MergeEvalRow& r : rows)
    csv += fmt::format("{},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.6f},{:.6f},{:.6f}\n", r.method, r.weighting, r.target.x, r.target.y,
                       r.target.z, r.distance_to_centre, r.diffuse, r.glossy10, r.glossy100);
  return csv;
}

// One panel per method: the diffuse error at each target against its distance from the
// centre, one scatter per weighting.
std::string chart(const EvalMergeReport& report) {
  std::vector<ChartPanel> panels;
  for (const MergeEvalRow& r : report.rows) {
    auto panel = std::find_if(panels.begin(), panels.end(), [&](const ChartPanel& p) { return p.title == r.method; });
    if (panel == panels.end()) {
      panels.push_back({r.method, "target's distance from the square's centre, m", "diffuse rel. RMS error", {}, false, true});
      panel = panels.end() - 1;
    }
    auto s = std::find_if(panel->series.begin(), panel->series.end(), [&](const ChartSeries& c) { return c.name == r.weighting; });
    if (s == panel->series.end()) {
      panel->series.push_back({r.weighting, {}, {}, {}, false});
      s = panel->series.end() - 1;
    }
    s->x.push_back(r.distance_to_centre);
    s->y.push_back(r.diffuse);
    s->labels.push_back("");
  }
  return svg_chart("Merging four displaced cameras: error at the target against a camera placed there", panels, 2);
}

}  // namespace

EvalMergeReport evaluate_merge(const EvalMergeOptions& o, const EvalProgress& progress) {
  validate(o);
  const Room room = default_room();
  const double h = o.side / 2;
  const std::vector<Vec3> cameras = {{o.centre.x - h, o.centre.y - h, o.centre.z}, {o.centre.x + h, o.centre.y - h, o.centre.z},
                                     {o.centre.x + h, o.centre.y + h, o.centre.z}, {o.centre.x - h, o.centre.y + h, o.centre.z}};
  std::vector<double> powers = {0};
  powers.insert(powers.end(), o.powers.begin(), o.powers.end());
  ProgressSteps steps(progress, size_t(o.grid * o.grid));
  // Every camera's lights, per method (samplers as the live cameras run them, fresh per map).
  std::vector<std::vector<LightList>> camera_lights(o.methods.size());
  for (const Vec3& c : cameras) {
    const EnvMap map = render_room_probe(room, c, o.map_width, o.samples);
    for (size_t m = 0; m < o.methods.size(); ++m) camera_lights[m].push_back(sample(map, o.n, o.methods[m]));
  }
  AccuracyOptions ao;
  ao.shadowed = false;  // a merge moves light between directions, not behind occluders
  EvalMergeReport report;
  for (int j = 0; j < o.grid; ++j)
    for (int i = 0; i < o.grid; ++i) {
      const Vec3 target{o.centre.x - h + o.side * i / (o.grid - 1), o.centre.y - h + o.side * j / (o.grid - 1), o.centre.z};
      const double from_centre = std::hypot(target.x - o.centre.x, target.y - o.centre.y);
      const EnvMap truth = render_room_probe(room, target, o.map_width, o.samples);
      const AccuracyReference reference = make_accuracy_reference(truth, ao);
      for (size_t m = 0; m < o.methods.size(); ++m) {
        const std::string method(to_string(o.methods[m]));
        report.rows.push_back(score(method, "target camera", target, from_centre, reference, sample(truth, o.n, o.methods[m])));
        for (double p : powers) {
          // Equal weights are plain equal (position_weights gives a camera standing at the
          // target all the weight even at power 0).
          const std::vector<double> w = p == 0 ? std::vector<double>{} : position_weights(cameras, target, p);
          const LightList merged = merge_light_lists(camera_lights[m], w, o.n);
          report.rows.push_back(score(method, weighting_name(p), target, from_centre, reference, merged));
        }
      }
      steps.advance();
    }
  summarise(report);
  if (!o.output_dir.empty()) {
    make_output_directory(o.output_dir);
    report.csv_path = (fs::path(o.output_dir) / "merge.csv").string();
    write_file_atomically(report.csv_path, rows_csv(report.rows));
    report.chart_path = (fs::path(o.output_dir) / "merge.svg").string();
    write_file_atomically(report.chart_path, chart(report));
  }
  return report;
}

std::string EvalMergeReport::summary() const {
  std::string s = fmt::format("{:<8} {:<14} {:>9} {:>9} {:>9} {:>9} {:>13}\n", "method", "weighting", "diffuse", "glossy10",
                              "glossy100", "centre", "beats equal");
  for (const MergeEvalSummary& r : summary_rows)
    s += fmt::format("{:<8} {:<14} {:>9.4f} {:>9.4f} {:>9.4f} {:>9.4f} {:>13}\n", r.method, r.weighting, r.diffuse, r.glossy10,
                     r.glossy100, r.diffuse_at_centre,
                     r.weighting == "equal" || r.weighting == "target camera" ? std::string("-")
                                                                               : fmt::format("{}/{}", r.wins_over_equal, r.targets));
  s += "(errors: means over the targets off the centre; centre: the diffuse error at the centre)\n";
  if (!csv_path.empty()) s += fmt::format("{} rows -> {}, {}\n", rows.size(), csv_path, chart_path);
  return s;
}

nlohmann::json EvalMergeReport::to_json() const {
  nlohmann::json means = nlohmann::json::array();
  for (const MergeEvalSummary& r : summary_rows)
    means.push_back({{"method", r.method}, {"weighting", r.weighting}, {"diffuse", r.diffuse}, {"glossy10", r.glossy10},
                     {"glossy100", r.glossy100}, {"diffuse_at_centre", r.diffuse_at_centre},
                     {"wins_over_equal", r.wins_over_equal}, {"targets", r.targets}});
  nlohmann::json rows_json = nlohmann::json::array();
  for (const MergeEvalRow& r : rows)
    rows_json.push_back({{"method", r.method}, {"weighting", r.weighting}, {"target", {r.target.x, r.target.y, r.target.z}},
                         {"distance_to_centre", r.distance_to_centre}, {"diffuse", r.diffuse}, {"glossy10", r.glossy10},
                         {"glossy100", r.glossy100}});
  return {{"csv", csv_path}, {"chart", chart_path}, {"summary", means}, {"rows", rows_json}};
}

}  // namespace lp
