// The walk-through scene: a room with several lights over a floor, seen by a head-mounted
// camera walking a path (rendered as per-frame metadata, through the photometric model of
// estimate/exposure_metering.h) and by true probes at query points. Ground truth for the
// probe-less lighting model.
//
// Room: the box [0, width] x [0, depth] x [0, height] (metres, +Z up), grey Lambertian
// floor, walls and ceiling; spherical lamps (uniform luminance, black-body colour) and a
// window on the wall x = 0 (uniform luminance, daylight colour). Surfaces are lit by one
// bounce of direct light and nothing else (no inter-reflection; the room is convex and the
// lights sit inside it, so nothing is shadowed). The window's light on a surface is
// integrated over 8 x 8 patches; a lamp is a point source of intensity L pi r^2.
// Radiance is in W sr^-1 m^-2 per channel (CONVENTIONS: 683 Y = cd m^-2), units Radiance.
//
// Camera: a pinhole with a horizontal field of view, 4:3, sampled by a grid of rays; its
// auto exposure brings the mean code value to the target: t g = Y_target / Y_rel with
// Y_rel = 683 Y / k (k the camera's photometric scale), exposure first (up to 1/30 s),
// then gain (1..16, in 0.1 dB steps); its auto white balance is grey-world (gains G/R, 1,
// G/B of the frame's mean raw RGB).
// Path: a serpentine over the floor (rows at most `row_spacing` apart, `margin` from the walls) at
// walking speed, the head turning (yaw +-70 deg around the heading, 4 s period) and nodding
// (pitch -40..+60 deg, 5.3 s period) so that every sector gets looked at.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/light_list.h"
#include "core/vec3.h"
#include "estimate/exposure_metering.h"
#include "estimate/metadata_track.h"

namespace lp {

struct RoomLamp {
  Vec3 position;
  double radius = 0.1;         // m
  double luminance = 30000;    // cd m^-2 of the globe's surface
  double cct_k = 2700;
};

struct RoomWindow {  // on the wall x = 0, facing +X
  double y0 = 2.0, y1 = 4.5, z0 = 0.9, z1 = 2.4;
  double luminance = 1000;     // cd m^-2
  double cct_k = 6500;
};

struct Room {
  double width = 8, depth = 6, height = 3;  // x, y, z extents
  double floor_albedo = 0.3, wall_albedo = 0.6, ceiling_albedo = 0.8;
  std::vector<RoomLamp> lamps;
  std::optional<RoomWindow> window;
};
// Three lamps of different colour temperature and power at 2.5 m and a window.
Room default_room();

// Radiance arriving at `origin` from direction `direction` (unit), W sr^-1 m^-2 per channel.
std::array<double, 3> room_radiance(const Room& room, Vec3 origin, Vec3 direction);
// The true probe at a point: a latlong map (width = 2 height), each pixel the average of
// samples x samples rays spread evenly in solid angle. Units Radiance.
EnvMap render_room_probe(const Room& room, Vec3 position, int width, int samples = 4);

// The synthetic camera: f/2, ISO 100 at gain 1, AE target 0.18, K = 12.5, and the
// photometric scale k = K N^2 / (S_base Y_target) = 2.78 that makes both metering routes agree.
MeteringOptions walkthrough_camera();

struct WalkthroughOptions {
  double eye_height = 1.6;     // m, camera and query points
  double speed = 0.7;          // m/s
  double fps = 10;
  double margin = 0.7;         // m from the walls
  double row_spacing = 1.2;    // m between serpentine rows
  double fov_deg = 60;         // horizontal
  int rays_x = 16;             // camera rays across (rays_x * 3/4 down)
  MeteringOptions camera = walkthrough_camera();
  double t_min = 1.0 / 8000, t_max = 1.0 / 30, gain_max = 16;
  bool record_mean_code = true;
  bool record_bright_rgb = false;  // brightest 5 % of rays, clipped at code 1
};

// One frame of the synthetic camera: the metadata it reports and the truth it saw.
struct CameraRender {
  FrameMetadata metadata;
  double true_luminance = 0;  // mean over the frame, cd m^-2
};
CameraRender render_camera_frame(const Room& room, Vec3 position, Vec3 view, const WalkthroughOptions& options);

// The path: positions (z = eye height) and view directions, one per frame.
struct PathPoint {
  Vec3 position, view;
  double timestamp = 0;
};
std::vector<PathPoint> walkthrough_path(const Room& room, const WalkthroughOptions& options);
// Track of the whole path (camera header included).
Track make_walkthrough_track(const Room& room, const WalkthroughOptions& options);
// The same head motion (view directions, timing) but every frame taken standing at `point`:
// separates the error of metering from views (what this track's model gets at `point`)
// from the error of being elsewhere (what the walked track's model gets there).
Track make_standing_track(const Room& room, const WalkthroughOptions& options, Vec3 point);
// Query points: a 3 x 2 grid over the floor at eye height.
std::vector<Vec3> walkthrough_query_points(const Room& room, const WalkthroughOptions& options);

// The best six lights a bipyramid node could hold at a point: the true map's mean radiance
// over each sector (sector of each pixel's direction), at the sector directions. Separates
// the error of the six-direction representation from the error of metering and space.
std::vector<Light> bipyramid_lights_of_map(const EnvMap& map);

// A walk written for `eval metadata` into `dir` (created): track.jsonl, the true probes
// at the query points (probes/qN.exr, probe_size wide, `samples` rays per pixel edge)
// with a standing track each (probes/qN_standing.jsonl), and truth.json (room, camera,
// query points with their true illuminance). `probe_done` is called after each probe.
struct WalkthroughFiles {
  std::string track_path, truth_path;
  size_t frames = 0, queries = 0;
  double duration_s = 0;  // of the walk
};
WalkthroughFiles write_walkthrough(const std::string& dir, const Room& room, const WalkthroughOptions& options,
                                   int probe_size, int samples, const std::function<void()>& probe_done = {});

}  // namespace lp
