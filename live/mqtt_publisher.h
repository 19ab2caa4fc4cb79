// `stream --publish mqtt://[user[:password]@]HOST[:PORT]/PREFIX` (issue 19): every light
// list, exactly the CONVENTIONS JSON that /lights serves (sh9 included when the list has
// it), on PREFIX/CAMERA/lights, retained (a late subscriber gets the latest at once),
// QoS 0 or 1. PREFIX/CAMERA/status is retained too: {"state": "online", ...what it serves}
// on every connection, and the last will, {"state": "offline", ...}, which the broker
// publishes when the camera vanishes (a clean stop publishes it itself).
//
// publish() never waits for the broker: while disconnected, or while QoS 1 lists are
// unacknowledged past `max_in_flight`, only the latest list is kept (the ones it replaces
// are counted as dropped) and it goes out as soon as the link allows. Lists are sent in
// order on one connection, so the retained list is always the newest one sent.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/light_list.h"
#include "live/mqtt_client.h"

namespace lp {

struct MqttPublisherOptions {
  std::string camera;           // the topic level CAMERA: mqtt_camera_name()
  int qos = 1;                  // of the lights (0 or 1); status and will are always QoS 1
  size_t max_in_flight = 8;     // QoS 1 lists unacknowledged before newer ones wait (latest only)
  MqttClientOptions client;
};

struct MqttPublisherStats {
  uint64_t lists_published = 0;  // handed to the broker
  uint64_t lists_delivered = 0;  // acknowledged (QoS 1) or written (QoS 0)
  uint64_t lists_dropped = 0;    // replaced by a newer list before they could go out
  MqttLinkStats link;
};

// CAMERA for the topics: `name` if given (checked: one topic level, no '+', '#' or '/',
// not "merged", which the merge publishes), else made from the source ("aravis:Fake_1"
// -> "aravis-Fake_1", "replay:/data/run3" -> "replay-run3"). InputError naming `flag`.
std::string mqtt_camera_name(const std::string& name, const std::string& source, const std::string& flag);

class MqttPublisher {
 public:
  // `url` is parsed (parse_mqtt_url; its topic is PREFIX, without wildcards) and checked
  // here: InputError naming `flag`. Nothing connects before start().
  MqttPublisher(const std::string& url, const std::string& flag, MqttPublisherOptions options);
  ~MqttPublisher();  // stop()
  void start();
  // Announces "offline" (retained) and disconnects. Idempotent.
  void stop();

  // Thread-safe; never blocks on the network.
  void publish(const LightList& list);
  // What the camera serves (a JSON object: source, method, its HTTP address...), merged
  // into the "online" status from the next connection on.
  void set_status(const std::string& json_object);

  MqttPublisherStats stats() const;
  // Prometheus text: lightprobe_mqtt_lists_{published,delivered,dropped}_total and the
  // link (mqtt_link_metrics), labelled "publish", beside `other_links`.
  std::string metrics(const std::vector<std::pair<std::string, MqttLinkStats>>& other_links = {}) const;
  // Non-empty once the broker refused our credentials or TLS failed (the stream ends with it).
  std::string refused() const { return connection_->stats().refused; }
  const std::string& lights_topic() const { return lights_topic_; }
  const std::string& status_topic() const { return status_topic_; }
  const std::string& address() const { return connection_->address(); }

 private:
  void on_connect();
  void on_delivered(int mid);
  void send_locked();  // sends pending_; with mutex_ held and the link free

  MqttPublisherOptions options_;
  std::string lights_topic_, status_topic_;
  std::unique_ptr<MqttConnection> connection_;
  mutable std::mutex mutex_;
  std::string status_json_ = "{}";
  std::optional<std::string> pending_;  // the latest list not sent yet
  std::set<int> in_flight_;             // mids of lists not acknowledged (QoS 1) or written (QoS 0)
  bool link_up_ = false;                // announced on the current connection
  double resync_since_ = 0;             // > 0: lists from before a reconnect are being re-sent
  MqttPublisherStats stats_;
};

}  // namespace lp
