// stream --metadata-model: the probe-less mode fed live. Every frame of the source gives
// its exposure and gain (CameraFrame), and the frame itself gives what a camera's AE and
// AWB compute anyway: the mean code value (Y of the mean raw RGB) and grey-world
// white-balance gains. A fixed rig stands at --position looking along --view-dir (camera
// sources carry no tracker); the model is the quadtree of estimate/light_quadtree.h, saved
// every 30 frames and at the end, and the server serves its six lights at the position.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <chrono>
#include <thread>

#include "calib/photometric.h"
#include "cli/cmd_live.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "core/warnings.h"
#include "estimate/light_quadtree.h"
#include "live/light_server.h"
#include "probe/camera_source.h"

namespace lp::cli {

namespace {

// The metadata of one live frame; nullopt (and a reason) for frames that cannot be metered.
std::optional<FrameMetadata> frame_metadata(const CameraFrame& f, std::string* why) {
  if (!(f.exposure_s > 0)) {
    *why = "no exposure time";
    return std::nullopt;
  }
  double sum[3] = {0, 0, 0};
  const size_t n = f.image.rgb.size() / 3;
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) sum[c] += f.image.rgb[3 * i + c];
  if (n == 0 || !(sum[0] > 0 && sum[1] > 0 && sum[2] > 0)) {
    *why = "a black frame";
    return std::nullopt;
  }
  const std::array<double, 3> mean{sum[0] / n, sum[1] / n, sum[2] / n};
  const double y = 0.2126 * mean[0] + 0.7152 * mean[1] + 0.0722 * mean[2];
  if (y > 1) throw InputError("stream --metadata-model: frames must be camera code values in [0, 1], not radiance maps");
  FrameMetadata m;
  m.exposure_s = f.exposure_s;
  m.gain_db = f.gain_db;  // sources report 0 when the camera has no gain control
  m.mean_code = y;
  m.wb_gains = std::array<double, 3>{mean[1] / mean[0], 1.0, mean[1] / mean[2]};
  return m;
}

}  // namespace

int run_stream_metadata(const StreamArgs& args, const Output& out) {
  const auto pos = parse_numbers(args.position, "--position", 2);
  const auto view = parse_numbers(args.view_dir, "--view-dir", 3);
  const Vec3 v{view[0], view[1], view[2]};
  if (!(length(v) > 0)) throw InputError("--view-dir must not be zero");
  if (!(args.min_frames >= 1)) throw InputError(fmt::format("--min-frames must be >= 1, got {}", args.min_frames));
  MeteringOptions camera;  // the meter equation unless a photometric scale is given
  if (!args.photometric.empty()) {
    const PhotometricCalibration cal = load_photometric(args.photometric);
    if (cal.log_sensor) throw InputError(fmt::format("{}: a log-sensor calibration has no linear scale", args.photometric));
    camera.photometric_scale = cal.scale_luminance;
  }
  validate_metering(camera);
  QuadtreeOptions qo;
  qo.origin_x = pos[0];
  qo.origin_y = pos[1];
  qo.max_weight = 30;  // live: a sector follows the last ~30 frames, so light changes show
  LightQuadtree model(qo);

  SourceOptions so;
  so.loop = args.loop;
  so.frame_rate = args.fps;
  if (!args.exposures.empty()) so.exposure_cycle = parse_numbers(args.exposures, "--exposures");
  auto source = open_source(args.source, so);
  LightServerOptions server_options;
  {
    const auto colon = args.listen.rfind(':');
    if (colon == std::string::npos) throw InputError(fmt::format("--listen must be HOST:PORT, got '{}'", args.listen));
    server_options.host = args.listen.substr(0, colon);
    try {
      server_options.port = std::stoi(args.listen.substr(colon + 1));
    } catch (const std::exception&) {
      throw InputError(fmt::format("--listen: '{}' is not a port", args.listen.substr(colon + 1)));
    }
  }
  if (!args.token.empty()) server_options.token = args.token;
  LightServer server(server_options);
  const int port = server.start();
  say(out, "lightprobe stream (metadata): {} -> http://{}:{}/lights, model {}\n", source->describe(), server_options.host, port,
      args.metadata_model);
  std::fflush(stdout);
  defer_interrupts();  // a signal stops the loop below: the model is saved, the summary printed
  const auto start = std::chrono::steady_clock::now();
  uint64_t used = 0, skipped = 0;
  std::string last_skip;
  LightReading last{};
  bool gain_unit_warned = false;
  while (!interrupt_signal()) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (args.duration > 0 && elapsed >= args.duration) break;
    auto frame = source->next(0.5);
    if (!frame) {
      if (source->finished()) break;
      continue;
    }
    auto meta = frame_metadata(*frame, &last_skip);
    if (!meta) {
      ++skipped;
      continue;
    }
    if (!std::isfinite(frame->gain_db)) {  // a gain in the camera's own steps (GainRaw)
      if (!camera.photometric_scale)
        throw InputError(source->describe() + ": the camera's gain is not in dB, and the meter equation needs it; "
                         "give --photometric, calibrated at a fixed gain");
      if (!gain_unit_warned)
        warn(source->describe() + ": the camera's gain is not in dB: taken as the gain --photometric was calibrated at; keep it fixed");
      gain_unit_warned = true;
      meta->gain_db = 0.0;
    }
    last = meter_frame(*meta, camera, fmt::format("{} frame {}", args.source, frame->sequence));
    model.update(pos[0], pos[1], v, last, frame->sequence);
    LightList lights = model.lights_at(pos[0], pos[1], -1, args.min_frames);
    lights.frame = frame->sequence;
    lights.timestamp = frame->timestamp_s;
    server.publish(lights, nullptr);
    if (++used % 30 == 0) save_model(args.metadata_model, model);
  }
  save_model(args.metadata_model, model);
  server.stop();
  say(out, "stream stopped: {} frames metered, {} skipped{}; last {:.1f} cd/m2, {:.0f} lux, {:.0f} K\n", used, skipped,
      last_skip.empty() ? "" : " (" + last_skip + ")", last.luminance, last.illuminance, last.cct_k);
  emit_json(out, {{"port", port}, {"frames_used", used}, {"frames_skipped", skipped}, {"model", args.metadata_model},
                  {"last_luminance_cd_m2", last.luminance}, {"last_illuminance_lux", last.illuminance}, {"last_cct_k", last.cct_k}});
  return 0;
}

}  // namespace lp::cli
