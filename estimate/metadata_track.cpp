#include "estimate/metadata_track.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <sstream>

#include "core/error.h"
#include "core/file_io.h"

namespace lp {

namespace {

using nlohmann::json;

std::optional<double> opt_number(const json& j, const char* key, const std::string& source) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return std::nullopt;
  if (!it->is_number()) throw InputError(fmt::format("{}: {} must be a number", source, key));
  return it->get<double>();
}

std::optional<std::array<double, 3>> opt_triple(const json& j, const char* key, const std::string& source) {
  auto it = j.find(key);
  if (it == j.end() || it->is_null()) return std::nullopt;
  if (!it->is_array() || it->size() != 3)
    throw InputError(fmt::format("{}: {} must be an array of 3 numbers", source, key));
  std::array<double, 3> v{};
  for (int i = 0; i < 3; ++i) {
    if (!(*it)[i].is_number()) throw InputError(fmt::format("{}: {} must be an array of 3 numbers", source, key));
    v[i] = (*it)[i].get<double>();
  }
  return v;
}

void read_camera(const json& c, MeteringOptions& o, const std::string& source) {
  if (auto v = opt_number(c, "photometric_scale", source)) o.photometric_scale = *v;
  if (auto v = opt_number(c, "calibration_f_number", source)) o.calibration_f_number = *v;
  if (auto v = opt_number(c, "f_number", source)) o.f_number = *v;
  if (auto v = opt_number(c, "ae_target", source)) o.ae_target = *v;
  if (auto v = opt_number(c, "iso_base", source)) o.iso_base = *v;
  if (auto v = opt_number(c, "meter_constant", source)) o.meter_constant = *v;
  if (auto it = c.find("colour_matrix"); it != c.end() && !it->is_null()) {
    if (!it->is_array() || it->size() != 9) throw InputError(fmt::format("{}: colour_matrix must be 9 numbers", source));
    std::array<double, 9> m{};
    for (int i = 0; i < 9; ++i) {
      if (!(*it)[i].is_number()) throw InputError(fmt::format("{}: colour_matrix must be 9 numbers", source));
      m[i] = (*it)[i].get<double>();
    }
    o.colour_matrix = m;
  }
}

}  // namespace

Track read_track(const std::string& path) {
  std::istringstream f(read_text_file(path, "the track"));
  Track track;
  std::string line;
  int line_no = 0;
  while (std::getline(f, line)) {
    ++line_no;
    const std::string source = fmt::format("{}:{}", path, line_no);
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    json j;
    try {
      j = json::parse(line);
    } catch (const json::exception&) {
      throw InputError(fmt::format("{}: not a JSON object", source));
    }
    if (!j.is_object()) throw InputError(fmt::format("{}: not a JSON object", source));
    if (j.contains("format")) {
      if (j["format"] != "lightprobe.track/1")
        throw InputError(fmt::format("{}: unknown format {} (expected lightprobe.track/1)", source, j["format"].dump()));
      if (!track.frames.empty()) throw InputError(fmt::format("{}: the header must be the first line", source));
      track.has_camera = true;
      if (j.contains("camera")) read_camera(j["camera"], track.camera, source);
      continue;
    }
    TrackFrame fr;
    fr.source = source;
    fr.frame = j.contains("frame") && j["frame"].is_number_integer() ? j["frame"].get<int64_t>()
                                                                    : int64_t(track.frames.size());
    fr.timestamp = opt_number(j, "timestamp", source).value_or(0.0);
    auto pos = j.find("position");
    if (pos == j.end() || !pos->is_array() || pos->size() < 2 || pos->size() > 3)
      throw InputError(fmt::format("{}: position must be [x, y] or [x, y, z] in metres", source));
    for (const auto& c : *pos)
      if (!c.is_number() || !std::isfinite(c.get<double>()))
        throw InputError(fmt::format("{}: position must hold finite numbers", source));
    fr.position = {(*pos)[0].get<double>(), (*pos)[1].get<double>(), pos->size() == 3 ? (*pos)[2].get<double>() : 0.0};
    auto view = opt_triple(j, "view_dir", source);
    if (!view) throw InputError(fmt::format("{}: view_dir [x, y, z] is missing", source));
    fr.view_direction = {(*view)[0], (*view)[1], (*view)[2]};
    const double len = length(fr.view_direction);
    if (!(len > 0) || !std::isfinite(len))
      throw InputError(fmt::format("{}: view_dir must be finite and non-zero", source));
    fr.view_direction = (1 / len) * fr.view_direction;
    FrameMetadata& m = fr.metadata;
    auto exposure = opt_number(j, "exposure_s", source);
    if (!exposure) throw InputError(fmt::format("{}: exposure_s is missing", source));
    m.exposure_s = *exposure;
    m.gain_db = opt_number(j, "gain_db", source);
    m.analog_gain = opt_number(j, "analog_gain", source);
    m.digital_gain = opt_number(j, "digital_gain", source);
    m.iso = opt_number(j, "iso", source);
    m.f_number = opt_number(j, "f_number", source);
    m.wb_gains = opt_triple(j, "wb_gains", source);
    m.cct_k = opt_number(j, "cct", source);
    m.mean_code = opt_number(j, "mean_code", source);
    m.bright_rgb = opt_triple(j, "bright_rgb", source);
    track.frames.push_back(std::move(fr));
  }
  if (track.frames.empty()) throw InputError(fmt::format("{}: no frames", path));
  return track;
}

void validate_track(const Track& track) {
  validate_metering(track.camera);
  for (const TrackFrame& f : track.frames) meter_frame(f.metadata, track.camera, f.source);
}

std::string track_to_jsonl(const Track& track) {
  std::string out;
  if (track.has_camera) {
    json cam{{"f_number", track.camera.f_number},
             {"ae_target", track.camera.ae_target},
             {"iso_base", track.camera.iso_base},
             {"meter_constant", track.camera.meter_constant}};
    if (track.camera.photometric_scale) cam["photometric_scale"] = *track.camera.photometric_scale;
    if (track.camera.calibration_f_number > 0) cam["calibration_f_number"] = track.camera.calibration_f_number;
    if (track.camera.colour_matrix) cam["colour_matrix"] = *track.camera.colour_matrix;
    out += json{{"format", "lightprobe.track/1"}, {"camera", cam}}.dump() + "\n";
  }
  for (const TrackFrame& f : track.frames) {
    const FrameMetadata& m = f.metadata;
    json j{{"frame", f.frame},
           {"timestamp", f.timestamp},
           {"position", {f.position.x, f.position.y, f.position.z}},
           {"view_dir", {f.view_direction.x, f.view_direction.y, f.view_direction.z}},
           {"exposure_s", m.exposure_s}};
    if (m.gain_db) j["gain_db"] = *m.gain_db;
    if (m.analog_gain) j["analog_gain"] = *m.analog_gain;
    if (m.digital_gain) j["digital_gain"] = *m.digital_gain;
    if (m.iso) j["iso"] = *m.iso;
    if (m.f_number) j["f_number"] = *m.f_number;
    if (m.wb_gains) j["wb_gains"] = *m.wb_gains;
    if (m.cct_k) j["cct"] = *m.cct_k;
    if (m.mean_code) j["mean_code"] = *m.mean_code;
    if (m.bright_rgb) j["bright_rgb"] = *m.bright_rgb;
    out += j.dump() + "\n";
  }
  return out;
}

LightQuadtree build_model(const Track& track, const MeteringOptions& camera, const BuildModelOptions& options,
                          size_t count) {
  QuadtreeOptions q = options.quadtree;
  if (options.origin_from_first_frame && !track.frames.empty()) {
    q.origin_x = track.frames[0].position.x;
    q.origin_y = track.frames[0].position.y;
  }
  LightQuadtree tree(q);
  count = std::min(count, track.frames.size());
  for (size_t i = 0; i < count; ++i) {
    const TrackFrame& f = track.frames[i];
    const LightReading r = meter_frame(f.metadata, camera, f.source);
    tree.update(f.position.x, f.position.y, f.view_direction, r, f.frame);
  }
  return tree;
}

}  // namespace lp
