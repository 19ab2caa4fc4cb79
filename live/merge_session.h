// `lightprobe merge` as one call: the merge of several cameras (their HTTP servers, or
// whatever publishes on an MQTT topic) served by a light server until a signal or a
// duration, with a summary of what was published. The command only parses options.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "live/light_server.h"
#include "live/merge_client.h"
#include "live/mqtt_merge.h"

namespace lp {

struct MergeSessionOptions {
  std::vector<std::string> urls;  // the cameras' servers, or
  std::string subscribe;          // an MQTT topic filter mqtt://HOST:PORT/PREFIX/+/lights
  std::string subscribe_flag = "--subscribe";  // named in errors about it
  MqttMergeOptions mqtt;          // mqtt.merge is used for both kinds (timeout, token, n, weights)
  LightServerOptions server;
  double duration_s = 0;          // stop after this long; 0: at SIGINT / SIGTERM only
};

struct MergeSessionReport {
  int port = 0;
  uint64_t published = 0;
  size_t inputs = 0, skipped = 0;
  MergeClientStatus last;  // the last round's status
  // "merge stopped: N lists published; last used ..." (one line).
  std::string summary() const;
  nlohmann::json to_json() const;
};

// InputError before anything starts for options that cannot work (both URLs and a topic,
// neither, --weights with a topic). `started(port)` is called once the server listens.
// Interrupts are deferred (core/interrupt.h): a first signal ends the session cleanly.
MergeSessionReport run_merge_session(const MergeSessionOptions& options, const std::function<void(int port)>& started);

}  // namespace lp
