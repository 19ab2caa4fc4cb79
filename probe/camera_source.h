// Camera sources: one interface for frames with their metadata, whatever delivers them.
//
// Specs accepted by open_source():
//   replay:DIR       images (.png .jpg .jpeg .tif .tiff: code values in [0, 1]) or radiance
//                    (.exr .hdr .pfm: float) in file-name order. Optional sidecars in DIR:
//                      exposures.csv   one exposure time in seconds per line, in file order,
//                                      or "name,seconds" lines (a non-numeric header is skipped)
//                      timestamps.txt  one timestamp in seconds per line, or "name seconds"
//                    Without timestamps: index / frame_rate when paced, else seconds since open.
//                    Pacing: at frame_rate when > 0, else at the recorded times when present
//                    (plain decimal seconds, strictly increasing: core/timestamps.h), else free.
//                    A frame file that cannot be read throws InputError (not CameraLost).
//   video:FILE       cv::VideoCapture on a file (8-bit, code values in [0, 1]); exposures from
//                    FILE's "<stem>.exposures.csv" or "exposures.csv" beside it (optional).
//   aravis           the first GenICam camera Aravis finds (GigE Vision, USB3 Vision).
//   aravis:ID        a camera by Aravis id, serial or IP address; "aravis:Fake_1" is Aravis'
//                    in-process fake camera (no network), painted with a synthetic fisheye
//                    sky probe whose brightness follows the exposure set: a simulated
//                    bracketing camera (see FakeScene).
//   libcamera        the first libcamera camera; libcamera:ID a camera by its id.
//   v4l2:N           /dev/videoN through cv::VideoCapture.
// An unknown spec, a missing directory/file or an absent camera throws InputError naming it.
//
// Exposure cycling (bracketing): set_exposure_cycle({t0, t1, t2}) makes the source take
// frames at t0, t1, t2, t0, ... Each frame carries the exposure it was really taken at,
// read back from the camera, and bracket_index = its position in the cycle. Aravis cameras
// without a sequencer cycle by writing the exposure feature between frames; frames whose read-back exposure is
// not the one expected (in flight while the feature changed) are dropped, so every delivered
// frame's exposure_s is trustworthy. Cameras with an SFNC sequencer cycle by themselves
// instead (SourceOptions::bracketing, probe/genicam_sequencer.h), losing no frame to the
// writes. Replay and video cannot change exposure: they only
// label frames whose recorded exposure matches a cycle entry (within 1 %).
//
// Thread safety: one thread per source; different sources may run on different threads.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/image_io.h"

namespace lp {

struct CameraFrame {
  // RGB, 3 floats per pixel: code values in [0, 1] for 8/12/16-bit sensors (linear in code,
  // no response applied; Bayer demosaiced, mono replicated to R=G=B), or float radiance
  // for EXR/HDR/PFM replay.
  RgbImage image;
  double timestamp_s = 0;   // camera clock when known, else host clock; monotonic per source
  double exposure_s = 0;    // exposure the frame was taken at; <= 0 unknown
  double gain_db = 0;       // analogue gain (0 when none; NaN when the camera states it in
                            // another unit than dB, e.g. GenICam's GainRaw steps)
  std::string pixel_format; // as the camera names it ("Mono8", "BayerRG16", "RGB8", "RGBFloat")
  int64_t sequence = 0;     // camera frame id (gaps = dropped frames) or replay index
  int bracket_index = -1;   // position in the exposure cycle, -1 none
};

// The camera went away (unplugged, link down, stream died). The pipeline may catch it and
// call reconnect() (Aravis) or reopen the source.
class CameraLost : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The exposure times a source can set, in seconds.
struct ExposureRange {
  double min_seconds = 0, max_seconds = 0;
};

struct FakeScene;

class CameraSource {
 public:
  // Inline, as every member: the class has no key function, so the camera plugin
  // (probe/camera_plugin.h) carries its own vtable and type info and needs no symbol of the
  // executable.
  virtual ~CameraSource() = default;
  // One line: kind, id, size and format, e.g. "aravis:Fake_1 (Aravis Fake, 512x512 Mono16)".
  virtual std::string describe() const = 0;
  // The next frame, waiting at most timeout_s; nullopt on timeout or at the end of a
  // non-looping replay (see finished()). Throws CameraLost / InputError when the camera
  // is gone.
  virtual std::optional<CameraFrame> next(double timeout_s) = 0;
  // Bracketing: cycle these exposure times (seconds, > 0) frame by frame; empty = fixed
  // exposure (the last one set stays). Throws InputError on non-positive times.
  virtual void set_exposure_cycle(const std::vector<double>& seconds) = 0;
  // The exposure times set_exposure_cycle can really take (auto-bracketing plans within
  // them), or nullopt when the source cannot set exposure: replay, video and V4L2 deliver
  // what was recorded, and libcamera's range is not read yet.
  virtual std::optional<ExposureRange> exposure_range() const { return std::nullopt; }
  // After CameraLost: reopen the same camera with the same settings. True when it is
  // back. Sources that cannot reconnect return false.
  virtual bool reconnect() { return false; }
  // True once a non-looping replay/video has delivered its last frame.
  virtual bool finished() const { return false; }
  // Aravis' fake camera: paint `scene` from the next frame on (see set_fake_scene).
  virtual bool set_fake_scene(const FakeScene&) { return false; }
};

// What the Aravis fake camera paints: an upward fisheye (equidistant, 180 deg across the
// image circle) of a sky with a sun. Radiance in relative units; the painted code value is
// radiance * exposure_s * 10^(gain_db / 20), clipped to the pixel format's range.
struct FakeScene {
  double circle_radius = 0.48;      // image circle radius as a fraction of min(width, height)
  double sky_zenith[3] = {20, 30, 60};    // sky radiance at the zenith, RGB
  double sky_horizon[3] = {60, 70, 80};   // at the horizon (linear blend in elevation)
  double sun_radiance[3] = {20000, 19000, 17000};
  double sun_elevation_deg = 50;
  double sun_azimuth_deg = 30;      // 0 = image right, counter-clockwise in the image
  double sun_radius_deg = 3;        // angular radius of the sun disc
};
// The scene as radiance (outside the image circle 0), width x height: the truth a merged
// bracket of the fake camera should reproduce.
RgbImage render_fake_scene(const FakeScene& scene, int width, int height);

struct SourceOptions {
  // replay / video
  bool loop = false;          // start over at the end
  double frame_rate = 0;      // replay/video: pace playback at this rate (0: a replay's recorded
                              // timestamps when it has them, else as fast as possible);
                              // cameras: acquisition frame rate if settable (0: keep)
  // cameras
  std::string pixel_format;   // "" keeps the camera's; Mono8, Mono12, Mono16, BayerRG8,
                              // BayerRG16, RGB8Packed, ... (Bayer is demosaiced)
  struct Roi {
    int x = 0, y = 0, width = 0, height = 0;
  };
  std::optional<Roi> roi;     // region of interest in sensor pixels
  std::optional<double> gain_db;
  std::optional<double> exposure_s;      // fixed exposure
  std::vector<double> exposure_cycle;    // bracketing from the first frame (overrides exposure_s)
  int n_buffers = 8;                     // stream buffers
  // Aravis: frames to drop after an exposure write when the camera cannot tell which
  // exposure a frame was taken at (no chunk data); 0 trusts the next frame.
  int exposure_settle_frames = 1;
  // Aravis bracketing: "auto" uses the camera's SFNC sequencer when it has one (the camera
  // switches exposure itself, no frame lost per switch) and per-frame exposure writes
  // otherwise; "sequencer" requires it; "writes" never uses it.
  std::string bracketing = "auto";
  // Aravis "aravis" without id: also search GigE Vision / USB3 Vision (discovery broadcasts
  // on every interface). False: only the in-process Fake interface.
  bool aravis_network = true;
  // The scene the Aravis fake camera paints.
  FakeScene fake_scene;
};

std::unique_ptr<CameraSource> open_source(const std::string& spec, const SourceOptions& options = {});

// Changes what an Aravis fake camera source paints from its next frame on. False when
// `source` is not one.
bool set_fake_scene(CameraSource& source, const FakeScene& scene);

}  // namespace lp
