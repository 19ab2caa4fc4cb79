#include "live/pipeline.h"

#include "live/bracket_unwrap.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <iterator>

#include "core/chromaticities.h"
#include "core/error.h"
#include "core/warnings.h"
#include "hdr/bracket.h"
#include "hdr/merge.h"
#include "probe/camera_codes.h"
#include "probe/camera_unwrap.h"
#include "probe/fisheye.h"
#include "probe/remap.h"

namespace lp {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
}  // namespace

// The stages a bracket can pass through, in the order /metrics lists them.
constexpr const char* kStages[] = {"fuse", "unwrap", "fuse_unwrap", "sample", "sh9", "publish"};
constexpr size_t kStageCount = std::size(kStages);

struct LivePipeline::Timings {
  double stage[kStageCount] = {NAN, NAN, NAN, NAN, NAN, NAN};  // as kStages; NaN: not run for this bracket
  double latency = NAN;
};

struct LivePipeline::Bracket {
  std::vector<CameraFrame> frames;
  Clock::time_point captured;
};

struct LivePipeline::RemapCache {
  int width = 0, height = 0;
  CompiledRemap compiled;
  BracketUnwrapPlan plan;  // over `compiled`
  FuseUnwrapWorkspace fuse;  // buffers reused from bracket to bracket
  RgbImage out;
  std::vector<float> vignetting_gain;  // per map pixel, 1 / V where it is read; empty: none
};

LivePipeline::LivePipeline(OpenSource open, LivePipelineOptions options, Publish publish)
    : open_(std::move(open)), options_(std::move(options)), publish_(std::move(publish)) {
  if (options_.queue_brackets < 1) throw InputError("the bracket queue needs room for at least one bracket");
  for (const char* stage : kStages) stages_.emplace_back(stage, Histogram(latency_buckets_seconds()));
  sampler_ = std::make_unique<FramePipeline>(options_.sampling);
  // Auto-bracketing always fuses brackets of 2 or more frames (its first is 3).
  const size_t exposures = options_.auto_exposures ? std::max<size_t>(options_.exposure_cycle.size(), 2)
                                                   : options_.exposure_cycle.size();
  decode_ = plan_frame_decode({options_.photometric ? &*options_.photometric : nullptr, options_.photometric_file,
                               exposures, options_.response.has_value(), options_.frames_are_maps});
  stats_.auto_exposures = options_.auto_exposures;
  stats_.decode = to_string(decode_);
  stats_.auto_count = options_.sampling.auto_count;
  stats_.count_target = options_.sampling.auto_count ? options_.sampling.auto_options.target_error : 0;
  stats_.count_measure = to_string(options_.sampling.auto_options.measure);
  stats_.count_budget_ms = options_.sampling.budget.budget_ms;
}

LivePipeline::~LivePipeline() { stop(); }

void LivePipeline::start() {
  if (running_) return;
  source_ = open_();
  cycle_ = options_.exposure_cycle;
  if (options_.auto_exposures) {
    const std::optional<ExposureRange> range = source_->exposure_range();
    if (!range)
      throw InputError(source_->describe() +
                       ": cannot set its exposure, so it cannot auto-bracket (replay, video, V4L2 and libcamera "
                       "sources deliver what they are given); give exposure times instead");
    if (!(range->max_seconds > range->min_seconds * 1.01))
      throw InputError(fmt::format("{}: its exposure range is one time ({:g} s), so it cannot bracket",
                                   source_->describe(), range->min_seconds));
    const ExposureLimits limits{range->min_seconds, range->max_seconds, options_.auto_max_exposures, 2};
    const CameraResponse response = options_.response ? *options_.response : linear_response(256);
    planner_ = std::make_unique<AutoBracketPlanner>(usable_exposure_window(response, options_.auto_bracket.codes),
                                                    limits, options_.auto_bracket);
    if (cycle_.empty()) cycle_ = auto_first_bracket(*range);
  }
  if (!cycle_.empty()) source_->set_exposure_cycle(cycle_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.exposures = cycle_;
  }
  running_ = true;
  capture_done_ = false;
  processing_done_ = false;
  capture_ = std::thread([this] { capture_loop(); });
  processor_ = std::thread([this] { process_loop(); });
}

void LivePipeline::stop() {
  running_ = false;
  cv_.notify_all();
  if (capture_.joinable()) capture_.join();
  if (processor_.joinable()) processor_.join();
  // Brackets still waiting at shutdown are accounted for as dropped.
  std::lock_guard<std::mutex> lock(mutex_);
  stats_.brackets_dropped += queue_.size();
  queue_.clear();
}

void LivePipeline::wait() {
  if (capture_.joinable()) capture_.join();
  if (processor_.joinable()) processor_.join();
  running_ = false;
}

LiveStats LivePipeline::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

std::string LivePipeline::metrics() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const LiveStats& s = stats_;
  MetricsText m;
  m.counter("lightprobe_frames_in_total", "Frames received from the camera.", double(s.frames_in));
  m.counter("lightprobe_frames_dropped_partial_total", "Frames dropped because their bracket was incomplete.",
            double(s.frames_dropped_partial));
  m.counter("lightprobe_brackets_dropped_total", "Whole brackets dropped because the back end was busy.",
            double(s.brackets_dropped));
  m.counter("lightprobe_brackets_processed_total", "Brackets turned into published light lists.",
            double(s.brackets_processed));
  m.counter("lightprobe_camera_reconnects_total", "Times the camera was reopened.", double(s.reconnects));
  m.gauge("lightprobe_lights", "Lights of the last list, before clustering (--n auto: chosen per frame).", s.lights);
  m.counter("lightprobe_light_count_changes_total", "Times --n auto changed the light count.", double(s.count_changes));
  if (s.auto_count) {
    m.gauge("lightprobe_light_error", "--n auto: the last list's error in the target's measure.", s.count_error);
    m.gauge("lightprobe_light_error_target", "--n auto: the error the count is chosen to stay within.", s.count_target);
  }
  if (s.count_budget_ms > 0) {
    m.gauge("lightprobe_light_budget_cap", "--frame-budget-ms: the most lights the budget allows the next frame.",
            double(s.count_budget_cap));
    m.gauge("lightprobe_light_budget_limited", "--frame-budget-ms: 1 when the budget placed fewer lights than the target asked.",
            s.count_budget_limited ? 1.0 : 0.0);
  }
  if (!s.exposures.empty()) {
    m.gauge("lightprobe_bracket_exposures", "Exposures in the bracket the camera cycles.", double(s.exposures.size()));
    m.family("lightprobe_bracket_exposure_seconds", "gauge", "Exposure times of the bracket, shortest first (index).");
    std::vector<double> sorted = s.exposures;
    std::sort(sorted.begin(), sorted.end());
    for (size_t i = 0; i < sorted.size(); ++i)
      m.sample("lightprobe_bracket_exposure_seconds", sorted[i], fmt::format("index=\"{}\"", i));
  }
  if (s.auto_exposures) {
    const BracketPlan& p = s.bracket_plan;
    m.gauge("lightprobe_bracket_scene_stops", "--exposures auto: the metered scene's range, stops.", p.scene_stops);
    m.gauge("lightprobe_bracket_covered_ratio", "--exposures auto: metered pixels the bracket covers.",
            p.covered_fraction);
    m.gauge("lightprobe_bracket_camera_limited",
            "--exposures auto: 1 when the camera's limits leave an end of the scene uncovered (/status bracket.limit).",
            p.limit == BracketLimit::None ? 0 : 1);
    m.counter("lightprobe_bracket_changes_total", "--exposures auto: times the planner changed the bracket.",
              double(s.bracket_changes));
  }
  m.family("lightprobe_stage_duration_seconds", "histogram",
           "Time of each processing stage per published list (fuse_unwrap: bracket fusion and unwrap in one pass).");
  for (const auto& [stage, h] : stages_)
    m.histogram("lightprobe_stage_duration_seconds", h, "stage=\"" + prometheus_label_value(stage) + "\"");
  m.family("lightprobe_latency_seconds", "histogram", "Last frame of a bracket captured to its light list published.");
  m.histogram("lightprobe_latency_seconds", latency_);
  return m.text();
}

void LivePipeline::capture_loop() {
  size_t cycle = std::max<size_t>(1, cycle_.size());
  std::unique_ptr<Bracket> current;
  while (running_) {
    std::optional<CameraFrame> frame;
    try {
      std::vector<double> next_cycle;  // a new plan of the auto-bracketing, from the process thread
      {
        std::lock_guard<std::mutex> lock(mutex_);
        next_cycle.swap(pending_cycle_);
      }
      if (!next_cycle.empty()) {
        source_->set_exposure_cycle(next_cycle);
        cycle_ = std::move(next_cycle);
        cycle = cycle_.size();
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.exposures = cycle_;
        if (current) stats_.frames_dropped_partial += current->frames.size();  // taken at the old times
        current.reset();
      }
      frame = source_->next(0.2);
    } catch (const InputError& e) {
      // A frame that is bad input (a replay file that cannot be read): no reconnect
      // would fix it, so capture ends and the command refuses it.
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.input_error = stats_.last_error = e.what();
      break;
    } catch (const std::exception& e) {
      // The camera went away: keep the stream alive and reopen it.
      {
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.last_error = e.what();
        if (current) stats_.frames_dropped_partial += current->frames.size();
      }
      current.reset();
      std::this_thread::sleep_for(std::chrono::duration<double>(options_.reconnect_delay_s));
      try {
        if (!source_->reconnect()) {
          source_ = open_();
          if (!cycle_.empty()) source_->set_exposure_cycle(cycle_);
        }
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.reconnects;
      } catch (const std::exception& e2) {
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.last_error = e2.what();
      }
      continue;
    }
    if (!frame) {
      if (source_->finished()) break;
      continue;
    }
    if (auto why = undecodable_frame(*frame, decode_)) {  // refused, never decoded as something else
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.input_error = stats_.last_error = *why;
      break;
    }
    if (!std::isfinite(frame->gain_db) && !gain_unit_warned_) {
      gain_unit_warned_ = true;
      warn(source_->describe() + ": the camera's gain is not in dB, so frames are divided by their exposure time "
           "only; keep the gain fixed (and calibrate at it)");
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.frames_in;
    }
    // Group into whole brackets: a frame out of order starts over (the partial bracket is
    // dropped and counted), so two brackets are never mixed.
    const int index = cycle == 1 ? 0 : frame->bracket_index;
    if (cycle > 1 && index < 0) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.frames_dropped_partial;
      // Frames that never carry a time of the cycle (a replay without its exposures.csv, or
      // of another bracket): every one was dropped and the stream served nothing, with exit 0.
      // Four cycles and eight frames: more than a camera's settling frames after its first writes.
      if (++unmatched_from_start_ >= 4 * cycle + 8 && !matched_once_ && stats_.input_error.empty())
        stats_.input_error = stats_.last_error =
            fmt::format("{}: {} frames in, none at an exposure time of the cycle {} (exposure {} s); a replay needs "
                        "its exposures.csv",
                        source_->describe(), unmatched_from_start_, fmt::join(cycle_, ","), frame->exposure_s);
      if (!stats_.input_error.empty()) break;
      continue;
    }
    matched_once_ = true;
    if (!current || int(current->frames.size()) != index) {
      if (current) {
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.frames_dropped_partial += current->frames.size();
      }
      current.reset();
      if (index != 0) {
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.frames_dropped_partial;
        continue;
      }
      current = std::make_unique<Bracket>();
      current->captured = Clock::now();
    }
    current->frames.push_back(std::move(*frame));
    current->captured = Clock::now();  // latency counts from the bracket's last frame
    if (current->frames.size() == cycle) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (queue_.size() >= options_.queue_brackets) {
        queue_.pop_front();  // the oldest waiting bracket: keep latency low
        ++stats_.brackets_dropped;
      }
      queue_.push_back(std::move(current));
      cv_.notify_one();
    }
  }
  if (current) {  // a bracket cut short by the end of the stream
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.frames_dropped_partial += current->frames.size();
  }
  capture_done_ = true;
  cv_.notify_all();
}

void LivePipeline::process_loop() {
  auto last = Clock::now();
  double fps = 0;
  while (true) {
    std::unique_ptr<Bracket> b;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return !queue_.empty() || !running_ || capture_done_; });
      if (queue_.empty()) {
        if (!running_ || capture_done_) break;
        continue;
      }
      b = std::move(queue_.front());
      queue_.pop_front();
    }
    try {
      const Timings t = process(*b);
      const double dt = std::chrono::duration<double>(Clock::now() - last).count();
      last = Clock::now();
      fps = fps == 0 ? 1 / std::max(dt, 1e-6) : 0.8 * fps + 0.2 / std::max(dt, 1e-6);
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.fps_out = fps;
      ++stats_.brackets_processed;
      stats_.fuse_ms = 1e3 * (std::isnan(t.stage[2]) ? t.stage[0] : t.stage[2]);
      stats_.unwrap_ms = std::isnan(t.stage[1]) ? 0 : 1e3 * t.stage[1];
      stats_.sample_ms = 1e3 * t.stage[3];
      stats_.capture_to_publish_ms = 1e3 * t.latency;
      const FrameCount& c = sampler_->last_count();  // the sampler lives on this thread
      stats_.count_changes += stats_.brackets_processed > 1 && c.count != stats_.lights;
      stats_.lights = c.count;
      stats_.count_error = c.automatic ? c.error : 0;
      stats_.count_reached = c.reached;
      stats_.count_budget_limited = c.budget_limited;
      stats_.count_budget_cap = c.budget_cap;
      for (size_t k = 0; k < stages_.size(); ++k) stages_[k].second.observe(t.stage[k]);
      latency_.observe(t.latency);
    } catch (const std::exception& e) {
      // A bracket the back end could not process is dropped whole, and counted so: every
      // frame in is processed, dropped or partial (the books balance, docs/live.md).
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.last_error = e.what();
      ++stats_.brackets_dropped;
      // Bad input from the start (a camera model for another sensor size, a map replay in
      // another layout): every bracket fails alike, and the stream served nothing with exit
      // 0. Three in a row before any succeeded end it as bad input; later failures (a scene
      // that changed) are dropped brackets, as before.
      const bool input = dynamic_cast<const InputError*>(&e) != nullptr;
      failed_from_start_ = input && stats_.brackets_processed == 0 ? failed_from_start_ + 1 : 0;
      if (failed_from_start_ >= 3 && stats_.input_error.empty()) stats_.input_error = e.what();
    }
  }
  {
    // A source that ended (a replay) before three failures, none processed and every bracket
    // bad input: the same end (a two-frame replay through a camera model of another sensor
    // ended with exit 0 having served nothing).
    std::lock_guard<std::mutex> lock(mutex_);
    if (stats_.brackets_processed == 0 && failed_from_start_ > 0 && stats_.input_error.empty())
      stats_.input_error = stats_.last_error;
  }
  processing_done_ = true;
}

void LivePipeline::plan_next_bracket(const MeteredScene& scene) {
  const bool changed = planner_->update(scene);
  std::lock_guard<std::mutex> lock(mutex_);
  stats_.bracket_plan = planner_->plan();
  stats_.bracket_decision = planner_->last_decision();
  stats_.bracket_changes = planner_->changes();
  if (changed) pending_cycle_ = planner_->plan().exposure_seconds;
}

std::vector<double> auto_first_bracket(const ExposureRange& range) {
  // Slide the decade-apart times into the range, then clamp what still sticks out.
  std::vector<double> times = kAutoFirstBracket;
  const double shift = times.front() < range.min_seconds  ? range.min_seconds / times.front()
                       : times.back() > range.max_seconds ? range.max_seconds / times.back()
                                                          : 1.0;
  for (double& t : times) t = std::clamp(t * shift, range.min_seconds, range.max_seconds);
  times.erase(std::unique(times.begin(), times.end()), times.end());
  return times;
}

void LivePipeline::ensure_remap(const RgbImage& frame) {
  const int width = frame.width, height = frame.height;
  if (remap_ && remap_->width == width && remap_->height == height) return;
  const CameraModel model =
      options_.camera ? *options_.camera : camera_model_from_fisheye(equidistant_fisheye(width, height, options_.fov_deg));
  if (model.width != width || model.height != height)
    throw InputError(fmt::format("{}camera model is for {}x{}, frames are {}x{}",
                                 options_.camera_file.empty() ? "" : options_.camera_file + ": ", model.width, model.height,
                                 width, height));
  if (options_.vignetting) check_vignetting_size(*options_.vignetting, width, height, options_.vignetting_file);
  remap_ = std::make_unique<RemapCache>();
  remap_->width = width;
  remap_->height = height;
  const Mat3 world_from_camera = options_.world_from_probe * upward_camera_world_from_camera();
  const bool lens_bounds = options_.camera && !options_.fov_given;
  const RemapTable table = camera_remap(model, world_from_camera, options_.layout, options_.width, options_.height,
                                        lens_bounds ? 0.0 : options_.fov_deg / 2,
                                        lens_bounds ? lens_image_circle(frame) : std::nullopt);
  // The falloff where each map pixel is read, once per frame size: a multiply per map pixel
  // (the same as correcting the frame, to the bilinear footprint's variation of V).
  if (options_.vignetting) remap_->vignetting_gain = inverse_vignetting_at(*options_.vignetting, table.src_x, table.src_y);
  remap_->compiled = compile_remap(table, width, height);
  remap_->plan = plan_bracket_unwrap(remap_->compiled);
}

LivePipeline::Timings LivePipeline::process(Bracket& b) {
  auto t0 = Clock::now();
  Timings timings;
  double& fuse_s = timings.stage[0];
  double& unwrap_s = timings.stage[1];
  auto map = std::make_shared<EnvMap>();
  *map = make_envmap(options_.layout, options_.width, options_.height);
  // Unwrapped here with this rotation (a replayed map was unwrapped elsewhere: none claimed).
  if (!options_.frames_are_maps) map->world_from_probe = options_.world_from_probe;
  // The bracket's frames (3 x 14.7 MB at 1280x960) are freed when this function returns,
  // after the list is published: unmapping their pages (and the TLB shootdowns of a
  // threaded process) sat between the fusion and the sampling, ~2 ms of the latency at
  // load 3.5 (bench Live_Latency, 6 interleaved pairs: mean 8.0 -> 5.2 ms).
  lp::Bracket hb;
  // A replayed probe fused with hdr fuse --vignetting: corrected again, its rim would come out
  // as much too bright as it was too dark.
  if (options_.vignetting && !b.frames.empty() && b.frames[0].image.vignetting_corrected)
    throw InputError(fmt::format("{}: the frames' vignetting is corrected already (hdr fuse --vignetting); --vignetting "
                                 "{} would divide it out twice",
                                 source_->describe(), options_.vignetting_file));
  if (options_.frames_are_maps) {
    RgbImage& radiance = b.frames[0].image;
    if (radiance.width != map->width || radiance.height != map->height)
      throw InputError(fmt::format("replayed map is {}x{}, the pipeline expects {}: with --maps, --layout and --size "
                                   "(or --nside) describe the maps replayed; nothing is resampled",
                                   radiance.width, radiance.height, describe_size(*map)));
    if (options_.photometric) apply_photometric(radiance, *options_.photometric);
    map->rgb = std::move(radiance.rgb);
    map->valid = std::move(radiance.valid);
    map->units = radiance.units;
    fuse_s = seconds_since(t0);
  } else if (b.frames.size() > 1) {
    // Fuse only the sensor pixels the unwrap reads (live/bracket_unwrap.h): the same map
    // as merging every pixel and unwrapping, for a tenth of the work at 1280x960.
    // The longest exposure shows the image circle best.
    ensure_remap(std::max_element(b.frames.begin(), b.frames.end(), [](const CameraFrame& x, const CameraFrame& y) {
                   return x.exposure_s < y.exposure_s;
                 })->image);
    // A map this small is cheaper on the calling thread than the wake-up of TBB workers,
    // which costs milliseconds when the cores are busy.
    const bool small = size_t(options_.width) * size_t(options_.height) <= 512 * 256;
    MergeOptions merge_options;
    merge_options.threads = small ? 1 : 0;
    RemapOptions ro;
    ro.threads = small ? 1 : 0;
    // Each frame's exposure at the first frame's gain: the times the planner sets. The map
    // is divided by that gain once planned (frame_exposure: radiance per unit gain).
    const double gain0 = frame_exposure(b.frames[0]) / (b.frames[0].exposure_s > 0 ? b.frames[0].exposure_s : 1.0);
    for (auto& f : b.frames) {
      // Fused at an exposure the camera did not report, a frame would be taken as 1 s.
      if (!(f.exposure_s > 0))
        throw InputError(fmt::format("{}: a bracket frame came back without its exposure time (read back {:g} s): the "
                                     "bracket cannot be fused",
                                     source_->describe(), f.exposure_s));
      const double t = frame_exposure(f) / gain0;
      // A camera asked for a time beyond its range takes its nearest (times below its
      // shortest), so two frames come back at one exposure: check_bracket refused each such
      // bracket and the stream served no light. The later frame of an exposure adds no
      // range and is left out, said once.
      if (std::find(hb.exposure_seconds.begin(), hb.exposure_seconds.end(), t) != hb.exposure_seconds.end()) {
        if (!repeated_exposure_warned_) {
          repeated_exposure_warned_ = true;
          warn(fmt::format("{}: two frames of a bracket came back at one exposure ({:g} s): the camera cannot take a "
                           "time it was asked for; each exposure is used once",
                           source_->describe(), f.exposure_s));
        }
        continue;
      }
      hb.exposure_seconds.push_back(t);
      hb.frames.push_back(std::move(f.image));
    }
    const CameraResponse response = options_.response ? *options_.response : linear_response(256);
    RgbImage radiance;
    try {
      radiance = fuse_and_unwrap(hb, response, merge_options, remap_->plan, ro, &remap_->fuse);
    } catch (const InputError&) {
      // Nothing well exposed (a first bracket far off the scene): the bracket is dropped,
      // but the planner still learns which way to go from its raw frames.
      if (planner_)
        plan_next_bracket(meter_unfusable_bracket(hb.frames, hb.exposure_seconds, response,
                                                  usable_exposure_window(response, options_.auto_bracket.codes)));
      throw;
    }
    if (planner_) plan_next_bracket(meter_image(radiance, hb.exposure_seconds));  // before any photometric scale
    if (gain0 != 1.0)
      for (float& v : radiance.rgb) v = float(v / gain0);
    if (options_.photometric) apply_photometric(radiance, *options_.photometric);
    map->rgb = std::move(radiance.rgb);
    map->valid = std::move(radiance.valid);
    map->units = radiance.units;
    timings.stage[2] = seconds_since(t0);  // fusion and unwrap in one pass
  } else {
    if (!response_table_) response_table_ = std::make_unique<CodeTable>();
    decode_single_frame(b.frames[0], decode_, options_.photometric ? &*options_.photometric : nullptr,
                        options_.response ? &*options_.response : nullptr, response_table_.get());
    RgbImage radiance = std::move(b.frames[0].image);
    fuse_s = seconds_since(t0);
    t0 = Clock::now();
    ensure_remap(radiance);
    apply_remap(radiance, remap_->compiled, &remap_->out);
    map->rgb = remap_->out.rgb;
    map->valid = remap_->out.valid;
    map->units = radiance.units;
    unwrap_s = seconds_since(t0);
  }

  if (remap_ && !options_.frames_are_maps && !remap_->vignetting_gain.empty()) {
    const std::vector<float>& gain = remap_->vignetting_gain;
    for (size_t i = 0; i < gain.size(); ++i)
      for (int c = 0; c < 3; ++c) map->rgb[3 * i + size_t(c)] *= gain[i];
    map->vignetting_corrected = true;
  }
  // Codes of another colour space (Display P3, Adobe RGB) to Rec. 709, as probe unwrap and
  // hdr fuse convert them.
  if (options_.to_rec709 && !options_.frames_are_maps) apply_colour_matrix(map->rgb, *options_.to_rec709);

  // 3. Lights, with the temporal processing of the stream.
  t0 = Clock::now();
  const double timestamp = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  LightList lights = sampler_->process(*map, published_++, timestamp);
  timings.stage[3] = seconds_since(t0);
  // 4. The map's SH9, once per frame for every consumer (/sh, the list, MQTT). It is the
  // map's, not a residual: the lights were sampled from the whole map, so the two are
  // alternatives. project_sh9 refuses what the sampler refused already (NaN, negative).
  if (options_.sh9) {
    t0 = Clock::now();
    lights.sh9 = project_sh9(*map);
    lights.sh9_content = Sh9Content::Map;
    timings.stage[4] = seconds_since(t0);
  }
  t0 = Clock::now();
  publish_(lights, map);
  timings.stage[5] = seconds_since(t0);
  timings.latency = seconds_since(b.captured);
  return timings;
}

}  // namespace lp
