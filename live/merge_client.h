// `lightprobe merge URL...`: subscribe to several light servers (one per camera) and
// publish their merged lights (sampling/merge_cameras.h). A camera that stops answering
// is dropped after a timeout and taken back when it returns; the output never stops.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "core/light_list.h"
#include "sampling/merge_cameras.h"

namespace lp {

struct MergeClientOptions {
  double poll_interval_s = 0.1;   // how often each server's /lights is fetched
  double timeout_s = 2.0;         // an input silent this long is dropped
  double request_timeout_s = 0.5;
  std::string token;              // bearer token for the servers, if they need one
  MergeAvailableOptions merge;
};

// Polls until `stop` becomes true, calling `publish` with every merged list (and the
// names used/dropped in `state`). Throws InputError for a malformed URL.
void run_merge_client(const std::vector<std::string>& urls, const MergeClientOptions& options,
                      const std::function<void(const LightList&, const MergeState&)>& publish,
                      const std::atomic<bool>& stop);

}  // namespace lp
