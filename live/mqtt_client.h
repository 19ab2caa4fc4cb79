// One connection to an MQTT broker through libmosquitto (issue 19): the URL, credentials,
// TLS, a last will, and a network thread that reconnects by itself with exponential
// backoff. What rides on it is the publisher's (live/mqtt_publisher.h)
// and the merge's (live/mqtt_merge.h) business. The library prints nothing.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

struct mosquitto;
struct mosquitto_message;

namespace lp {

// mqtt://[user[:password]@]HOST[:PORT]/TOPIC, or mqtts:// for TLS. The port defaults to
// 1883 (8883 for mqtts); HOST may be [v6]; the topic is everything after the first '/'.
struct MqttUrl {
  bool tls = false;
  std::string user, password;  // empty user: no credentials
  std::string host;
  int port = 1883;
  std::string topic;
};
// InputError naming `flag` on a malformed URL (scheme, host, port, an empty topic or one
// with a '#', or a '+' anywhere but a whole level).
MqttUrl parse_mqtt_url(const std::string& url, const std::string& flag);

struct MqttClientOptions {
  std::string cafile;           // mqtts: CA certificates (PEM); empty: the system's, /etc/ssl/certs
  int keepalive_s = 5;          // the broker drops us (and sends the will) after 1.5x this silent
  int reconnect_delay_s = 1;    // first retry after a lost connection; doubles up to the next
  int reconnect_delay_max_s = 8;
};

struct MqttWill {
  std::string topic, payload;
  int qos = 1;
  bool retain = true;
};

struct MqttLinkStats {
  bool connected = false;
  uint64_t connects = 0;     // connections the broker accepted (the first and every reconnect)
  uint64_t disconnects = 0;  // connections lost (or refused)
  std::string refused;       // the broker refused our credentials, or TLS failed: fatal, no more retries
};

class MqttConnection {
 public:
  // Both run on the network thread: after every accepted connection (subscribe and
  // announce here: a clean session forgets them), and for every message received.
  using OnConnect = std::function<void()>;
  using OnMessage = std::function<void(const std::string& topic, std::string_view payload)>;
  using OnDelivered = std::function<void(int mid)>;  // QoS 1: acknowledged; QoS 0: sent
  // `flag` names the option the URL came from, in errors. Throws InputError on a bad
  // cafile; nothing connects before start().
  MqttConnection(const MqttUrl& url, const std::string& flag, const MqttClientOptions& options,
                 const std::optional<MqttWill>& will, OnConnect on_connect, OnMessage on_message = {},
                 OnDelivered on_delivered = {});
  ~MqttConnection();  // stop()
  MqttConnection(const MqttConnection&) = delete;
  MqttConnection& operator=(const MqttConnection&) = delete;

  // Connects in the background; an unreachable broker is retried, never an error.
  void start();
  // Sends `farewell` (topic, payload; retained, QoS 1) if connected, disconnects cleanly
  // (the broker sends no will), and joins the network thread. Idempotent.
  void stop(const std::optional<std::pair<std::string, std::string>>& farewell = std::nullopt);

  // Queues a message for the network thread; never waits for the network. False when
  // not connected (nothing queued). `mid` receives the message id for OnDelivered.
  bool publish(const std::string& topic, std::string_view payload, int qos, bool retain, int* mid = nullptr);
  bool subscribe(const std::string& filter, int qos);

  MqttLinkStats stats() const;
  // "mqtt://HOST:PORT" without credentials, for messages.
  const std::string& address() const { return address_; }

 private:
  static void connected_cb(mosquitto*, void* self, int rc);
  static void disconnected_cb(mosquitto*, void* self, int rc);
  static void message_cb(mosquitto*, void* self, const mosquitto_message* message);
  static void published_cb(mosquitto*, void* self, int mid);
  static void log_cb(mosquitto*, void* self, int level, const char* text);

  MqttUrl url_;
  std::string flag_, address_;
  MqttClientOptions options_;
  OnConnect on_connect_;
  OnMessage on_message_;
  OnDelivered on_delivered_;
  mosquitto* mosq_ = nullptr;
  mutable std::mutex mutex_;  // stats_
  MqttLinkStats stats_;
  std::atomic<bool> connected_{false};
  bool started_ = false;
  std::atomic<bool> stopping_{false};
  // The one thread that drives libmosquitto's socket: connects, reconnects after the
  // backoff, runs mosquitto_loop, and on stop() lets the farewell out (see start()).
  std::thread network_;
  void run();
};

// Prometheus text of named links ("publish", "subscribe"): lightprobe_mqtt_connected and
// lightprobe_mqtt_{connects,disconnects}_total, labelled link=NAME.
std::string mqtt_link_metrics(const std::vector<std::pair<std::string, MqttLinkStats>>& links);

}  // namespace lp
