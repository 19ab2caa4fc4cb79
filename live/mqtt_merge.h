// `lightprobe merge --subscribe mqtt://HOST:PORT/PREFIX/+/lights` (issue 19): merges
// whichever cameras publish on PREFIX/CAMERA/lights (live/mqtt_publisher.h), with the
// rounds of the HTTP merge (merge_round in live/merge_client.h: the same merges, liveness,
// skips and status), and publishes the result on PREFIX/merged/lights, retained, as a
// camera named "merged" with its own status and will.
//
// A camera is dropped when its status says "offline" (its last will, or a clean stop) or
// when it has sent no list for `timeout_s`, and taken back with its next list. A payload
// that is not a light list (not JSON, another format, over max_payload_bytes) is counted
// against its camera (polls_failed, and "malformed" skips while it stands) and never
// reaches the merge; nothing a publisher sends can end the merge.
#pragma once

#include <atomic>
#include <functional>
#include <string>

#include "live/merge_client.h"
#include "live/mqtt_client.h"

namespace lp {

struct MqttMergeOptions {
  MergeClientOptions merge;            // poll_interval_s: the merge rounds' period; timeout_s; merge (n, q2); weights unused
  MqttClientOptions client;
  int qos = 1;                         // of the subscription and of the merged lists
  size_t max_payload_bytes = 16 << 20;  // a larger payload is malformed, not parsed
  size_t max_cameras = 256;            // cameras beyond this many are ignored (counted)
};

// Runs until `stop`, calling `publish` after every round that merged something (as
// run_merge_client does; status.inputs are the cameras, named by their topic level, and
// polls_ok / polls_failed count their lists and malformed payloads). Throws InputError
// naming `flag` for a URL whose topic is not PREFIX/+/lights, before anything starts,
// and when the broker refuses the credentials; never for what publishers send.
void run_mqtt_merge(const std::string& url, const std::string& flag, const MqttMergeOptions& options,
                    const std::function<void(const LightList&, const MergeClientStatus&)>& publish,
                    const std::atomic<bool>& stop);

}  // namespace lp
