#include "eval/auto_bracket_eval.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include "core/error.h"
#include "core/image_io.h"
#include "hdr/bracket.h"
#include "hdr/hdr_accuracy.h"
#include "hdr/merge.h"

namespace lp {
namespace {

double luminance_at(const RgbImage& image, size_t i) {
  return 0.2126 * image.rgb[3 * i] + 0.7152 * image.rgb[3 * i + 1] + 0.0722 * image.rgb[3 * i + 2];
}

// One frame through the response (merge_bracket needs two): L = exp(g(z)) / t.
RgbImage decode_one(const RgbImage& codes, double seconds, const CameraResponse& response) {
  RgbImage out = codes;
  for (size_t i = 0; i < out.rgb.size(); ++i) {
    const size_t level = size_t(std::lround(double(codes.rgb[i]) * (response.levels - 1)));
    out.rgb[i] = float(std::exp(double(response.log_exposure[i % 3][level])) / seconds);
  }
  return out;
}

struct FrameResult {
  size_t exposures = 0;
  HdrError error;
  double power_error = 0;
};

FrameResult photograph(const RgbImage& truth, const std::vector<double>& times, const EvalAutoBracketOptions& options,
                       uint64_t seed, RgbImage* fused_out) {
  SyntheticBracketOptions so;
  so.exposure_seconds = times;
  so.response = options.response;
  so.bit_depth = options.bit_depth;
  so.exposure_scale = 1;  // a fixed camera: code = f(L t), whatever the scene does
  so.seed = seed;
  const SyntheticBracket sb = make_synthetic_bracket(truth, so);
  CameraResponse response;
  response.levels = int(sb.true_log_exposure[0].size());
  response.log_exposure = sb.true_log_exposure;
  RgbImage fused = times.size() == 1 ? decode_one(sb.frames[0], times[0], response)
                                     : merge_bracket(Bracket{sb.frames, sb.exposure_seconds, options.bit_depth, {}}, response);
  FrameResult r;
  r.exposures = times.size();
  r.error = hdr_log_error(fused, truth);
  double power = 0, true_power = 0;
  for (size_t i = 0; i < size_t(truth.width) * size_t(truth.height); ++i) {
    const double y = luminance_at(fused, i);
    if (std::isfinite(y)) power += y;
    true_power += luminance_at(truth, i);
  }
  r.power_error = std::abs(power * r.error.global_scale - true_power) / true_power;
  if (fused_out) *fused_out = std::move(fused);
  return r;
}

}  // namespace

RgbImage auto_bracket_scene(const std::string& scenario, int frame, int frames, int width, int height) {
  if (width < 32 || height < 16) throw InputError("eval auto-bracket: images must be at least 32x16");
  RgbImage image;
  image.width = width, image.height = height;
  image.rgb.resize(size_t(3) * width * height);
  const double t = frames > 1 ? double(frame) / (frames - 1) : 0;  // 0 .. 1 over the sequence
  auto set = [&](int x, int y, double v) {
    for (int c = 0; c < 3; ++c) image.rgb[3 * (size_t(y) * width + x) + c] = float(v);
  };
  auto in_disc = [](int x, int y, double cx, double cy, double r) { return (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r; };
  const double s = width / 128.0;  // features scale with the image
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double f = 0.5 * (double(x) / (width - 1) + double(y) / (height - 1));  // 0 .. 1 across
      if (scenario == "lamp") {
        const bool on = frame >= frames / 2;
        set(x, y, in_disc(x, y, 32 * s, 20 * s, 6 * s) ? (on ? 2000.0 : 0.8) : 0.5 * std::pow(4.0, f));
      } else if (scenario == "window") {
        const double open = std::clamp((t - 0.25) / 0.5, 0.0, 1.0);
        const bool window = x >= 80 * s && x < 104 * s && y >= 16 * s && y < 32 * s;
        set(x, y, window ? std::pow(300.0, open) : 0.5 * std::pow(4.0, f));
      } else if (scenario == "cloud") {
        const bool cloudy = t >= 1 / 3.0 && t < 2 / 3.0;
        const bool sun = in_disc(x, y, 96 * s, 16 * s, 2 * s);
        const bool cloud = x >= 80 * s && x < 112 * s && y >= 8 * s && y < 24 * s;
        const double sky = 2 * std::pow(4.0, double(y) / (height - 1));
        set(x, y, sun ? (cloudy ? 50.0 : 5e4) : cloudy && cloud ? 10.0 : sky);
      } else {
        throw InputError("eval auto-bracket: unknown scenario '" + scenario + "' (lamp, window, cloud)");
      }
    }
  return image;
}

const AutoBracketRow& EvalAutoBracketReport::row(const std::string& scenario, const std::string& strategy) const {
  for (const auto& r : rows)
    if (r.scenario == scenario && r.strategy == strategy) return r;
  throw std::out_of_range("no row " + scenario + "/" + strategy);
}

EvalAutoBracketReport evaluate_auto_bracket(const EvalAutoBracketOptions& options, const EvalProgress& progress) {
  if (options.frames < 2) throw InputError("eval auto-bracket: at least 2 frames per scenario");
  for (const auto& name : options.scenarios) auto_bracket_scene(name, 0, 2, options.width, options.height);  // names first
  EvalAutoBracketReport report;
  std::string csv = "scenario,strategy,frame,exposures,median_log10,p95_log10,power_error,exposure_seconds\n";
  ProgressSteps steps(progress, options.scenarios.size());
  for (const auto& scenario : options.scenarios) {
    for (const std::string strategy : {"auto", "fixed3", "fixed5"}) {
      AutoBracketRow row;
      row.scenario = scenario;
      row.strategy = strategy;
      std::vector<double> times = strategy == "fixed5" ? options.fixed5 : options.fixed3;
      std::unique_ptr<AutoBracketPlanner> planner;
      for (int f = 0; f < options.frames; ++f) {
        const RgbImage truth = auto_bracket_scene(scenario, f, options.frames, options.width, options.height);
        RgbImage fused;
        const FrameResult r = photograph(truth, times, options, options.seed + uint64_t(f), &fused);
        row.frames.push_back({r.exposures, r.error.median_log10, r.error.p95_log10, r.power_error});
        row.frames_per_map += double(r.exposures) / options.frames;
        row.median_log10 += r.error.median_log10 / options.frames;
        row.p95_log10 += r.error.p95_log10 / options.frames;
        row.worst_p95_log10 = std::max(row.worst_p95_log10, r.error.p95_log10);
        row.power_error += r.power_error / options.frames;
        row.worst_power_error = std::max(row.worst_power_error, r.power_error);
        std::string list;
        for (double t : times) list += fmt::format("{}{:.4g}", list.empty() ? "" : ";", t);
        csv += fmt::format("{},{},{},{},{:.5f},{:.5f},{:.5f},{}\n", scenario, strategy, f, r.exposures,
                           r.error.median_log10, r.error.p95_log10, r.power_error, list);
        if (strategy != "auto") continue;
        // The next frame's bracket from this frame's map, as the stream plans it.
        if (!planner) {
          CameraResponse truth_response;  // the response the merge used: the true one
          SyntheticBracketOptions so;
          so.response = options.response;
          so.exposure_scale = 1;
          so.bit_depth = options.bit_depth;
          const SyntheticBracket probe = make_synthetic_bracket(truth, so);
          truth_response.levels = int(probe.true_log_exposure[0].size());
          truth_response.log_exposure = probe.true_log_exposure;
          planner = std::make_unique<AutoBracketPlanner>(usable_exposure_window(truth_response, options.planner.codes),
                                                         options.limits, options.planner);
        }
        planner->update(meter_image(fused, times));
        times = planner->plan().exposure_seconds;
      }
      if (planner) row.replans = int(planner->changes());
      report.rows.push_back(row);
    }
    steps.advance();
  }
  if (!options.output_dir.empty()) {
    make_output_directory(options.output_dir);
    report.csv_path = (std::filesystem::path(options.output_dir) / "auto_bracket.csv").string();
    write_file_atomically(report.csv_path, csv);
  }
  return report;
}

std::string EvalAutoBracketReport::summary() const {
  std::string s = fmt::format("{:<8} {:<8} {:>7} {:>8} {:>8} {:>9} {:>8} {:>9} {:>7}\n", "scenario", "bracket",
                              "frames", "median", "p95", "worst p95", "power", "worst pow", "replans");
  for (const auto& r : rows)
    s += fmt::format("{:<8} {:<8} {:>7.2f} {:>8.4f} {:>8.4f} {:>9.4f} {:>8.4f} {:>9.4f} {:>7}\n", r.scenario, r.strategy,
                     r.frames_per_map, r.median_log10, r.p95_log10, r.worst_p95_log10, r.power_error,
                     r.worst_power_error, r.strategy == "auto" ? std::to_string(r.replans) : "-");
  s += "(frames per HDR map; log10 luminance errors and relative power error, means over frames)\n";
  if (!csv_path.empty()) s += "per frame: " + csv_path + "\n";
  return s;
}

nlohmann::json EvalAutoBracketReport::to_json() const {
  nlohmann::json rows_json = nlohmann::json::array();
  for (const auto& r : rows)
    rows_json.push_back({{"scenario", r.scenario}, {"strategy", r.strategy}, {"frames_per_map", r.frames_per_map},
                         {"median_log10", r.median_log10}, {"p95_log10", r.p95_log10},
                         {"worst_p95_log10", r.worst_p95_log10}, {"power_error", r.power_error},
                         {"worst_power_error", r.worst_power_error}, {"replans", r.replans}});
  return {{"csv", csv_path}, {"rows", rows_json}};
}

}  // namespace lp
