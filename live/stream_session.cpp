#include "live/stream_session.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <memory>
#include <thread>

#include "core/interrupt.h"

namespace lp {

nlohmann::json light_count_json(const LiveStats& s) {
  nlohmann::json j{{"mode", s.auto_count ? "auto" : "fixed"}, {"lights", s.lights}};
  if (s.auto_count)
    j.update({{"measure", s.count_measure}, {"target_error", s.count_target}, {"error", s.count_error}, {"reached", s.count_reached},
              {"changes", s.count_changes}});
  if (s.count_budget_ms > 0)
    j.update({{"frame_budget_ms", s.count_budget_ms}, {"budget_cap", s.count_budget_cap},
              {"budget_limited", s.count_budget_limited}});
  return j;
}

nlohmann::json bracket_json(const LiveStats& s) {
  nlohmann::json j{{"mode", s.auto_exposures ? "auto" : s.exposures.empty() ? "single" : "fixed"},
                   {"exposure_seconds", s.exposures}};
  if (s.auto_exposures) {
    const BracketPlan& p = s.bracket_plan;
    j.update({{"reason", p.reason}, {"decision", s.bracket_decision}, {"scene_stops", p.scene_stops},
              {"covered_fraction", p.covered_fraction}, {"limit", to_string(p.limit)}, {"changes", s.bracket_changes}});
  }
  return j;
}

nlohmann::json pipeline_status_json(const LiveStats& s, const std::string& source, double seconds_since_frame,
                                    double quiet_s) {
  const bool streaming = seconds_since_frame < quiet_s;
  return {{"source", source},
          {"camera_state", streaming ? "streaming" : fmt::format("no frame for {:.0f} s", seconds_since_frame)},
          {"frames_in", s.frames_in},
          {"brackets_processed", s.brackets_processed},
          {"brackets_dropped", s.brackets_dropped},
          {"frames_dropped_partial", s.frames_dropped_partial},
          {"reconnects", s.reconnects},
          {"last_error", s.last_error}};
}

StreamSessionReport run_stream_session(const StreamSessionOptions& options, const std::function<void(int port)>& started) {
  LightServer server(options.server);
  std::unique_ptr<MqttPublisher> mqtt;
  if (!options.publish.empty()) mqtt = std::make_unique<MqttPublisher>(options.publish, options.publish_flag, options.mqtt);
  LivePipeline pipeline([&] { return open_source(options.source, options.source_options); }, options.pipeline,
                        [&](const LightList& lights, std::shared_ptr<const EnvMap> map) {
                          server.publish(lights, map);
                          if (mqtt) mqtt->publish(lights);
                        });
  StreamSessionReport report;
  report.port = server.start();
  if (mqtt) {
    mqtt->set_status(nlohmann::json{{"source", options.source},
                                    {"method", options.method_name},
                                    {"http", fmt::format("http://{}:{}/", options.server.host, report.port)}}
                         .dump());
    mqtt->start();
  }
  pipeline.start();
  if (started) started(report.port);
  defer_interrupts();  // a signal stops the loop below: servers stopped, the summary returned
  const auto start = std::chrono::steady_clock::now();
  auto last_frame_at = start;
  const double fps = options.source_options.frame_rate;
  const double quiet_s = fps > 0 ? std::max(2.0, 3.0 / fps) : 2.0;  // three frame periods at a slow pace
  uint64_t frames_seen = 0;
  while (!interrupt_signal()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const LiveStats stats = pipeline.stats();
    if (!stats.input_error.empty() || (mqtt && !mqtt->refused().empty())) break;
    server.publish_metrics(pipeline.metrics() + (mqtt ? mqtt->metrics() : ""));
    server.publish_status("light_count", light_count_json(stats).dump());
    server.publish_status("bracket", bracket_json(stats).dump());
    const auto now = std::chrono::steady_clock::now();
    if (stats.frames_in != frames_seen) frames_seen = stats.frames_in, last_frame_at = now;
    server.publish_status("pipeline",
                          pipeline_status_json(stats, options.source, std::chrono::duration<double>(now - last_frame_at).count(),
                                               quiet_s).dump());
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (options.duration_s > 0 && elapsed >= options.duration_s) break;
    // Without --duration a replay that has ended ends the stream (it kept serving its last
    // lights until killed); with one, the lights stay up that long.
    if (options.duration_s <= 0 && pipeline.finished()) break;
  }
  pipeline.stop();
  report.stats = pipeline.stats();
  server.stop();
  if (mqtt) {
    const std::string refused = mqtt->refused();
    mqtt->stop();
    report.published = true;
    report.mqtt = mqtt->stats();
    if (!refused.empty()) report.error = refused;
  }
  if (!report.stats.input_error.empty()) report.error = report.stats.input_error;  // a bad frame is refused
  return report;
}

std::string StreamSessionReport::summary() const {
  const LiveStats& s = stats;
  return fmt::format(
      "stream stopped: {} frames in ({} decode), {} brackets processed, {} dropped whole, {} frames in partial "
      "brackets, {} reconnects; {} lights{}{}{}{}\n",
      s.frames_in, s.decode, s.brackets_processed, s.brackets_dropped, s.frames_dropped_partial, s.reconnects, s.lights,
      s.auto_count ? fmt::format(" (--n auto: {} error {:.4f}, target {:g}{}, {} changes{})", s.count_measure,
                                 s.count_error, s.count_target, s.count_reached ? "" : " MISSED", s.count_changes,
                                 s.count_budget_limited ? fmt::format(", held to {} by the frame budget", s.count_budget_cap) : "")
                   : "",
      s.auto_exposures ? fmt::format("; --exposures auto: {} ({} changes)", s.bracket_plan.reason, s.bracket_changes) : "",
      published ? fmt::format("; mqtt: {} lists published, {} dropped, {} connects", mqtt.lists_published,
                              mqtt.lists_dropped, mqtt.link.connects)
                : "",
      s.last_error.empty() ? "" : "; last error: " + s.last_error);
}

nlohmann::json StreamSessionReport::to_json() const {
  const LiveStats& s = stats;
  return {{"port", port}, {"frames_in", s.frames_in}, {"decode", s.decode}, {"brackets_processed", s.brackets_processed},
          {"brackets_dropped", s.brackets_dropped}, {"frames_dropped_partial", s.frames_dropped_partial},
          {"reconnects", s.reconnects}, {"fps", s.fps_out}, {"last_error", s.last_error},
          {"mqtt_published", mqtt.lists_published}, {"mqtt_dropped", mqtt.lists_dropped},
          {"mqtt_connects", mqtt.link.connects}, {"light_count", light_count_json(s)}, {"bracket", bracket_json(s)}};
}

}  // namespace lp
