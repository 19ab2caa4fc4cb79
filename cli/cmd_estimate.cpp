// estimate metadata / estimate query: lighting without a probe, from the metadata a camera
// already has (exposure, gain, aperture, white balance), stored over the floor in the
// quadtree of seed 003 (docs/metadata.md).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <memory>

#include "calib/photometric.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/warnings.h"
#include "core/image_io.h"
#include "estimate/light_quadtree.h"
#include "estimate/metadata_track.h"
#include "sampling/exporters.h"

namespace lp::cli {

struct EstimateMetadataArgs {
  std::string track;                // JSONL track (estimate/metadata_track.h)
  std::string output;               // model.json
  std::string photometric;          // calib photometric result: k for the calibration route
  bool meter_equation = false;      // ignore any photometric scale (also the track's)
  double calibration_f_number = -1; // -1: the track header's (or 0)
  double f_number = -1, ae_target = -1, iso_base = -1, meter_constant = -1;  // -1: the track's
  std::string colour_matrix;        // 9 numbers, camera RGB -> Rec. 709 (default: the track's, else none)
  BuildModelOptions build;          // --root-size, --min-size and --max-weight, bound directly
  std::string origin;               // "X,Y"; default the first frame's position
};

struct EstimateQueryArgs {
  std::string model;
  std::string at;                   // "X,Y" or "X,Y,Z" (z ignored: the model is 2D)
  std::string output;               // light list; format from --format or the extension
  std::string format;
  double min_frames = 1;            // frames that make a sector informed (1: the paper's rule)
  double shrink = 0;                // > 0: hierarchical shrinkage with this prior weight
  int max_depth = -1;
};

namespace {

// The camera: the track's header, then --photometric and the explicit options.
MeteringOptions camera_from(const Track& track, const EstimateMetadataArgs& a) {
  MeteringOptions m = track.camera;
  if (!a.photometric.empty() && a.meter_equation)
    throw InputError(fmt::format("--photometric {} and --meter-equation contradict: the first gives the scale the second ignores",
                                 a.photometric));
  if (!a.photometric.empty()) {
    const PhotometricCalibration cal = load_photometric(a.photometric);
    if (cal.log_sensor)
      throw InputError(fmt::format("{}: a log-sensor calibration has no linear scale for exposure metering", a.photometric));
    m.photometric_scale = cal.scale_luminance;
  }
  if (a.meter_equation) m.photometric_scale.reset();
  // -1 exactly is "not given": any other value is the user's and is validated below (a NaN or
  // a negative aperture used to fall back to the track's without a word).
  auto given = [](double v) { return v != -1; };
  // An option the route never reads is refused, not ignored: the meter constant means nothing
  // beside a photometric scale, the calibration's aperture nothing without one.
  if (m.photometric_scale && given(a.meter_constant))
    throw InputError("--meter-constant is read by the meter equation only, and this run has a photometric scale "
                     "(--photometric or the track's); add --meter-equation to use it");
  if (!m.photometric_scale && given(a.calibration_f_number))
    throw InputError("--calibration-f-number is the aperture of a photometric scale, and this run has none "
                     "(the meter equation)");
  if (given(a.calibration_f_number)) m.calibration_f_number = a.calibration_f_number;
  if (given(a.f_number)) m.f_number = a.f_number;
  if (given(a.ae_target)) m.ae_target = a.ae_target;
  if (given(a.iso_base)) m.iso_base = a.iso_base;
  if (given(a.meter_constant)) m.meter_constant = a.meter_constant;
  if (!a.colour_matrix.empty()) {
    const auto v = parse_numbers(a.colour_matrix, "--colour-matrix", 9);
    m.colour_matrix = std::array<double, 9>{};
    std::copy(v.begin(), v.end(), m.colour_matrix->begin());
  }
  validate_metering(m);
  // The per-frame fallbacks are read only for frames that lack the value: said when none does.
  size_t no_aperture = 0, no_mean = 0, iso_only = 0;
  for (const TrackFrame& f : track.frames) {
    no_aperture += !f.metadata.f_number;
    no_mean += !f.metadata.mean_code;
    iso_only += f.metadata.iso && !f.metadata.gain_db && !f.metadata.analog_gain;
  }
  if (given(a.f_number) && no_aperture == 0)
    warn(fmt::format("--f-number {} is not used: every frame of {} records its aperture", a.f_number, a.track));
  if (given(a.ae_target) && no_mean == 0 && m.photometric_scale)
    warn(fmt::format("--ae-target {} is not used: the photometric scale reads each frame's own mean code, and every "
                     "frame of {} records one",
                     a.ae_target, a.track));
  if (given(a.iso_base) && iso_only == 0 && m.photometric_scale)
    warn(fmt::format("--iso-base {} is not used: the photometric scale reads each frame's own gain, and every frame "
                     "of {} records one (the meter equation, --meter-equation, would read it)",
                     a.iso_base, a.track));
  return m;
}

}  // namespace

int run_estimate_metadata(const EstimateMetadataArgs& args, const Output& out) {
  const auto t0 = Clock::now();
  const Track track = read_track(args.track);
  const MeteringOptions camera = camera_from(track, args);
  // Meter every frame first: a bad line fails before anything is written.
  std::vector<LightReading> readings;
  readings.reserve(track.frames.size());
  for (const TrackFrame& f : track.frames) readings.push_back(meter_frame(f.metadata, camera, f.source));

  BuildModelOptions b = args.build;
  if (!args.origin.empty()) {
    const auto o = parse_numbers(args.origin, "--origin", 2);
    b.quadtree.origin_x = o[0];
    b.quadtree.origin_y = o[1];
    b.origin_from_first_frame = false;
  }
  const auto t_build = Clock::now();
  const LightQuadtree model = build_model(track, camera, b);
  const double build_s = seconds_since(t_build);
  save_model(args.output, model);

  const ReadingsSpread spread = readings_spread(readings);
  const Spread &lum = spread.luminance, &lux = spread.illuminance, &cct = spread.cct;
  const std::string route = camera.photometric_scale ? "calibration" : "meter equation";
  say(out, "{}: {} frames -> {} nodes (depth {}), {} outside the root; luminance by the {}\n", args.output,
      track.frames.size(), model.nodes().size(), model.max_depth(), model.outside_updates(), route);
  say(out, "  luminance cd/m2  median {:.1f}  5-95 %: {:.1f} .. {:.1f}\n", lum.median, lum.p05, lum.p95);
  say(out, "  lux (pi L)       median {:.0f}  5-95 %: {:.0f} .. {:.0f}\n", lux.median, lux.p05, lux.p95);
  if (spread.with_cct)
    say(out, "  CCT K            median {:.0f}  5-95 %: {:.0f} .. {:.0f}\n", cct.median, cct.p05, cct.p95);
  say(out, "  build {:.2f} ms ({:.2f} us per frame)\n", build_s * 1e3, build_s * 1e6 / double(track.frames.size()));
  emit_json(out, {{"output", args.output},
                  {"frames", track.frames.size()},
                  {"nodes", model.nodes().size()},
                  {"max_depth", model.max_depth()},
                  {"outside_updates", model.outside_updates()},
                  {"camera", metering_json(camera)},
                  {"luminance_cd_m2", lum.to_json()},
                  {"illuminance_lux", lux.to_json()},
                  {"cct_k", cct.to_json()},
                  {"build_seconds", build_s},
                  {"seconds", seconds_since(t0)}});
  return 0;
}

int run_estimate_query(const EstimateQueryArgs& args, const Output& out) {
  const LightQuadtree model = load_model(args.model);
  const auto at = parse_numbers(args.at, "--at");
  if (at.size() != 2 && at.size() != 3) throw InputError(fmt::format("--at: give X,Y or X,Y,Z in metres, got '{}'", args.at));
  // A tracker's position has a height; the model is a floor plan and cannot use it.
  if (at.size() == 3)
    warn(fmt::format("--at: the model maps the floor plan (X, Y); the height Z = {:g} m is not used", at[2]));
  if (!(args.min_frames >= 1)) throw InputError(fmt::format("--min-frames must be >= 1, got {}", args.min_frames));
  if (!(args.shrink >= 0)) throw InputError(fmt::format("--shrink must be >= 0, got {}", args.shrink));
  if (args.max_depth < -1) throw InputError(fmt::format("--max-depth must be >= 0 (or -1: no limit), got {}", args.max_depth));
  // Shrinkage weighs every level of the path itself: the depth rule's options would be ignored.
  if (args.shrink > 0 && (args.max_depth != -1 || args.min_frames != 1))
    throw InputError("--shrink blends every level of the tree; --max-depth and --min-frames belong to the rule without it");
  const ExportFormat format = export_format_for(args.format, args.output, false);
  const auto t0 = Clock::now();
  const auto look = args.shrink > 0 ? model.lookup_shrunk(at[0], at[1], args.shrink)
                                    : model.lookup(at[0], at[1], args.max_depth, args.min_frames);
  LightList lights = args.shrink > 0 ? model.lights_shrunk(at[0], at[1], args.shrink)
                                     : model.lights_at(at[0], at[1], args.max_depth, args.min_frames);
  const double query_s = seconds_since(t0);
  if (lights.lights.empty()) throw InputError(fmt::format("{}: the model holds no data yet", args.model));
  write_file_atomically(args.output, export_lights(lights, format));
  const bool outside = !model.nodes()[0].contains(at[0], at[1]);
  nlohmann::json sectors = nlohmann::json::array();
  say(out, "{}: {} lights at ({}, {}){}\n", args.output, lights.lights.size(), at[0], at[1],
      outside ? " (outside the model: its root answers)" : "");
  for (int s = 0; s < kBipyramidSectors; ++s) {
    const SectorLookup& l = look[s];
    const double cct = l.sample.mired > 0 ? 1e6 / l.sample.mired : 0.0;
    say(out, "  sector {} ({}): {:8.1f} cd/m2  {:5.0f} K  from {}\n", s, s < 3 ? "up  " : "down", l.sample.luminance, cct,
        l.filled ? std::string("other sectors (never observed)") : fmt::format("node {} (depth {}, {} frames)", l.node, l.depth, l.sample.weight));
    sectors.push_back({{"sector", s},
                       {"luminance_cd_m2", l.sample.luminance},
                       {"cct_k", cct},
                       {"node", l.node},
                       {"depth", l.depth},
                       {"frames", l.sample.weight},
                       {"filled", l.filled}});
  }
  emit_json(out, {{"output", args.output},
                  {"format", std::string(to_string(format))},
                  {"lights", lights.lights.size()},
                  {"outside", outside},
                  {"sectors", sectors},
                  {"query_seconds", query_s}});
  return 0;
}

std::vector<Command> estimate_commands() {
  return {
      {"estimate metadata", "A recorded track (position, view, exposure, gain, WB per frame) -> quadtree model",
       "lightprobe estimate metadata track.jsonl -o model.json\nlightprobe estimate metadata track.jsonl --photometric photometric.json -o model.json",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EstimateMetadataArgs>();
         f.arg("TRACK", a->track, "JSONL track (see docs/metadata.md for the schema)").required();
         f.output(a->output, "Model JSON");
         f.opt("--photometric", a->photometric, "Photometric calibration (calib photometric): k for the calibration route");
         f.flag("--meter-equation", a->meter_equation, "Use the ISO 2720 meter equation even if a scale is known");
         f.opt("--calibration-f-number", a->calibration_f_number, "Aperture the photometric scale was fitted at");
         f.opt("--f-number", a->f_number, "Aperture of frames that record none");
         f.opt("--ae-target", a->ae_target, "Mean code value the auto exposure aims at (0..1)");
         f.opt("--iso-base", a->iso_base, "ISO at gain 1 (meter equation)");
         f.opt("--meter-constant", a->meter_constant, "Reflected-light meter constant K, cd s m^-2");
         f.opt("--colour-matrix", a->colour_matrix, "Camera RGB -> Rec. 709: 9 numbers, row-major");
         f.opt("--root-size", a->build.quadtree.root_size, "Side of the root cell, m (must cover the scene)");
         f.opt("--min-size", a->build.quadtree.min_size, "Smallest cell side, m");
         f.opt("--max-weight", a->build.quadtree.max_weight,
               "Cap on a sector's frame count: old frames fade (0: no cap)");
         f.opt("--origin", a->origin, "Root centre X,Y in metres (default: the first frame's position)");
         return [a](const Output& out) { return run_estimate_metadata(*a, out); };
       }},
      {"estimate query", "Six directional lights of a model at a position",
       "lightprobe estimate query model.json --at 4,3 -o lights.json",
       [](Flags& f) -> Handler {
         auto a = std::make_shared<EstimateQueryArgs>();
         f.arg("MODEL", a->model, "Model JSON (estimate metadata)").required();
         f.opt("--at", a->at, "Position X,Y in metres (a Z is accepted and not used: the model is a floor plan)").required();
         f.output(a->output, "Light list (.json, .pbrt, .xml, .gltf, .csv)");
         f.opt("--format", a->format, "json|ndjson|pbrt|mitsuba|gltf|glb|csv (default from -o)");
         f.opt("--min-frames", a->min_frames, "Frames that make a sector informed (1: the paper's rule)");
         f.opt("--shrink", a->shrink, "Hierarchical shrinkage with this prior weight in frames (0: off)");
         f.opt("--max-depth", a->max_depth, "Descend at most this deep (0: the root's global estimate)");
         return [a](const Output& out) { return run_estimate_query(*a, out); };
       }},
  };
}

}  // namespace lp::cli
