// A recorded track: per frame, where the camera was, where it looked and what its
// metadata said. JSON Lines, one object per line; positions from any tracker, in metres,
// in the world frame of CONVENTIONS.md (+Z up, the floor is the XY plane).
//
// Optional first line, the camera (the same keys as MeteringOptions; CLI options override):
//   {"format": "lightprobe.track/1", "camera": {"photometric_scale": 2.78, "f_number": 2.0,
//    "calibration_f_number": 2.0, "ae_target": 0.18, "iso_base": 100, "meter_constant": 12.5,
//    "colour_matrix": [9 numbers, camera RGB -> Rec. 709, row-major]}}
// Frame lines (required: position, view_dir, exposure_s and one of gain_db / analog_gain /
// iso; the rest optional):
//   {"frame": 0, "timestamp": 0.1, "position": [x, y] or [x, y, z], "view_dir": [x, y, z],
//    "exposure_s": 0.01, "gain_db": 6.0, "analog_gain": 2.0, "digital_gain": 1.0,
//    "iso": 200, "f_number": 2.0, "wb_gains": [r, g, b], "cct": 5200,
//    "mean_code": 0.18, "bright_rgb": [r, g, b]}
// Blank lines and lines starting with '#' are skipped. Errors name the file and line:
// "track.jsonl:12: exposure_s must be finite and positive, got 0".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "estimate/exposure_metering.h"
#include "estimate/light_quadtree.h"

namespace lp {

struct TrackFrame {
  int64_t frame = 0;
  double timestamp = 0;
  Vec3 position;      // z optional (0)
  Vec3 view_direction;
  FrameMetadata metadata;
  std::string source;  // "track.jsonl:12" for messages
};

struct Track {
  bool has_camera = false;     // the header line was present
  MeteringOptions camera;      // from the header, else defaults
  std::vector<TrackFrame> frames;
};

// Reads and checks the structure (required keys, numbers, 3-vectors); metadata values are
// checked when metered (meter_frame), or all at once by validate_track.
Track read_track(const std::string& path);
// Meters every frame once, so that a bad line fails before any output is written.
void validate_track(const Track& track);
// The JSONL text of a track (header + frames), for synthetic tracks.
std::string track_to_jsonl(const Track& track);

// Feeds frames [0, count) into a new quadtree rooted at the first frame's position (or
// options' origin when `origin_from_first_frame` is false).
struct BuildModelOptions {
  QuadtreeOptions quadtree;
  bool origin_from_first_frame = true;
};
LightQuadtree build_model(const Track& track, const MeteringOptions& camera, const BuildModelOptions& options,
                          size_t count = SIZE_MAX);

}  // namespace lp
