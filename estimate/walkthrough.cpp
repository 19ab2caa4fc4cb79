#include "estimate/walkthrough.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/accuracy.h"
#include "core/error.h"
#include "core/image_io.h"
#include "estimate/light_quadtree.h"
#include "estimate/white_balance_cct.h"

namespace lp {

namespace {

constexpr double kEfficacy = 683.0;

std::array<double, 3> emitter_radiance(double luminance_cd, double cct_k) {
  const auto c = planckian_rgb(cct_k);
  return {c[0] * luminance_cd / kEfficacy, c[1] * luminance_cd / kEfficacy, c[2] * luminance_cd / kEfficacy};
}

// Irradiance (per channel, radiance units x sr) on a surface point h with unit normal n.
std::array<double, 3> direct_irradiance(const Room& room, Vec3 h, Vec3 n) {
  std::array<double, 3> e{0, 0, 0};
  for (const RoomLamp& lamp : room.lamps) {
    const Vec3 w = lamp.position - h;
    const double d2 = dot(w, w);
    const double cos_r = dot(n, w) / std::sqrt(d2);
    if (cos_r <= 0) continue;
    const auto l = emitter_radiance(lamp.luminance, lamp.cct_k);
    const double f = M_PI * lamp.radius * lamp.radius * cos_r / d2;  // intensity L pi r^2
    for (int c = 0; c < 3; ++c) e[c] += l[c] * f;
  }
  if (room.window) {
    const RoomWindow& win = *room.window;
    const auto l = emitter_radiance(win.luminance, win.cct_k);
    constexpr int kPatches = 8;
    const double dy = (win.y1 - win.y0) / kPatches, dz = (win.z1 - win.z0) / kPatches;
    for (int a = 0; a < kPatches; ++a)
      for (int b = 0; b < kPatches; ++b) {
        const Vec3 c{0, win.y0 + (a + 0.5) * dy, win.z0 + (b + 0.5) * dz};
        const Vec3 w = c - h;
        const double d2 = dot(w, w);
        if (d2 < 1e-12) continue;
        const double inv = 1 / std::sqrt(d2);
        const double cos_r = dot(n, w) * inv, cos_e = -w.x * inv;  // window normal +X
        if (cos_r <= 0 || cos_e <= 0) continue;
        const double f = dy * dz * cos_e * cos_r / d2;
        for (int k = 0; k < 3; ++k) e[k] += l[k] * f;
      }
  }
  return e;
}

// Camera basis for a view direction: right and up in the image.
void camera_basis(Vec3 view, Vec3* right, Vec3* up) {
  Vec3 world_up{0, 0, 1};
  if (std::fabs(view.z) > 0.999) world_up = {1, 0, 0};
  *right = normalize(cross(view, world_up));
  *up = cross(*right, view);
}

}  // namespace

MeteringOptions walkthrough_camera() {
  MeteringOptions m;
  m.f_number = 2.0;
  m.iso_base = 100;
  m.ae_target = 0.18;
  m.meter_constant = 12.5;
  m.photometric_scale = m.meter_constant * m.f_number * m.f_number / (m.iso_base * m.ae_target);
  return m;
}

Room default_room() {
  Room r;
  r.lamps = {{{2.0, 2.0, 2.5}, 0.1, 30000, 2700}, {{6.0, 1.8, 2.5}, 0.1, 20000, 4000}, {{4.5, 4.6, 2.5}, 0.12, 25000, 3000}};
  r.window = RoomWindow{};
  return r;
}

std::array<double, 3> room_radiance(const Room& room, Vec3 o, Vec3 d) {
  // Exit of the box (o is inside).
  double t_exit = INFINITY;
  int axis = 0;
  bool positive_side = false;
  const double lo[3] = {0, 0, 0}, hi[3] = {room.width, room.depth, room.height};
  const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  for (int a = 0; a < 3; ++a) {
    if (dd[a] == 0) continue;
    const double t = ((dd[a] > 0 ? hi[a] : lo[a]) - oo[a]) / dd[a];
    if (t < t_exit) {
      t_exit = t;
      axis = a;
      positive_side = dd[a] > 0;
    }
  }
  // Nearest lamp in front of the wall.
  double best = t_exit;
  const RoomLamp* hit_lamp = nullptr;
  for (const RoomLamp& lamp : room.lamps) {
    const Vec3 oc = o - lamp.position;
    const double b = dot(oc, d), c = dot(oc, oc) - lamp.radius * lamp.radius;
    const double disc = b * b - c;
    if (disc < 0) continue;
    const double t = -b - std::sqrt(disc);
    if (t > 0 && t < best) {
      best = t;
      hit_lamp = &lamp;
    }
  }
  if (hit_lamp) return emitter_radiance(hit_lamp->luminance, hit_lamp->cct_k);
  const Vec3 h = o + t_exit * d;
  if (room.window && axis == 0 && !positive_side) {
    const RoomWindow& w = *room.window;
    if (h.y >= w.y0 && h.y <= w.y1 && h.z >= w.z0 && h.z <= w.z1) return emitter_radiance(w.luminance, w.cct_k);
  }
  Vec3 n{0, 0, 0};
  double albedo = room.wall_albedo;
  if (axis == 0) n.x = positive_side ? -1 : 1;
  if (axis == 1) n.y = positive_side ? -1 : 1;
  if (axis == 2) {
    n.z = positive_side ? -1 : 1;
    albedo = positive_side ? room.ceiling_albedo : room.floor_albedo;
  }
  auto e = direct_irradiance(room, h, n);
  for (double& c : e) c *= albedo / M_PI;
  return e;
}

EnvMap render_room_probe(const Room& room, Vec3 p, int width, int samples) {
  if (samples < 1) throw InputError("probe samples must be >= 1");
  EnvMap map = make_latlong(width, width / 2);
  const int w = map.width, h = map.height;
  tbb::parallel_for(0, h, [&](int v) {
    const double c0 = std::cos(M_PI * v / h), c1 = std::cos(M_PI * (v + 1) / h);
    for (int u = 0; u < w; ++u) {
      std::array<double, 3> sum{0, 0, 0};
      for (int a = 0; a < samples; ++a)
        for (int b = 0; b < samples; ++b) {
          const double phi = 2 * M_PI * (u + (a + 0.5) / samples) / w;
          const double theta = std::acos(c0 + (b + 0.5) / samples * (c1 - c0));  // even in solid angle
          const auto l = room_radiance(room, p, direction_from_angles(theta, phi));
          for (int c = 0; c < 3; ++c) sum[c] += l[c];
        }
      float* px = map.pixel(size_t(v) * w + u);
      for (int c = 0; c < 3; ++c) px[c] = float(sum[c] / (samples * samples));
    }
  });
  map.units = Units::Radiance;
  return map;
}

CameraRender render_camera_frame(const Room& room, Vec3 p, Vec3 view, const WalkthroughOptions& o) {
  view = normalize(view);
  Vec3 right, up;
  camera_basis(view, &right, &up);
  const int nx = std::max(2, o.rays_x), ny = std::max(2, o.rays_x * 3 / 4);
  const double tx = std::tan(o.fov_deg * M_PI / 360), ty = tx * ny / nx;
  std::vector<std::array<double, 3>> rays;
  rays.reserve(size_t(nx) * ny);
  std::array<double, 3> mean{0, 0, 0};
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double sx = (2 * (i + 0.5) / nx - 1) * tx, sy = (1 - 2 * (j + 0.5) / ny) * ty;
      const auto l = room_radiance(room, p, normalize(view + sx * right + sy * up));
      rays.push_back(l);
      for (int c = 0; c < 3; ++c) mean[c] += l[c];
    }
  for (double& c : mean) c /= double(rays.size());

  // Relative units of the camera: code / (t g) = 683 L / k per channel.
  const MeteringOptions& cam = o.camera;
  const double k = cam.photometric_scale.value_or(1.0);
  const double y_rel = kEfficacy * luminance(mean.data()) / k;
  CameraRender r;
  r.true_luminance = kEfficacy * luminance(mean.data());
  // Auto exposure: exposure first, then gain in 0.1 dB steps.
  const double product = cam.ae_target / std::max(y_rel, 1e-12);
  const double t = std::clamp(product, o.t_min, o.t_max);
  const double g = std::clamp(product / t, 1.0, o.gain_max);
  const double gain_db = std::round(200.0 * std::log10(g)) / 10.0;
  const double g_q = std::pow(10.0, gain_db / 20);
  FrameMetadata& m = r.metadata;
  m.exposure_s = t;
  m.gain_db = gain_db;
  m.f_number = cam.f_number;
  if (o.record_mean_code) m.mean_code = std::min(1.0, y_rel * t * g_q);
  m.wb_gains = wb_gains_for_illuminant(mean);
  if (o.record_bright_rgb) {
    std::sort(rays.begin(), rays.end(),
              [](const auto& a, const auto& b) { return luminance(a.data()) > luminance(b.data()); });
    const size_t n = std::max<size_t>(1, rays.size() / 20);
    std::array<double, 3> bright{0, 0, 0};
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) bright[c] += std::min(1.0, kEfficacy * rays[i][c] / k * t * g_q) / double(n);
    m.bright_rgb = bright;
  }
  return r;
}

std::vector<PathPoint> walkthrough_path(const Room& room, const WalkthroughOptions& o) {
  if (!(o.speed > 0) || !(o.fps > 0) || !(o.row_spacing > 0) || !(o.margin >= 0) ||
      2 * o.margin >= std::min(room.width, room.depth))
    throw InputError("walk-through: speed, fps and row spacing must be positive and the margin leave a floor");
  // Waypoints of the serpentine.
  std::vector<Vec3> way;
  // Rows evenly spaced from margin to depth - margin, no further apart than row_spacing.
  const double x0 = o.margin, x1 = room.width - o.margin;
  const double span = room.depth - 2 * o.margin;
  const int rows = 1 + int(std::ceil(span / o.row_spacing - 1e-9));
  for (int row = 0; row < rows; ++row) {
    const double y = o.margin + span * row / std::max(1, rows - 1);
    way.push_back({row % 2 ? x1 : x0, y, o.eye_height});
    way.push_back({row % 2 ? x0 : x1, y, o.eye_height});
  }
  std::vector<PathPoint> path;
  const double step = o.speed / o.fps;
  double time = 0;
  for (size_t i = 0; i + 1 < way.size(); ++i) {
    const Vec3 a = way[i], b = way[i + 1];
    const double len = length(b - a);
    const Vec3 dir = (1 / len) * (b - a);
    const double heading = std::atan2(dir.y, dir.x);
    for (double s = 0; s < len; s += step, time += 1 / o.fps) {
      const double yaw = heading + 70.0 * M_PI / 180 * std::sin(2 * M_PI * time / 4.0);
      const double pitch = (10.0 + 50.0 * std::sin(2 * M_PI * time / 5.3)) * M_PI / 180;
      PathPoint p;
      p.position = a + s * dir;
      p.view = {std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch)};
      p.timestamp = time;
      path.push_back(p);
    }
  }
  return path;
}

namespace {

Track track_along(const Room& room, const WalkthroughOptions& o, const std::vector<PathPoint>& path) {
  Track track;
  track.has_camera = true;
  track.camera = o.camera;
  track.frames.resize(path.size());
  tbb::parallel_for(size_t(0), path.size(), [&](size_t i) {
    TrackFrame& f = track.frames[i];
    f.frame = int64_t(i);
    f.timestamp = path[i].timestamp;
    f.position = path[i].position;
    f.view_direction = path[i].view;
    f.metadata = render_camera_frame(room, path[i].position, path[i].view, o).metadata;
  });
  return track;
}

}  // namespace

Track make_walkthrough_track(const Room& room, const WalkthroughOptions& o) {
  return track_along(room, o, walkthrough_path(room, o));
}

Track make_standing_track(const Room& room, const WalkthroughOptions& o, Vec3 point) {
  auto path = walkthrough_path(room, o);
  for (PathPoint& p : path) p.position = point;
  return track_along(room, o, path);
}

std::vector<Vec3> walkthrough_query_points(const Room& room, const WalkthroughOptions& o) {
  std::vector<Vec3> q;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i) q.push_back({room.width * (i + 0.5) / 3, room.depth * (j + 0.5) / 2, o.eye_height});
  return q;
}

std::vector<Light> bipyramid_lights_of_map(const EnvMap& map) {
  std::array<std::array<double, 3>, kBipyramidSectors> power{};
  std::array<double, kBipyramidSectors> solid{};
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    if (!map.is_valid(i)) continue;
    const int s = bipyramid_sector(pixel_direction(map, i));
    const double dw = pixel_solid_angle(map, i);
    for (int c = 0; c < 3; ++c) power[s][c] += map.pixel(i)[c] * dw;
    solid[s] += dw;
  }
  std::vector<Light> lights;
  for (int s = 0; s < kBipyramidSectors; ++s) {
    if (solid[s] <= 0) continue;
    Light l;
    l.id = uint64_t(s);
    l.direction = bipyramid_direction(s);
    l.rgb = power[s];
    l.solid_angle = solid[s];
    lights.push_back(l);
  }
  return lights;
}

namespace {

nlohmann::json room_json(const Room& room) {
  nlohmann::json lamps = nlohmann::json::array();
  for (const RoomLamp& l : room.lamps)
    lamps.push_back({{"position", {l.position.x, l.position.y, l.position.z}}, {"radius", l.radius}, {"luminance", l.luminance}, {"cct", l.cct_k}});
  nlohmann::json j{{"width", room.width}, {"depth", room.depth}, {"height", room.height},
                   {"albedo", {{"floor", room.floor_albedo}, {"walls", room.wall_albedo}, {"ceiling", room.ceiling_albedo}}},
                   {"lamps", lamps}};
  if (room.window)
    j["window"] = {{"wall", "x=0"}, {"y", {room.window->y0, room.window->y1}}, {"z", {room.window->z0, room.window->z1}},
                   {"luminance", room.window->luminance}, {"cct", room.window->cct_k}};
  return j;
}

}  // namespace

WalkthroughFiles write_walkthrough(const std::string& dir, const Room& room, const WalkthroughOptions& o,
                                   int probe_size, int samples, const std::function<void()>& probe_done) {
  namespace fs = std::filesystem;
  const Track track = make_walkthrough_track(room, o);
  make_output_directory((fs::path(dir) / "probes").string());
  WalkthroughFiles files;
  files.track_path = (fs::path(dir) / "track.jsonl").string();
  write_file_atomically(files.track_path, track_to_jsonl(track));
  const auto queries = walkthrough_query_points(room, o);
  nlohmann::json jq = nlohmann::json::array();
  for (size_t i = 0; i < queries.size(); ++i) {
    const EnvMap probe = render_room_probe(room, queries[i], probe_size, samples);
    const std::string rel = fmt::format("probes/q{}.exr", i);
    write_envmap((fs::path(dir) / rel).string(), probe);
    const std::string standing = fmt::format("probes/q{}_standing.jsonl", i);
    write_file_atomically((fs::path(dir) / standing).string(), track_to_jsonl(make_standing_track(room, o, queries[i])));
    jq.push_back({{"name", fmt::format("q{}", i)},
                  {"position", {queries[i].x, queries[i].y, queries[i].z}},
                  {"probe", rel},
                  {"standing_track", standing},
                  {"illuminance_up_lux", 683.0 * map_irradiance(probe, {0, 0, 1})}});
    if (probe_done) probe_done();
  }
  const nlohmann::json truth{{"format", "lightprobe.walkthrough/1"},
                             {"units", "radiance"},
                             {"room", room_json(room)},
                             {"frames", track.frames.size()},
                             {"fps", o.fps},
                             {"fov_deg", o.fov_deg},
                             {"eye_height", o.eye_height},
                             {"camera", metering_json(o.camera)},
                             {"queries", jq}};
  files.truth_path = (fs::path(dir) / "truth.json").string();
  write_file_atomically(files.truth_path, truth.dump(2) + "\n");
  files.frames = track.frames.size();
  files.queries = queries.size();
  files.duration_s = track.frames.back().timestamp;
  return files;
}

}  // namespace lp
