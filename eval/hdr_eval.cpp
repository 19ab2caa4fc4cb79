#include "eval/hdr_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>

#include "core/error.h"
#include "core/image_io.h"
#include "eval/svg_chart.h"
#include "hdr/bracket.h"
#include "hdr/merge.h"
#include "hdr/opencv_peer.h"
#include "hdr/response.h"

namespace lp {

namespace {

namespace fs = std::filesystem;

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The name `eval hdr --response` takes, shown in the chart's title.
const char* curve_name(ResponseCurve curve) {
  switch (curve) {
    case ResponseCurve::Linear: return "linear";
    case ResponseCurve::Gamma22: return "gamma";
    case ResponseCurve::SCurve: return "scurve";
    case ResponseCurve::Custom: return "custom";
  }
  return "custom";
}

// The best of three runs, ms.
template <typename F>
double best_of_three_ms(F&& f) {
  double best = 1e30;
  for (int r = 0; r < 3; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    best = std::min(best, ms_since(t0));
  }
  return best;
}

// The memory floor: one pass over the bracket (the best of five).
double floor_ms(const Bracket& bracket) {
  double best = 1e30;
  for (int r = 0; r < 5; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    float s = 0;
    for (const auto& f : bracket.frames)
      for (float v : f.rgb) s += v;
    volatile float sink = s;
    (void)sink;
    best = std::min(best, ms_since(t0));
  }
  return best;
}

// The six fusions of one map's bracket.
void measure_map(const std::string& path, const EvalHdrOptions& options, std::vector<HdrRow>& rows) {
  SyntheticBracketOptions o;
  o.response = options.response;
  o.exposure_seconds = {1 / 64., 1 / 8., 1.};
  const SyntheticBracket sb = make_synthetic_bracket(radiance_or_scene(path), o);
  Bracket bracket;
  bracket.frames = sb.frames;
  bracket.exposure_seconds = sb.exposure_seconds;
  CameraResponse truth;
  truth.levels = int(sb.true_log_exposure[0].size());
  truth.log_exposure = sb.true_log_exposure;
  const double floor = floor_ms(bracket);
  const std::string name = map_label(path);
  auto add = [&](const std::string& method, const RgbImage& est, double rec_ms, double merge_ms) {
    HdrError e;
    try {
      e = hdr_log_error(est, sb.true_radiance);
    } catch (const InputError&) {  // nothing usable in the estimate: a failure, recorded as such
      e.median_log10 = e.p95_log10 = std::nan("");
      e.pixels_invalid = size_t(est.width) * size_t(est.height);
    }
    rows.push_back({name, method, e, rec_ms, merge_ms, floor});
  };
  RgbImage est;
  double merge_ms = best_of_three_ms([&] { est = merge_bracket(bracket, truth); });
  add("ours (true response)", est, 0, merge_ms);
  CameraResponse deb;
  double rec_ms = best_of_three_ms([&] { deb = recover_debevec(bracket); });
  merge_ms = best_of_three_ms([&] { est = merge_bracket(bracket, deb); });
  add("ours (Debevec)", est, rec_ms, merge_ms);
  CameraResponse rob;
  rec_ms = best_of_three_ms([&] { rob = recover_robertson(bracket); });
  merge_ms = best_of_three_ms([&] { est = merge_bracket(bracket, rob); });
  add("ours (Robertson)", est, rec_ms, merge_ms);
  double ms = 0;
  CameraResponse cvdeb, cvrob;
  rec_ms = best_of_three_ms([&] { cvdeb = opencv_recover_response(bracket, OpenCvHdrMethod::Debevec); });
  merge_ms = best_of_three_ms([&] { est = opencv_merge(bracket, OpenCvHdrMethod::Debevec, &cvdeb, &ms); });
  add("OpenCV Debevec", est, rec_ms, merge_ms);
  rec_ms = best_of_three_ms([&] { cvrob = opencv_recover_response(bracket, OpenCvHdrMethod::Robertson); });
  merge_ms = best_of_three_ms([&] { est = opencv_merge(bracket, OpenCvHdrMethod::Robertson, &cvrob, &ms); });
  add("OpenCV Robertson", est, rec_ms, merge_ms);
  merge_ms = best_of_three_ms([&] { est = opencv_merge(bracket, OpenCvHdrMethod::Robertson, &truth, &ms); });
  add("OpenCV MergeRobertson (true response)", est, 0, merge_ms);
}

// p95 error against recover + merge time, one scatter series per method.
ChartPanel error_against_time(const std::vector<HdrRow>& rows) {
  std::map<std::string, ChartSeries> by_method;
  for (const HdrRow& r : rows) {
    auto& s = by_method[r.method];
    s.name = r.method;
    s.x.push_back(r.recover_ms + r.merge_ms);
    s.y.push_back(r.error.p95_log10);
    s.labels.push_back(r.map);
  }
  ChartPanel panel{"95th-percentile log10 luminance error against time", "recover + merge, ms",
                   "p95 |log10 L - log10 L_true|", {}};
  for (auto& entry : by_method) {
    const ChartSeries& s = entry.second;  // not a structured binding: clang 14 cannot capture those
    // Points of one method across maps: sort by time so the polyline reads left to right.
    std::vector<size_t> idx(s.x.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return s.x[a] < s.x[b]; });
    ChartSeries sorted{s.name, {}, {}, {}, false};  // one point per map: a scatter
    for (size_t i : idx) sorted.x.push_back(s.x[i]), sorted.y.push_back(s.y[i]), sorted.labels.push_back(s.labels[i]);
    panel.series.push_back(sorted);
  }
  return panel;
}

}  // namespace

EvalHdrReport evaluate_hdr(const EvalHdrOptions& options, const EvalProgress& progress) {
  make_output_directory(options.output_dir);
  EvalHdrReport report;
  {
    ProgressSteps steps(progress, options.maps.size());
    for (const std::string& path : options.maps) {
      measure_map(path, options, report.rows);
      steps.advance();
    }
  }
  std::string csv = "map,method,median_log10,p95_log10,invalid_pixels,recover_ms,merge_ms,merge_x_floor\n";
  for (const HdrRow& r : report.rows)
    csv += fmt::format("{},{},{:.6g},{:.6g},{},{:.4g},{:.4g},{:.4g}\n", r.map, r.method, r.error.median_log10,
                       r.error.p95_log10, r.error.pixels_invalid, r.recover_ms, r.merge_ms, r.merge_ms / r.floor_ms);
  report.csv_path = (fs::path(options.output_dir) / "hdr.csv").string();
  write_file_atomically(report.csv_path, csv);
  report.svg_path = (fs::path(options.output_dir) / "hdr.svg").string();
  write_file_atomically(report.svg_path,
                        svg_chart(fmt::format("HDR fusion: error against time ({} response, 3 exposures 3 stops apart)",
                                              curve_name(options.response)),
                                  {error_against_time(report.rows)}, 1));
  return report;
}

std::string EvalHdrReport::summary() const {
  std::string s = fmt::format("{:<12} {:<38} {:>9} {:>9} {:>8} {:>10} {:>9} {:>8}\n", "map", "method", "median", "p95",
                              "invalid", "recover ms", "merge ms", "x floor");
  for (const HdrRow& r : rows)
    s += fmt::format("{:<12} {:<38} {:>9.4f} {:>9.4f} {:>8} {:>10.1f} {:>9.2f} {:>8.1f}\n", r.map, r.method,
                     r.error.median_log10, r.error.p95_log10, r.error.pixels_invalid, r.recover_ms, r.merge_ms,
                     r.merge_ms / r.floor_ms);
  s += fmt::format("-> {}, {}\n", csv_path, svg_path);
  return s;
}

nlohmann::json EvalHdrReport::to_json() const {
  nlohmann::json jr = nlohmann::json::array();
  for (const HdrRow& r : rows)
    jr.push_back({{"map", r.map}, {"method", r.method}, {"median_log10", r.error.median_log10},
                  {"p95_log10", r.error.p95_log10}, {"invalid_pixels", r.error.pixels_invalid},
                  {"recover_ms", r.recover_ms}, {"merge_ms", r.merge_ms}});
  return {{"csv", csv_path}, {"chart", svg_path}, {"rows", jr}};
}

}  // namespace lp
