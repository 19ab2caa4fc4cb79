#include "eval/unwrap_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <tuple>

#include "core/image_io.h"
#include "core/resample.h"
#include "probe/fisheye.h"
#include "probe/mirror_ball.h"
#include "probe/stabilise.h"
#include "probe/synthetic_probe.h"

namespace lp {

namespace {

namespace fs = std::filesystem;

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The four mirror-ball probes and the fisheye of one map.
void measure_map(const std::string& path, std::vector<UnwrapRow>& rows) {
  const EnvMap world = map_or_scene(path, 1024);
  const std::string name = map_label(path);
  const EnvMap truth = resample(world, Layout::LatLong, 256, 128);
  const BallInImage ball{256.3, 251.7, 200.0};
  for (const auto& [label, distance, noise] :
       std::vector<std::tuple<std::string, double, double>>{{"ball, orthographic", 0, 0},
                                                            {"ball, orthographic, 2 % noise", 0, 0.02},
                                                            {"ball, perspective 10 radii", 10, 0},
                                                            {"ball, perspective 10 radii, 2 % noise", 10, 0.02}}) {
    MirrorBallCamera cam;
    if (distance > 0) cam.distance_in_radii = distance;
    RenderBallOptions ro;
    ro.noise_relative = noise;
    const RgbImage img = render_mirror_ball(world, ball, cam, 512, 512, ro);
    const auto t0 = std::chrono::steady_clock::now();
    const BallInImage found = find_ball(img);
    const EnvMap map = unwrap_mirror_ball(img, found, cam, Layout::LatLong, 256, 128);
    const double ms = ms_since(t0);
    rows.push_back({name, label, unwrap_error(map, truth), std::hypot(found.cx - ball.cx, found.cy - ball.cy),
                    std::fabs(found.radius_px - ball.radius_px), ms});
  }
  const FisheyeModel m = equidistant_fisheye(600, 600, 190);
  const RgbImage img = render_fisheye(world, m, 4);
  const auto t0 = std::chrono::steady_clock::now();
  const EnvMap map = unwrap_fisheye(img, m, Layout::LatLong, 256, 128, {});
  const double ms = ms_since(t0);
  const ImageCircle c = find_image_circle(img);
  rows.push_back({name, "fisheye 190 deg equidistant", unwrap_error(map, truth), std::hypot(c.cx - 300.0, c.cy - 300.0),
                  std::fabs(c.r - 300.0 * 190.0 / 190.0), ms});
}

}  // namespace

EvalUnwrapReport evaluate_unwrap(const EvalUnwrapOptions& options, const EvalProgress& progress) {
  make_output_directory(options.output_dir);
  EvalUnwrapReport report;
  {
    ProgressSteps steps(progress, options.maps.size());
    for (const std::string& path : options.maps) {
      measure_map(path, report.rows);
      steps.advance();
    }
  }
  std::string csv = "map,probe,mean_abs_log10,pixels,valid_solid_angle_sr,centre_error_px,radius_error_px,ms\n";
  for (const UnwrapRow& r : report.rows)
    // Probe names hold commas ("ball, orthographic"): quoted, as RFC 4180 has it.
    csv += fmt::format("{},\"{}\",{:.6g},{},{:.4f},{:.4f},{:.4f},{:.2f}\n", r.map, r.probe, r.error.mean_abs_log10,
                       r.error.pixels_compared, r.error.valid_solid_angle, r.centre_error_px, r.radius_error_px, r.ms);
  report.csv_path = (fs::path(options.output_dir) / "unwrap.csv").string();
  write_file_atomically(report.csv_path, csv);
  return report;
}

std::string EvalUnwrapReport::summary() const {
  std::string s = fmt::format("{:<10} {:<40} {:>10} {:>9} {:>10} {:>8}\n", "map", "probe", "log10 err", "valid sr",
                              "centre px", "ms");
  for (const UnwrapRow& r : rows)
    s += fmt::format("{:<10} {:<40} {:>10.4f} {:>9.3f} {:>10.3f} {:>8.1f}\n", r.map, r.probe, r.error.mean_abs_log10,
                     r.error.valid_solid_angle, r.centre_error_px, r.ms);
  s += fmt::format("-> {}\n", csv_path);
  return s;
}

nlohmann::json EvalUnwrapReport::to_json() const {
  nlohmann::json jr = nlohmann::json::array();
  for (const UnwrapRow& r : rows)
    jr.push_back({{"map", r.map}, {"probe", r.probe}, {"mean_abs_log10", r.error.mean_abs_log10},
                  {"centre_error_px", r.centre_error_px}, {"ms", r.ms}});
  return {{"csv", csv_path}, {"rows", jr}};
}

}  // namespace lp
