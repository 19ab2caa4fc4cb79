#include "live/mqtt_merge.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <map>
#include <mutex>
#include <thread>

#include "core/error.h"
#include "live/mqtt_publisher.h"

namespace lp {

namespace {

constexpr std::string_view kLightsFilterTail = "/+/lights";

double now_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// What the subscriber thread has heard of every camera, under one lock.
struct Cameras {
  std::mutex mutex;
  std::map<std::string, size_t> index;  // name -> position in the vectors
  std::vector<MergeInput> inputs;
  std::vector<std::string> malformed;   // why its last lights payload was not a list
  std::vector<bool> offline;            // its status said offline: its retained list is old
  std::vector<uint64_t> ok, failed;     // lists received, malformed payloads
  uint64_t generation = 0;              // moves with every change the merge should see
  uint64_t ignored = 0;                 // messages of cameras beyond max_cameras

  // The camera's position, added if new; npos when there are too many.
  size_t find(const std::string& name, size_t max_cameras) {
    if (auto it = index.find(name); it != index.end()) return it->second;
    if (inputs.size() >= max_cameras) return std::string::npos;
    index[name] = inputs.size();
    inputs.push_back({name, std::nullopt, 0});
    malformed.emplace_back();
    offline.push_back(false);
    ok.push_back(0), failed.push_back(0);
    return inputs.size() - 1;
  }

  void on_lights(size_t i, std::string_view payload, size_t max_bytes) {
    if (offline[i]) return;  // the retained list of a camera that is gone
    ++generation;
    try {
      if (payload.size() > max_bytes)
        throw InputError(fmt::format("a payload of {} bytes (over {})", payload.size(), max_bytes));
      inputs[i].latest = light_list_from_json(std::string(payload), inputs[i].name);
      inputs[i].last_seen_s = now_s();
      malformed[i].clear();
      ++ok[i];
    } catch (const std::exception& e) {
      inputs[i].latest.reset();  // alive but unusable: its older list must not stand in for it
      malformed[i] = e.what();
      ++failed[i];
    }
  }

  void on_status(size_t i, std::string_view payload) {
    const auto j = nlohmann::json::parse(payload, nullptr, false);
    const std::string state = j.is_object() && j.contains("state") && j["state"].is_string() ? j["state"].get<std::string>() : "";
    if (state == "offline") {
      offline[i] = true;
      inputs[i].latest.reset();
      malformed[i].clear();
      ++generation;
    } else if (state == "online") {
      offline[i] = false;
    }
  }
};

}  // namespace

void run_mqtt_merge(const std::string& url, const std::string& flag, const MqttMergeOptions& options,
                    const std::function<void(const LightList&, const MergeClientStatus&)>& publish,
                    const std::atomic<bool>& stop) {
  const MqttUrl u = parse_mqtt_url(url, flag);
  const std::string& filter = u.topic;
  const bool shaped = filter.size() > kLightsFilterTail.size() &&
                      filter.compare(filter.size() - kLightsFilterTail.size(), kLightsFilterTail.size(), kLightsFilterTail) == 0;
  const std::string prefix = shaped ? filter.substr(0, filter.size() - kLightsFilterTail.size()) : "";
  if (!shaped || prefix.find('+') != std::string::npos)
    throw InputError(fmt::format("{}: the topic must be PREFIX/+/lights (no other wildcard), got '{}'", flag, filter));
  if (options.qos != 0 && options.qos != 1) throw InputError(fmt::format("{}: QoS must be 0 or 1", flag));

  MqttPublisherOptions po;
  po.camera = "merged";
  po.qos = options.qos;
  po.client = options.client;
  MqttPublisher out(url.substr(0, url.size() - kLightsFilterTail.size()), flag, po);
  out.set_status(nlohmann::json{{"merges", filter}}.dump());

  Cameras cams;
  MqttConnection* link = nullptr;
  auto on_message = [&](const std::string& topic, std::string_view payload) {
    // PREFIX/CAMERA/lights or PREFIX/CAMERA/status; our own output is CAMERA "merged".
    if (topic.size() <= prefix.size() + 1 || topic.compare(0, prefix.size() + 1, prefix + "/") != 0) return;
    const std::string rest = topic.substr(prefix.size() + 1);
    const auto slash = rest.find('/');
    if (slash == std::string::npos || slash == 0) return;
    const std::string camera = rest.substr(0, slash), kind = rest.substr(slash + 1);
    if (camera == "merged" || (kind != "lights" && kind != "status")) return;
    std::lock_guard lock(cams.mutex);
    const size_t i = cams.find(camera, options.max_cameras);
    if (i == std::string::npos) {
      ++cams.ignored;
      return;
    }
    if (kind == "lights") cams.on_lights(i, payload, options.max_payload_bytes);
    else cams.on_status(i, payload);
  };
  MqttConnection sub(u, flag, options.client, std::nullopt,
                     [&] {  // a clean session forgets subscriptions: renew them on every connection
                       link->subscribe(prefix + "/+/lights", options.qos);
                       link->subscribe(prefix + "/+/status", 1);
                     },
                     on_message);
  link = &sub;
  out.start();
  sub.start();

  MergeClientStatus status;
  uint64_t sent_generation = 0;
  std::vector<std::string> sent_used;
  while (!stop) {
    for (const std::string& refused : {sub.stats().refused, out.refused()})
      if (!refused.empty()) throw InputError(refused);
    std::vector<MergeInput> inputs;
    std::vector<std::string> malformed;
    uint64_t generation = 0, ignored = 0;
    std::vector<uint64_t> ok, failed;
    {
      std::lock_guard lock(cams.mutex);
      inputs = cams.inputs, malformed = cams.malformed, generation = cams.generation, ignored = cams.ignored;
      ok = cams.ok, failed = cams.failed;
    }
    try {
      std::optional<LightList> merged = merge_round(inputs, malformed, options.merge, status);
      for (size_t i = 0; i < status.inputs.size(); ++i) status.inputs[i].polls_ok = ok[i], status.inputs[i].polls_failed = failed[i];
      status.link_metrics = out.metrics({{"subscribe", sub.stats()}}) +
                            fmt::format("# HELP lightprobe_mqtt_messages_ignored_total Messages of cameras past the "
                                        "camera limit.\n# TYPE lightprobe_mqtt_messages_ignored_total counter\n"
                                        "lightprobe_mqtt_messages_ignored_total {}\n",
                                        ignored);
      if (merged) {
        // The broker gets a list when an input changed, not every round.
        if (generation != sent_generation || status.state.used != sent_used) out.publish(*merged);
        sent_generation = generation, sent_used = status.state.used;
        publish(*merged, status);
      }
    } catch (const std::exception& e) {
      // Nothing a publisher sends throws here; a failing `publish` ends this round only.
      status.error = e.what();
      ++status.stale_rounds;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(options.merge.poll_interval_s));
  }
  sub.stop();
  out.stop();
}

}  // namespace lp
