// `lightprobe stream` as one call: the live pipeline from a camera source, its lists served
// by a light server (and published on an MQTT broker when asked) until a signal, a duration,
// a bad frame or a refused broker login, with a summary. The command only parses options.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <functional>
#include <string>

#include "live/light_server.h"
#include "live/mqtt_publisher.h"
#include "live/pipeline.h"
#include "probe/camera_source.h"

namespace lp {

struct StreamSessionOptions {
  std::string source;              // open_source() spec
  SourceOptions source_options;
  LivePipelineOptions pipeline;
  LightServerOptions server;
  std::string publish;             // mqtt[s]://... : the lists on a broker too; empty: HTTP only
  std::string publish_flag = "--publish";
  MqttPublisherOptions mqtt;
  std::string method_name;         // for the MQTT status message
  double duration_s = 0;           // stop after this long; 0: at SIGINT / SIGTERM only
};

struct StreamSessionReport {
  int port = 0;
  LiveStats stats;
  bool published = false;          // an MQTT publisher ran
  MqttPublisherStats mqtt;
  std::string error;               // a bad frame or a refused broker login: the command fails with it
  // "stream stopped: N frames in, ..." (one line).
  std::string summary() const;
  nlohmann::json to_json() const;
};

// The light count as /status shows it (section "light_count") and to_json reports it:
// {"mode": "fixed"|"auto", "lights", and for auto "measure", "target_error", "error",
// (with --frame-budget-ms "frame_budget_ms", "budget_cap", "budget_limited"),
// "reached", "changes"}.
nlohmann::json light_count_json(const LiveStats& stats);

// The bracket as /status shows it (section "bracket") and to_json reports it:
// {"mode": "fixed"|"auto"|"single" (no bracket), "exposure_seconds" (what the camera cycles
// now), and for auto "reason" (the plan's one line: scene range, bracket, coverage, what
// the camera's limits leave out), "decision" (why the last map kept or changed it),
// "scene_stops", "covered_fraction", "limit" ("none" or the end given up), "changes"}.
nlohmann::json bracket_json(const LiveStats& stats);

// The camera and its brackets as the pipeline counts them, served in /status as the
// "pipeline" section for the page's operator view: source, camera_state ("streaming" while
// frames arrive; after 2 s without one, "no frame for N s": a lost camera is being reopened
// then, and reconnects and last_error tell the rest), frames_in, brackets_processed,
// brackets_dropped, frames_dropped_partial (frames of broken brackets), reconnects,
// last_error.
// `quiet_s`: how long without a frame still counts as streaming (2 s; longer for a source
// paced slower than a frame per 2 s, which is not lost between its frames).
nlohmann::json pipeline_status_json(const LiveStats& stats, const std::string& source, double seconds_since_frame,
                                    double quiet_s = 2);

// InputError before anything starts for a malformed publish URL. `started(port)` is called
// once the server listens and the pipeline runs. Interrupts are deferred (core/interrupt.h).
StreamSessionReport run_stream_session(const StreamSessionOptions& options, const std::function<void(int port)>& started);

}  // namespace lp
