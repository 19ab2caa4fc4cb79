// `lightprobe merge` as one call: the merge of several cameras (their HTTP servers, or
// whatever publishes on an MQTT topic) served by a light server until a signal or a
// duration, with a summary of what was published. The command only parses options.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "live/light_server.h"
#include "live/merge_client.h"
#include "live/mqtt_merge.h"

namespace lp {

struct MergeSessionOptions {
  std::vector<std::string> urls;  // the cameras' servers, or
  std::string subscribe;          // an MQTT topic filter mqtt://HOST:PORT/PREFIX/+/lights
  std::string subscribe_flag = "--subscribe";  // named in errors about it
  MqttMergeOptions mqtt;          // mqtt.merge is used for both kinds (timeout, token, n, weights)
  // Position weights (Nikodym et al. 2013, section 4): where each URL's camera stands and
  // the point being lit, in one frame and unit (metres, say); each camera is weighted by
  // 1 / distance^position_power to the target (sampling/merge_cameras.h position_weights),
  // replacing mqtt.merge.merge.weights. Both or neither; not with explicit weights or a
  // topic (whose cameras come and go by name).
  std::vector<Vec3> camera_positions;
  std::optional<Vec3> target;
  double position_power = 2;
  LightServerOptions server;
  double duration_s = 0;          // stop after this long; 0: at SIGINT / SIGTERM only
};

struct MergeSessionReport {
  int port = 0;
  std::vector<double> weights;     // per URL, normalised, as merged (empty: equal)
  std::string weights_from;        // "equal", "--weights" or "camera positions"
  uint64_t published = 0;
  size_t inputs = 0, skipped = 0;
  MergeClientStatus last;  // the last round's status
  // "merge stopped: N lists published; last used ..." (one line).
  std::string summary() const;
  nlohmann::json to_json() const;
};

// The weights a session merges with (empty: equal) and where they come from (report
// fields above). InputError for positions that do not fit the options (see above).
std::vector<double> merge_session_weights(const MergeSessionOptions& options, std::string* from = nullptr);

// InputError before anything starts for options that cannot work (both URLs and a topic,
// neither, --weights with a topic, positions that do not fit). `started(port)` is called once the server listens.
// Interrupts are deferred (core/interrupt.h): a first signal ends the session cleanly.
MergeSessionReport run_merge_session(const MergeSessionOptions& options, const std::function<void(int port)>& started);

}  // namespace lp
