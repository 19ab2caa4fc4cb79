// sample: environment map(s) -> light list in the chosen format.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <memory>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "cli/commands.h"
#include "cli/report.h"
#include "core/accuracy.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "sampling/auto_count.h"
#include "sampling/exporters.h"
#include "sampling/frame_pipeline.h"
#include "sampling/overlay.h"
#include "sampling/sampler.h"

namespace lp::cli {

struct SampleArgs {
  std::vector<std::string> inputs;  // one map, several maps (a sequence) or a directory
  std::string method = "pharr";
  std::string n = "256";            // a count or "auto"
  double target_error = 0.01;
  std::string format;               // json|ndjson|pbrt|mitsuba|gltf|csv (default from -o)
  std::string output;
  std::string overlay;              // PNG of the lights on the map
  std::string layout;               // input layout override
  bool upper_only = false;
  bool lloyd = false;
  double q2_a = 1.0, q2_b = 0.25;
  bool q2_jitter = false;
  int q2_nside = 0;
  std::string filter = "auto";      // FIR filtering of power and directions: auto|on|off
  double fps = 21;                  // frame rate the filter is designed for
  int cluster = 0;                  // cluster to at most this many lights (0: off)
};

namespace {

namespace fs = std::filesystem;

bool is_map_file(const fs::path& p) {
  const std::string e = p.extension().string();
  return e == ".exr" || e == ".hdr" || e == ".pfm";
}

// A directory stands for the maps inside it, in name order (a recorded sequence).
std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs) {
  std::vector<std::string> files;
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      std::vector<std::string> found;
      for (const auto& entry : fs::directory_iterator(in))
        if (entry.is_regular_file() && is_map_file(entry.path())) found.push_back(entry.path().string());
      std::sort(found.begin(), found.end());
      if (found.empty()) throw InputError(fmt::format("{}: directory holds no .exr/.hdr/.pfm maps", in));
      files.insert(files.end(), found.begin(), found.end());
    } else {
      files.push_back(in);
    }
  }
  return files;
}

// Capture times of a recorded sequence, when known: a directory may hold
// `timestamps.txt`, one time in seconds per map, in the maps' name order.
std::optional<std::vector<double>> read_timestamps(const std::vector<std::string>& inputs, size_t frames) {
  if (inputs.size() != 1) return std::nullopt;
  std::error_code ec;
  if (!fs::is_directory(inputs[0], ec)) return std::nullopt;
  const fs::path path = fs::path(inputs[0]) / "timestamps.txt";
  if (!fs::exists(path, ec)) return std::nullopt;
  std::ifstream in(path);
  std::vector<double> times;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    try {
      size_t used = 0;
      const double t = std::stod(line, &used);
      if (!std::isfinite(t)) throw std::invalid_argument("x");
      times.push_back(t);
    } catch (const std::exception&) {
      throw InputError(fmt::format("{}: line {} is not a time in seconds: '{}'", path.string(), times.size() + 1, line));
    }
  }
  if (times.size() != frames)
    throw InputError(fmt::format("{}: {} times for {} maps", path.string(), times.size(), frames));
  return times;
}

ExportFormat format_for(const std::string& format, const std::string& output, bool sequence) {
  if (!format.empty()) {
    auto f = export_format_from_string(format);
    if (!f) throw InputError(fmt::format("--format: unknown format '{}' (json, ndjson, pbrt, mitsuba, gltf, csv)", format));
    return *f;
  }
  const std::string e = fs::path(output).extension().string();
  if (e == ".ndjson" || e == ".jsonl") return ExportFormat::Ndjson;
  if (e == ".pbrt") return ExportFormat::Pbrt;
  if (e == ".xml") return ExportFormat::Mitsuba;
  if (e == ".gltf") return ExportFormat::Gltf;
  if (e == ".csv") return ExportFormat::Csv;
  return sequence ? ExportFormat::Ndjson : ExportFormat::Json;
}


}  // namespace

int run_sample(const SampleArgs& args, const Output& out) {
  const auto method = method_from_string(args.method);
  if (!method) throw InputError(fmt::format("--method: unknown method '{}' (pharr, hemigon, q2tree, mediancut)", args.method));
  const bool automatic = args.n == "auto";
  int n = 0;
  if (!automatic) {
    try {
      size_t used = 0;
      n = std::stoi(args.n, &used);
      if (used != args.n.size()) throw std::invalid_argument("x");
    } catch (const std::exception&) {
      throw InputError(fmt::format("--n must be a positive integer or 'auto', got '{}'", args.n));
    }
    if (n <= 0) throw InputError(fmt::format("--n must be positive, got {}", n));
  }
  const std::vector<std::string> files = expand_inputs(args.inputs);
  const auto timestamps = read_timestamps(args.inputs, files.size());
  const bool sequence = files.size() > 1;
  const ExportFormat format = format_for(args.format, args.output, sequence);
  if (sequence && format != ExportFormat::Ndjson && format != ExportFormat::Csv)
    throw InputError(fmt::format("{} maps form a sequence: use --format ndjson (or csv)", files.size()));

  FramePipelineOptions po;
  po.method = *method;
  po.sampler.upper_only = args.upper_only;
  po.sampler.lloyd_relaxed = args.lloyd;
  po.sampler.q2_luminance_exponent = args.q2_a;
  po.sampler.q2_solid_angle_exponent = args.q2_b;
  po.sampler.q2_jitter = args.q2_jitter;
  po.sampler.q2_nside = args.q2_nside;
  po.count = n;
  po.auto_count = automatic;
  po.auto_options.target_diffuse_error = args.target_error;
  if (args.filter == "auto") po.filter = FilterMode::Auto;
  else if (args.filter == "on") po.filter = FilterMode::On;
  else if (args.filter == "off") po.filter = FilterMode::Off;
  else throw InputError(fmt::format("--filter must be auto, on or off, got '{}'", args.filter));
  if (!(args.fps > 0)) throw InputError(fmt::format("--fps must be positive, got {}", args.fps));
  po.frame_rate_hz = args.fps;
  po.cluster_max_lights = args.cluster;
  FramePipeline pipeline(po);

  ReadMapOptions ro;
  if (!args.layout.empty()) {
    ro.layout = layout_from_string(args.layout);
    if (!ro.layout) throw InputError(fmt::format("--layout: unknown layout '{}'", args.layout));
  }
  AccuracyOptions ao;
  ao.shadowed = false;  // the slow part of the reference; `eval sampling` charts it

  std::string text;
  nlohmann::json frames = nlohmann::json::array();
  Progress progress("sample", files.size(), out.progress && sequence);
  EnvMap last_map;
  LightList last;
  for (size_t f = 0; f < files.size(); ++f) {
    EnvMap map = read_envmap(files[f], ro);
    // Frame times: the sequence's timestamps.txt when known, else --fps from 0; a single
    // map is stamped with the current time.
    const double now = timestamps ? (*timestamps)[f]
                       : sequence ? double(f) / args.fps
                                  : std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    LightList list;
    try {
      list = pipeline.process(map, int64_t(f), now);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", files[f], e.what()));
    }
    const FrameTiming& t = pipeline.last_timing();
    const AccuracyReference reference = make_accuracy_reference(map, ao);
    const LightError err = light_error(reference, list.lights);
    nlohmann::json frame_report = {{"file", files[f]},
                                   {"frame", list.frame},
                                   {"lights", list.lights.size()},
                                   {"prepare_seconds", t.prepare_ms / 1e3},
                                   {"place_seconds", t.place_ms / 1e3},
                                   {"temporal_seconds", t.temporal_ms / 1e3},
                                   {"diffuse_error", err.diffuse},
                                   {"glossy10_error", err.glossy.at(0)},
                                   {"glossy100_error", err.glossy.at(1)}};
    if (automatic && err.diffuse > args.target_error)
      say(out, "{}: the target diffuse error {:.3g} was not reached ({} lights, {:.3g})\n", files[f],
          args.target_error, list.lights.size(), err.diffuse);
    frames.push_back(frame_report);
    if (!out.json && !sequence)
      say(out, "{}: {} {} lights in {:.3f} ms (+{:.3f} ms preparing); diffuse error {:.2f} %, glossy {:.2f} % (s=10), {:.2f} % (s=100)\n",
          files[f], list.lights.size(), list.method, t.place_ms + t.temporal_ms, t.prepare_ms, 100 * err.diffuse,
          100 * err.glossy[0], 100 * err.glossy[1]);
    if (format == ExportFormat::Csv && f > 0) {
      std::string body = export_lights(list, format);
      text += body.substr(body.find('\n') + 1);  // one header for the whole sequence
    } else {
      text += export_lights(list, format);
    }
    progress.advance();
    last = std::move(list);
    if (f + 1 == files.size()) last_map = std::move(map);
  }
  progress.finish();
  write_file_atomically(args.output, text);
  if (!args.overlay.empty()) write_overlay_png(args.overlay, last_map, last.lights);
  if (sequence && !out.json)
    say(out, "{} frames -> {}{}\n", files.size(), args.output,
        pipeline.filtering() ? fmt::format(" (FIR-filtered: lights lag the maps by {} frames)", pipeline.delay_frames()) : "");
  nlohmann::json report = {{"method", args.method},
                            {"output", args.output},
                            {"format", std::string(to_string(format))},
                            {"filter_delay_frames", pipeline.delay_frames()}};
  if (sequence)
    report["frames"] = frames;
  else
    report.update(frames[0]);
  emit_json(out, report);
  return 0;
}

std::vector<Command> sample_commands() {
  return {
      {"sample", "Environment map -> directional lights",
       "lightprobe sample probe.exr --method q2tree --n 256 -o lights.json --overlay lights.png\nlightprobe sample probe.exr --method pharr --n auto --target-error 0.01 -o lights.pbrt\nlightprobe sample frames/ --method hemigon --n 300 -o lights.ndjson",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<SampleArgs>();
         f.arg("MAP", a->inputs, "A map, several maps (a sequence: NDJSON, one frame each) or a directory").required();
         f.opt("--method", a->method, "pharr|hemigon|q2tree|mediancut");
         f.opt("--n", a->n, "Number of lights, or 'auto' with --target-error");
         f.opt("--target-error", a->target_error, "With --n auto: largest diffuse error (0.01 = 1 %)");
         f.opt("--format", a->format, "json|ndjson|pbrt|mitsuba|gltf|csv (default: from -o's extension)");
         f.output(a->output, "Output file");
         f.opt("--overlay", a->overlay, "Also draw the lights on the tone-mapped map (PNG)");
         f.opt("--layout", a->layout, "Read the input as this layout");
         f.flag("--upper-only", a->upper_only, "hemigon: sample only the upper hemisphere (sky probes)");
         f.flag("--lloyd", a->lloyd, "hemigon: Lloyd-relaxed Halton points");
         f.opt("--q2-a", a->q2_a, "q2tree: luminance exponent a of p = L^a dw^b");
         f.opt("--q2-b", a->q2_b, "q2tree: solid-angle exponent b of p = L^a dw^b");
         f.flag("--q2-jitter", a->q2_jitter, "q2tree: deterministic jitter instead of leaf centroids");
         f.opt("--q2-nside", a->q2_nside, "q2tree: HEALPix resolution to bin to (0: from the input)");
         f.opt("--filter", a->filter, "Temporal FIR filter on power and directions: auto (hemigon only), on, off");
         f.opt("--fps", a->fps, "Frame rate of a sequence (the FIR filter is designed for it)");
         f.opt("--cluster", a->cluster, "Cluster the lights to at most this many (Havran 2005 4.3)");
         return [a](const Output& out) { return run_sample(*a, out); };
       }},
  };
}

}  // namespace lp::cli
