#include "eval/synthetic_sequence.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "core/accuracy.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/resample.h"

namespace lp {

namespace {

double deg(double d) { return d * M_PI / 180.0; }

uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Uniform in (0, 1]: never 0, so log() in Box-Muller is finite.
double unit_open(uint64_t& state) { return (double(splitmix64(state) >> 11) + 1.0) * 0x1.0p-53; }

bool adds_light(Scenario s) { return s != Scenario::StaticNoise && s != Scenario::CameraTurn; }

Vec3 from_elevation_azimuth(double elevation_deg, double azimuth_deg) {
  return direction_from_angles(deg(90.0 - elevation_deg), deg(azimuth_deg));
}

// Two unit vectors completing `n` to a right-handed orthonormal frame.
void basis(Vec3 n, Vec3& t1, Vec3& t2) {
  const Vec3 a = std::fabs(n.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
  t1 = normalize(cross(a, n));
  t2 = cross(n, t1);
}

void check_frame(const SequenceOptions& o, int frame) {
  if (frame < 0 || frame >= o.frames)
    throw InputError("sequence frame " + std::to_string(frame) + " is outside 0.." + std::to_string(o.frames - 1));
}

// Adds a cap of half-angle `radius` around `dir` carrying `power` (per channel) to the map,
// by 64 x 64 equal-area strata (see the header).
void deposit_cap(EnvMap& map, Vec3 dir, double radius, const std::array<double, 3>& power) {
  constexpr int kSide = 64;
  Vec3 t1, t2;
  basis(dir, t1, t2);
  const double cos_r = std::cos(radius);
  std::vector<size_t> hits;
  hits.reserve(kSide * kSide);
  for (int a = 0; a < kSide; ++a) {
    const double ca = 1 - (1 - cos_r) * (a + 0.5) / kSide;
    const double sa = std::sqrt(std::max(0.0, 1 - ca * ca));
    for (int b = 0; b < kSide; ++b) {
      const double beta = 2 * M_PI * (b + 0.5) / kSide;
      const Vec3 d = ca * dir + (sa * std::cos(beta)) * t1 + (sa * std::sin(beta)) * t2;
      const auto p = pixel_at(map, d);
      if (p && map.is_valid(*p)) hits.push_back(*p);
    }
  }
  std::sort(hits.begin(), hits.end());
  const double share = 1.0 / double(kSide * kSide);
  for (size_t i = 0; i < hits.size();) {
    size_t j = i;
    while (j < hits.size() && hits[j] == hits[i]) ++j;
    const size_t p = hits[i];
    const double f = double(j - i) * share / pixel_solid_angle(map, p);
    for (int c = 0; c < 3; ++c) map.pixel(p)[c] = float(double(map.pixel(p)[c]) + power[c] * f);
    i = j;
  }
}

void add_noise(EnvMap& map, double sigma, uint64_t seed, int frame) {
  uint64_t s = seed;
  const uint64_t frame_key = splitmix64(s) ^ (uint64_t(frame) * 0xD1B54A32D192ED03ull);
  const size_t n = map.pixel_count();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      uint64_t state = frame_key ^ (uint64_t(i) * 0x9FB21C651E98DF25ull);
      splitmix64(state);
      double g[4];
      for (int k = 0; k < 4; k += 2) {  // Box-Muller: two normals per pair of uniforms
        const double rad = std::sqrt(-2.0 * std::log(unit_open(state)));
        const double ang = 2 * M_PI * unit_open(state);
        g[k] = rad * std::cos(ang);
        g[k + 1] = rad * std::sin(ang);
      }
      float* p = map.pixel(i);
      for (int c = 0; c < 3; ++c) p[c] = float(std::max(0.0, double(p[c]) * (1.0 + sigma * g[c])));
    }
  });
}

}  // namespace

std::string_view to_string(Scenario scenario) {
  switch (scenario) {
    case Scenario::StaticNoise: return "static-noise";
    case Scenario::MovingLight: return "moving-light";
    case Scenario::SwingingBulb: return "swinging-bulb";
    case Scenario::AbruptSwitch: return "abrupt-switch";
    case Scenario::Flicker: return "flicker";
    case Scenario::RisingLight: return "rising-light";
    case Scenario::CameraTurn: return "camera-turn";
  }
  return "?";
}

std::optional<Scenario> scenario_from_string(std::string_view name) {
  for (Scenario s : all_scenarios())
    if (to_string(s) == name) return s;
  return std::nullopt;
}

const std::vector<Scenario>& all_scenarios() {
  static const std::vector<Scenario> all{Scenario::StaticNoise,  Scenario::MovingLight, Scenario::SwingingBulb,
                                         Scenario::AbruptSwitch, Scenario::Flicker,     Scenario::RisingLight,
                                         Scenario::CameraTurn};
  return all;
}

void validate(const SequenceOptions& o) {
  if (o.frames < 1) throw InputError("sequence: frames must be at least 1 (got " + std::to_string(o.frames) + ")");
  if (!(o.frame_rate_hz > 0) || !std::isfinite(o.frame_rate_hz))
    throw InputError("sequence: frame rate must be positive (got " + std::to_string(o.frame_rate_hz) + " Hz)");
  if (o.noise_sigma && (!(*o.noise_sigma >= 0) || !std::isfinite(*o.noise_sigma)))
    throw InputError("sequence: noise sigma must be >= 0 (got " + std::to_string(*o.noise_sigma) + ")");
  if (!(o.light_power_share >= 0) || !std::isfinite(o.light_power_share))
    throw InputError("sequence: light power share must be >= 0 (got " + std::to_string(o.light_power_share) + ")");
  if (!(o.light_radius_deg > 0 && o.light_radius_deg <= 90))
    throw InputError("sequence: light radius must be in (0, 90] deg (got " + std::to_string(o.light_radius_deg) + ")");
  if (!(std::fabs(o.light_elevation_deg) < 89))
    throw InputError("sequence: light elevation must be within +-89 deg (got " +
                     std::to_string(o.light_elevation_deg) + ")");
  if (!(o.flicker_depth >= 0 && o.flicker_depth <= 1))
    throw InputError("sequence: flicker depth must be in [0, 1] (got " + std::to_string(o.flicker_depth) + ")");
}

double effective_noise_sigma(const SequenceOptions& o) {
  if (o.noise_sigma) return *o.noise_sigma;
  return o.scenario == Scenario::StaticNoise ? 0.02 : 0.0;
}

int step_frame(const SequenceOptions& o) { return o.frames / 2; }

double flicker_alias_hz(const SequenceOptions& o) {
  double a = std::fmod(std::fabs(o.flicker_hz), o.frame_rate_hz);
  if (a > o.frame_rate_hz / 2) a = o.frame_rate_hz - a;
  return a;
}

std::optional<Vec3> added_light_direction(const SequenceOptions& o, int frame) {
  validate(o);
  check_frame(o, frame);
  if (!adds_light(o.scenario)) return std::nullopt;
  const Vec3 rest = from_elevation_azimuth(o.light_elevation_deg, o.light_azimuth_deg);
  const double phi = deg(o.light_azimuth_deg);
  const Vec3 east{-std::sin(phi), std::cos(phi), 0};  // towards increasing azimuth
  switch (o.scenario) {
    case Scenario::MovingLight: {
      // Great-circle angle a between azimuths dphi apart at elevation e: sin(a/2) = cos e sin(dphi/2).
      const double s = std::min(1.0, std::sin(deg(o.move_deg_per_frame) / 2) / std::cos(deg(o.light_elevation_deg)));
      const double dphi = 2 * std::asin(s) * 180.0 / M_PI;
      return from_elevation_azimuth(o.light_elevation_deg, o.light_azimuth_deg + dphi * frame);
    }
    case Scenario::SwingingBulb: {
      const double a = deg(o.swing_amplitude_deg) * std::sin(2 * M_PI * o.swing_hz * frame / o.frame_rate_hz);
      return normalize(std::cos(a) * rest + std::sin(a) * east);
    }
    case Scenario::RisingLight: {
      const double f = o.frames > 1 ? double(frame) / double(o.frames - 1) : 0.0;
      return from_elevation_azimuth(o.rise_from_deg + (o.rise_to_deg - o.rise_from_deg) * f, o.light_azimuth_deg);
    }
    default: return rest;
  }
}

double added_light_power_factor(const SequenceOptions& o, int frame) {
  validate(o);
  check_frame(o, frame);
  switch (o.scenario) {
    case Scenario::StaticNoise:
    case Scenario::CameraTurn: return 0;
    case Scenario::AbruptSwitch: return frame < step_frame(o) ? 1 : 0;
    case Scenario::Flicker:
      return 1 - o.flicker_depth * std::cos(2 * M_PI * o.flicker_hz * frame / o.frame_rate_hz);
    default: return 1;
  }
}

std::array<double, 3> added_light_rgb(const EnvMap& base, const SequenceOptions& o, int frame) {
  const double f = added_light_power_factor(o, frame);
  if (f == 0) return {0, 0, 0};
  const double p = o.light_power_share * total_luminance_power(base) * f;
  return {p, p, p};
}

Mat3 camera_rotation(const SequenceOptions& o, int frame) {
  validate(o);
  check_frame(o, frame);
  if (o.scenario != Scenario::CameraTurn) return Mat3{};
  return rotation_from_yaw_pitch_roll_deg(o.camera_turn_deg_per_frame * frame, 0, 0);
}

EnvMap render_sequence_frame(const EnvMap& base, const SequenceOptions& o, int frame) {
  validate(o);
  check_frame(o, frame);
  EnvMap map = o.scenario == Scenario::CameraTurn && std::fmod(o.camera_turn_deg_per_frame * frame, 360.0) != 0
                   ? rotate(base, camera_rotation(o, frame))
                   : base;
  if (adds_light(o.scenario)) {
    const double base_power = total_luminance_power(base);
    if (!(base_power > 0) && o.light_power_share > 0)
      throw InputError("sequence: the base map has no power to scale the added light by");
    const auto rgb = added_light_rgb(base, o, frame);
    if (rgb[0] != 0 || rgb[1] != 0 || rgb[2] != 0)
      deposit_cap(map, *added_light_direction(o, frame), deg(o.light_radius_deg), rgb);
  }
  const double sigma = effective_noise_sigma(o);
  if (sigma > 0) add_noise(map, sigma, o.seed, frame);
  return map;
}

std::string write_sequence_files(const std::string& dir, const EnvMap& base, const std::string& base_label,
                                 const SequenceOptions& so, const std::function<void()>& frame_done) {
  namespace fs = std::filesystem;
  make_output_directory(dir);
  nlohmann::json truth = {{"scenario", std::string(to_string(so.scenario))},
                          {"base", base_label},
                          {"frames", so.frames},
                          {"frame_rate_hz", so.frame_rate_hz},
                          {"layout", std::string(to_string(base.layout))}};
  if (so.scenario == Scenario::AbruptSwitch) truth["step_frame"] = step_frame(so);
  if (so.scenario == Scenario::Flicker) truth["alias_hz"] = flicker_alias_hz(so);
  nlohmann::json per_frame = nlohmann::json::array();
  std::string times;
  for (int f = 0; f < so.frames; ++f) {
    const EnvMap frame = render_sequence_frame(base, so, f);
    const std::string name = fmt::format("frame_{:04d}.exr", f);
    write_envmap((fs::path(dir) / name).string(), frame);
    nlohmann::json j = {{"frame", f}, {"file", name}, {"power_luminance", total_luminance_power(frame)}};
    if (auto d = added_light_direction(so, f)) {
      const auto rgb = added_light_rgb(base, so, f);
      j["light_direction"] = {d->x, d->y, d->z};
      j["light_rgb"] = {rgb[0], rgb[1], rgb[2]};
    }
    per_frame.push_back(j);
    times += fmt::format("{:.9g}\n", f / so.frame_rate_hz);
    if (frame_done) frame_done();
  }
  truth["per_frame"] = per_frame;
  write_file_atomically((fs::path(dir) / "timestamps.txt").string(), times);
  const std::string truth_path = (fs::path(dir) / "truth.json").string();
  write_file_atomically(truth_path, truth.dump(2) + "\n");
  return truth_path;
}

}  // namespace lp
