// `lightprobe merge URL...`: subscribe to several light servers (one per camera) and
// publish their merged lights (sampling/merge_cameras.h). A camera that stops answering
// is dropped after a timeout and taken back when it returns; a camera whose list cannot
// be merged (malformed JSON, no lights, values that are not finite, negative or too big,
// other units) is skipped, counted per reason and reported; cameras of different methods
// are merged by direction. The output never stops while one input is usable, and
// nothing an upstream sends can end the merge (issue 22).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/light_list.h"
#include "sampling/merge_cameras.h"

namespace lp {

struct MergeClientOptions {
  double poll_interval_s = 0.1;   // how often each server's /lights is fetched
  double timeout_s = 2.0;         // an input silent this long is dropped
  double request_timeout_s = 0.5; // a whole request (connect to the last byte) at most
  size_t max_body_bytes = 64 << 20;  // an answer longer than this is abandoned
  std::string token;              // bearer token for the servers, if they need one
  MergeAvailableOptions merge;
};

// One input as the last round saw it, with its counters since the start.
struct MergeInputStatus {
  std::string name;                // its URL
  std::string state = "waiting";   // "used", "silent" (none or too old), "skipped" (cannot be merged), "waiting"
  std::string reason, detail;      // why it was skipped (reason codes: merge_problem's, "units", "malformed")
  uint64_t polls_ok = 0;           // answers 200
  uint64_t polls_failed = 0;       // no answer, or another status
  std::map<std::string, uint64_t> skipped;  // merge rounds that left its list out, by reason
};

struct MergeClientStatus {
  uint64_t rounds = 0;        // merges attempted
  uint64_t stale_rounds = 0;  // rounds that merged nothing (no usable input, or the merge failed)
  std::string mode;           // "index", "q2tree" or "direction": how the last output was merged
  std::string error;          // why the last round's merge failed, if it did
  std::vector<MergeInputStatus> inputs;
  MergeState state;           // the merge's own report of the last round
  uint64_t lists_out = 0;     // merged lists numbered so far (the next one's frame)
  std::string link_metrics;   // Prometheus text of the link the inputs come through (MQTT), if any
};

// One round over the inputs as they stand, shared by the HTTP poller below and the MQTT
// subscriber (live/mqtt_merge.h): merges the live ones (merge_available), updates
// `status` (its inputs follow `inputs`, which may only grow) and returns the merged list,
// numbered, or nullopt when the round merged nothing. `malformed[i]`: why input i's last
// answer was not a light list (its older list must not stand in for it; empty: it was).
std::optional<LightList> merge_round(const std::vector<MergeInput>& inputs, const std::vector<std::string>& malformed,
                                     const MergeClientOptions& options, MergeClientStatus& status);

// Polls until `stop` becomes true, calling `publish` with every new merged list (rounds
// that merge nothing publish nothing) and the status. Throws InputError for a malformed
// URL, before anything starts; never afterwards (an exception of `publish` ends the
// round, not the loop).
void run_merge_client(const std::vector<std::string>& urls, const MergeClientOptions& options,
                      const std::function<void(const LightList&, const MergeClientStatus&)>& publish,
                      const std::atomic<bool>& stop);

// The status as a JSON object (for /status) and as Prometheus text (for /metrics:
// lightprobe_merge_* with HELP and TYPE; counters by input and reason).
std::string merge_status_json(const MergeClientStatus& status);
std::string merge_metrics_text(const MergeClientStatus& status);

}  // namespace lp
