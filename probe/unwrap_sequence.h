// `lightprobe probe unwrap` as one call: probe images (one, or a sequence of frames of
// one probe) -> environment maps in the world frame.
//   pass 1  each frame's geometry: the mirror ball (probe/mirror_ball.h find_ball, or the
//           ball given), or a fisheye sequence's image circle (probe/stabilise.h); the
//           track is smoothed when asked (a fixed probe whose detection is noisy), or
//           frame 0's geometry used for all (no stabilisation, for comparison)
//   pass 2  each frame (a camera image's codes made linear first) unwrapped with its own
//           geometry, so that the map stays put when the camera shakes; the optional
//           colour match to a backplate camera applied.
// Reports the map's stability: the power-weighted mean direction of each map, which a
// static world must keep still, and the detected and used tracks' jitter.
#pragma once

#include <array>
#include <nlohmann/json_fwd.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "calib/colour_match.h"
#include "calib/vignetting.h"
#include "core/envmap.h"
#include "probe/camera_codes.h"
#include "probe/camera_unwrap.h"
#include "probe/mirror_ball.h"
#include "probe/stabilise.h"

namespace lp {

enum class ProbeType { MirrorBall, Fisheye };

struct UnwrapSequenceOptions {
  ProbeType type = ProbeType::MirrorBall;
  Layout layout = Layout::LatLong;
  int width = 1024, height = 512;     // healpix: width = nside
  bool fill = false;                  // fill what the camera cannot see (mask kept)
  // Mirror ball.
  MirrorBallCamera ball_camera;
  std::optional<BallInImage> ball;    // instead of detection
  double blind_spot_deg = 15;
  // Fisheye: the calibrated model, or (nullopt) the equidistant model of
  // `fisheye_fov_deg` (180 when 0); fisheye_fov_deg also limits a calibrated model's
  // field to its image circle (0: no limit).
  std::optional<CameraModel> camera;
  double fisheye_fov_deg = 0;
  Mat3 world_from_probe;              // after CONVENTIONS.md's default orientation
  // Sequences.
  bool smooth_track = false;          // smooth the per-frame ball / image-circle track
  bool static_probe = false;          // with smooth_track: one median position for all
  bool fixed_geometry = false;        // frame 0's geometry for every frame
  // Mirror ball: each frame's search starts from the last frame's ball when that one's
  // silhouette fit held (the full search where the seeded fit agrees with the rim along
  // less than 0.9x the arc of the last full search's); false: every frame from scratch.
  bool seed_from_previous = true;
  // Frames are kept in memory between the two passes while all of them so far fit in this
  // many bytes; the rest are read again in pass 2.
  double kept_frames_bytes = 512e6;
  // Camera codes in a wide-gamut colour space (the files' ICC profile, hdr/bracket.h's
  // read_colour_profile): linear values in it to Rec. 709, row-major, applied before `colour`.
  std::optional<std::array<double, 9>> to_rec709;
  std::optional<ColourMatch> colour;  // 3x3 transform to the backplate camera
  // How camera images' codes encode light (probe/camera_codes.h), linearised before the
  // unwrap (the ball is found on the codes as read). nullopt: sRGB for 8-bit images, as JPEG
  // and PNG define them; 16-bit ones are refused, their encoding being a converter's choice
  // (linear from a raw developer, a gamma curve from an editor).
  std::optional<CodeCurve> codes;
  // The camera's lens vignetting (calib/vignetting.h, from `calib vignetting`), divided out of
  // every frame once it is radiance, before the unwrap; `vignetting_file` names it in errors.
  // A frame recorded as corrected already (a fused bracket of `hdr fuse --vignetting`) is
  // refused with it.
  std::optional<VignettingModel> vignetting;
  std::string vignetting_file;
};

struct UnwrapSequenceReport {
  struct Frame {
    std::string file;
    std::optional<BallInImage> ball, ball_detected;  // mirror ball: used, and as found
    // How it was found (confidence, whether sub-pixel, the fit's standard errors); nullopt
    // when the ball was given, or recorded in the file.
    bool ball_recorded = false;  // taken from the file (probe register records it), not searched
    std::optional<FindBallReport> ball_fit;
    bool ball_seeded = false;  // found by the search from the last frame's ball (else the full search)
    std::optional<ImageCircle> circle;               // fisheye sequence
    double valid_fraction = 0;                       // share of the map's solid angle that is valid
    std::string codes;             // the curve a camera image's codes went through; empty for radiance
    double clipped_fraction = 0;   // camera image: share of its pixels at the top code
  };
  std::vector<Frame> frames;
  CircleTrack detected, used;         // empty for a single fisheye image
  double fill_power_share = 0;        // of the last frame
  std::optional<double> map_jitter_deg;  // mean angle between consecutive maps' centroids
  double unwrap_seconds = 0;          // pass 2
};

// Unwraps every file in order and hands each map to `emit` (frame index, map); `step`
// is called after each frame of each pass (2 * files.size() calls). Throws InputError
// naming the file that cannot be read, has another size than frame 0, holds no ball, or
// unwraps to a map with no valid pixel (a ball or circle outside the image), before that
// frame is emitted.
UnwrapSequenceReport unwrap_probe_sequence(const std::vector<std::string>& files, const UnwrapSequenceOptions& options,
                                           const std::function<void(size_t frame, EnvMap& map)>& emit,
                                           const std::function<void()>& step = {});

}  // namespace lp
