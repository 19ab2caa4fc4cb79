// The live chain as threads with bounded queues:
//   capture (camera source; frames grouped into whole brackets)
//     -> [queue of brackets; when the back end is slower than the camera the OLDEST
//        waiting bracket is dropped, never part of one: brackets are never mixed]
//     -> process (HDR fusion or a single frame -> unwrap through a cached remap table
//        -> sampler + temporal filtering) -> publish(lights, map)
// Every frame is accounted for: processed, dropped in a partial bracket, or dropped with
// a whole bracket. A lost camera is reopened by the capture thread, and the stream goes on.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <array>
#include <optional>
#include <string>
#include <thread>

#include "calib/camera_model.h"
#include "calib/photometric.h"
#include "calib/vignetting.h"
#include "core/envmap.h"
#include "core/light_list.h"
#include "hdr/auto_bracket.h"
#include "hdr/response.h"
#include "live/frame_decode.h"
#include "live/metrics.h"
#include "probe/camera_source.h"
#include "sampling/frame_pipeline.h"

namespace lp {

struct LivePipelineOptions {
  // Bracketing: exposure times cycled by the camera; empty = single frames (a linear or
  // log sensor, or a replayed sequence of radiance maps).
  std::vector<double> exposure_cycle;
  // Auto-bracketing (--exposures auto, hdr/auto_bracket.h): each fused map meters the
  // scene and the planner picks the next brackets' times within the source's exposure
  // range (CameraSource::exposure_range; start() refuses a source without one).
  // exposure_cycle is the first bracket (empty: kAutoFirstBracket moved into the range).
  // At least 2 exposures: the live chain fuses brackets (a single frame is decoded
  // without the response, frame_decode.h).
  bool auto_exposures = false;
  AutoBracketOptions auto_bracket;
  int auto_max_exposures = 7;
  std::optional<CameraResponse> response;         // default: linear
  // Absolute units; a log-sensor curve decodes single frames (live/frame_decode.h: what
  // it refuses at start). The file is named in those refusals.
  std::optional<PhotometricCalibration> photometric;
  std::string photometric_file;
  // Probe geometry: a fisheye through `camera` (default: equidistant 180 deg over the
  // image's short side) looking up, turned by `world_from_probe`.
  std::optional<CameraModel> camera;
  std::string camera_file;  // where `camera` was read from, named in errors about it
  // The lens's vignetting (calib/vignetting.h): each map pixel is multiplied by 1 / V where
  // the unwrap read it (frames of another size are refused, naming vignetting_file).
  std::optional<VignettingModel> vignetting;
  std::string vignetting_file;
  double fov_deg = 180;
  // With `camera`: whether fov_deg was given. Without it the calibrated model's own domain
  // is bounded by the image circle found in the first frame (probe unwrap's rule), not by
  // 180 deg, which cut a 190 deg lens and kept a 150 deg lens's black surround.
  bool fov_given = false;
  Mat3 world_from_probe{};
  // The frames' colours when they are codes of a colour space other than sRGB (a replayed
  // photo's matrix ICC profile, hdr/bracket.h read_colour_profile): linear values in it to
  // Rec. 709, row-major, applied to each unwrapped map. Empty: sRGB.
  std::optional<std::array<double, 9>> to_rec709;
  // Input frames that are already environment maps (replayed .exr maps) skip unwrapping.
  bool frames_are_maps = false;
  Layout layout = Layout::Hemisphere;
  int width = 360, height = 90;
  FramePipelineOptions sampling;
  // Every list carries the SH9 of its map ("sh9", content "map": core/spherical_harmonics.h),
  // what /sh serves and engines light their ambient with. About 0.5 ms for a 360x90 map
  // (stage "sh9" in /metrics); off saves it for lists nobody reads SH from.
  bool sh9 = true;
  size_t queue_brackets = 2;        // brackets waiting for the back end
  double reconnect_delay_s = 0.5;
};

struct LiveStats {
  uint64_t frames_in = 0, frames_dropped_partial = 0, brackets_dropped = 0, brackets_processed = 0;
  uint64_t reconnects = 0;
  double fps_out = 0;                      // lists published per second (recent)
  double capture_to_publish_ms = 0;        // last frame of the bracket in -> its list published
  double fuse_ms = 0, unwrap_ms = 0, sample_ms = 0;  // last frame's stages (brackets: fuse_ms includes the unwrap)
  std::string last_error;
  std::string input_error;  // a frame was bad input (capture stopped there); empty: none
  std::string decode = "relative";  // how frames become radiance (frame_decode.h to_string)
  // The light count (--n N, or --n auto: the fewest within count_target, with hysteresis).
  int lights = 0;                   // of the last list, before clustering
  bool auto_count = false;
  double count_target = 0;          // auto: the error to stay within, in count_measure
  double count_error = 0;           // auto: the last count's error
  std::string count_measure = "diffuse";  // auto: sampling/auto_count.h to_string(ErrorMeasure)
  bool count_reached = true;        // auto: false when the largest count missed the target
  uint64_t count_changes = 0;       // auto: times the count changed after the first list
  double count_budget_ms = 0;       // --frame-budget-ms (0: none)
  bool count_budget_limited = false;  // the budget placed fewer lights than the target asked
  int count_budget_cap = 0;         // the most lights the budget allows the next frame
  // The bracket (--exposures LIST, or auto: the planner's latest plan and why).
  bool auto_exposures = false;
  std::vector<double> exposures;    // the times the camera cycles now
  BracketPlan bracket_plan;         // auto: the latest plan (reason, coverage, limit)
  std::string bracket_decision;     // auto: why the last map kept or changed it
  uint64_t bracket_changes = 0;     // auto: plan changes after the first
};

// The first bracket of --exposures auto before anything is metered: three exposures a
// decade apart (moved into the camera's range by auto_first_bracket).
inline const std::vector<double> kAutoFirstBracket{1e-4, 1e-3, 1e-2};
std::vector<double> auto_first_bracket(const ExposureRange& range);

class LivePipeline {
 public:
  using Publish = std::function<void(const LightList&, std::shared_ptr<const EnvMap>)>;
  using OpenSource = std::function<std::unique_ptr<CameraSource>()>;
  LivePipeline(OpenSource open, LivePipelineOptions options, Publish publish);
  ~LivePipeline();
  void start();
  void stop();
  // Blocks until the source is finished (replay without loop) and everything is processed.
  void wait();
  LiveStats stats() const;
  // The source has ended (a replay without --loop, or bad input) and every bracket it gave is
  // processed or dropped: nothing new will be published.
  bool finished() const { return processing_done_; }
  // Prometheus text: the counters of stats(), and histograms of every published list's
  // stage times (lightprobe_stage_duration_seconds{stage=fuse|unwrap|fuse_unwrap|sample|
  // sh9|publish}) and capture-to-publish latency (lightprobe_latency_seconds), in seconds.
  // The frame rate gauge comes from the light server (lightprobe_frame_rate_hertz).
  std::string metrics() const;

 private:
  struct Bracket;
  struct Timings;  // of one processed bracket, seconds
  void capture_loop();
  void process_loop();
  Timings process(Bracket& bracket);
  void ensure_remap(const RgbImage& frame);
  void plan_next_bracket(const MeteredScene& scene);  // compiles the unwrap table for this frame size

  OpenSource open_;
  LivePipelineOptions options_;
  Publish publish_;
  std::unique_ptr<CameraSource> source_;
  bool gain_unit_warned_ = false;  // a camera whose gain is not in dB, said once
  bool repeated_exposure_warned_ = false;  // a bracket frame at an exposure already in it, said once
  int failed_from_start_ = 0;      // brackets refused as bad input before any was processed
  size_t unmatched_from_start_ = 0;  // frames at no time of the cycle, before any was
  bool matched_once_ = false;
  std::thread capture_, processor_;
  std::atomic<bool> running_{false};
  std::atomic<bool> capture_done_{false};
  std::atomic<bool> processing_done_{false};
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::unique_ptr<Bracket>> queue_;
  LiveStats stats_;
  // Under mutex_, updated with brackets_processed: their counts equal it.
  Histogram latency_{latency_buckets_seconds()};
  std::vector<std::pair<std::string, Histogram>> stages_;
  std::unique_ptr<FramePipeline> sampler_;
  FrameDecode decode_ = FrameDecode::Relative;  // chosen from the options at construction
  // Unwrapping cache: rebuilt when the image size changes.
  struct RemapCache;
  std::unique_ptr<RemapCache> remap_;
  std::unique_ptr<CodeTable> response_table_;  // --response on single frames, per level (built once)
  int64_t published_ = 0;
  // Auto-bracketing: the planner lives on the process thread; a new plan waits in
  // pending_cycle_ (under mutex_) until the capture thread gives it to the source.
  std::unique_ptr<AutoBracketPlanner> planner_;
  std::vector<double> pending_cycle_;
  std::vector<double> cycle_;  // capture thread: what the source cycles
};

}  // namespace lp
