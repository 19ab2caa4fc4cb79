#include "live/mqtt_client.h"

#include <fmt/format.h>
#include <mosquitto.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>

#include "core/error.h"

namespace lp {

namespace {

// The URL as it may appear in a message: the password never does.
std::string redacted(const std::string& url) {
  const auto scheme_end = url.find("://");
  const auto at = url.find('@');
  const auto colon = url.find(':', scheme_end == std::string::npos ? 0 : scheme_end + 3);
  if (scheme_end == std::string::npos || at == std::string::npos || colon == std::string::npos || colon > at) return url;
  return url.substr(0, colon) + ":***" + url.substr(at);
}

// Credentials refused, or a protocol the broker will not speak: retrying cannot help.
bool refusal_is_final(int rc) { return rc == 1 || rc == 2 || rc == 4 || rc == 5; }

}  // namespace

MqttUrl parse_mqtt_url(const std::string& url, const std::string& flag) {
  const auto bad = [&](const std::string& why) {
    return InputError(fmt::format("{}: '{}' {}", flag, redacted(url), why));
  };
  MqttUrl u;
  std::string rest;
  if (url.rfind("mqtt://", 0) == 0) {
    rest = url.substr(7);
  } else if (url.rfind("mqtts://", 0) == 0) {
    rest = url.substr(8), u.tls = true, u.port = 8883;
  } else {
    throw bad("is not an mqtt://HOST[:PORT]/TOPIC or mqtts:// URL");
  }
  const auto slash = rest.find('/');
  if (slash == std::string::npos || slash + 1 == rest.size()) throw bad("has no topic after the host");
  std::string authority = rest.substr(0, slash);
  u.topic = rest.substr(slash + 1);
  if (const auto at = authority.rfind('@'); at != std::string::npos) {
    const std::string userinfo = authority.substr(0, at);
    authority = authority.substr(at + 1);
    const auto colon = userinfo.find(':');
    u.user = userinfo.substr(0, colon);
    if (colon != std::string::npos) u.password = userinfo.substr(colon + 1);
    if (u.user.empty()) throw bad("has a password but no user name");
  }
  std::string port_text;
  if (!authority.empty() && authority[0] == '[') {  // [v6 address]
    const auto close = authority.find(']');
    if (close == std::string::npos) throw bad("has an unclosed '[' in its host");
    u.host = authority.substr(1, close - 1);
    const std::string after = authority.substr(close + 1);
    if (!after.empty() && after[0] != ':') throw bad("has text after its host");
    if (!after.empty()) port_text = after.substr(1);
  } else {
    const auto colon = authority.find(':');
    u.host = authority.substr(0, colon);
    if (colon != std::string::npos) port_text = authority.substr(colon + 1);
  }
  if (u.host.empty()) throw bad("has no host");
  if (authority.find(':') != std::string::npos && authority.back() == ':') throw bad("has an empty port");
  if (!port_text.empty()) {
    try {
      size_t used = 0;
      u.port = std::stoi(port_text, &used);
      if (used != port_text.size() || u.port < 1 || u.port > 65535) throw std::invalid_argument("port");
    } catch (const std::exception&) {
      throw bad(fmt::format("has a bad port '{}'", port_text));
    }
  }
  if (u.topic.find('#') != std::string::npos) throw bad("has a '#' in its topic");
  for (size_t i = u.topic.find('+'); i != std::string::npos; i = u.topic.find('+', i + 1)) {
    const bool whole_level = (i == 0 || u.topic[i - 1] == '/') && (i + 1 == u.topic.size() || u.topic[i + 1] == '/');
    if (!whole_level) throw bad("has a '+' that is not a whole topic level");
  }
  return u;
}

MqttConnection::MqttConnection(const MqttUrl& url, const std::string& flag, const MqttClientOptions& options,
                               const std::optional<MqttWill>& will, OnConnect on_connect, OnMessage on_message,
                               OnDelivered on_delivered)
    : url_(url),
      flag_(flag),
      address_(fmt::format("{}://{}:{}", url.tls ? "mqtts" : "mqtt", url.host, url.port)),
      options_(options),
      on_connect_(std::move(on_connect)),
      on_message_(std::move(on_message)),
      on_delivered_(std::move(on_delivered)) {
  if (url.tls && !options.cafile.empty() && !std::filesystem::is_regular_file(options.cafile))
    throw InputError(fmt::format("{}: no such CA file for {}", options.cafile, flag));
  static const int init = mosquitto_lib_init();  // once per process; thread-safe in C++11
  (void)init;
  mosq_ = mosquitto_new(nullptr, true, this);  // a random client id, a clean session
  if (!mosq_) throw std::runtime_error("mosquitto_new failed (out of memory)");
  mosquitto_connect_callback_set(mosq_, &MqttConnection::connected_cb);
  mosquitto_disconnect_callback_set(mosq_, &MqttConnection::disconnected_cb);
  mosquitto_message_callback_set(mosq_, &MqttConnection::message_cb);
  mosquitto_publish_callback_set(mosq_, &MqttConnection::published_cb);
  mosquitto_log_callback_set(mosq_, &MqttConnection::log_cb);
  if (!url.user.empty())
    mosquitto_username_pw_set(mosq_, url.user.c_str(), url.password.empty() ? nullptr : url.password.c_str());
  if (url.tls) {
    const int rc = options.cafile.empty() ? mosquitto_tls_set(mosq_, nullptr, "/etc/ssl/certs", nullptr, nullptr, nullptr)
                                          : mosquitto_tls_set(mosq_, options.cafile.c_str(), nullptr, nullptr, nullptr, nullptr);
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_destroy(mosq_);
      throw InputError(fmt::format("{}: TLS setup failed: {}", flag, mosquitto_strerror(rc)));
    }
  }
  if (will) {
    const int rc = mosquitto_will_set(mosq_, will->topic.c_str(), int(will->payload.size()), will->payload.data(),
                                      will->qos, will->retain);
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_destroy(mosq_);
      throw InputError(fmt::format("{}: bad last-will topic '{}': {}", flag, will->topic, mosquitto_strerror(rc)));
    }
  }
}

MqttConnection::~MqttConnection() {
  stop();
  mosquitto_destroy(mosq_);
}

void MqttConnection::start() {
  if (started_) throw std::logic_error("MqttConnection started twice");
  // Our own network thread (run()) calls libmosquitto's loop, so that every call that
  // touches the socket and its TLS state is made by that one thread. With libmosquitto's
  // thread (mosquitto_loop_start) that could not hold: 2.0.11 ends its thread on any TLS
  // error, a broker's SIGKILL included, and starting it again while reconnecting from
  // another thread raced on the SSL object (a crash in libssl, about 1 in 50 broker kills).
  // "Threaded" tells libmosquitto that publishing threads only queue and wake the loop.
  mosquitto_threaded_set(mosq_, true);
  // Before the thread exists: a non-blocking connect (its failure is retried by run()),
  // and malformed arguments are an error now rather than a silent retry loop.
  if (mosquitto_connect_async(mosq_, url_.host.c_str(), url_.port, options_.keepalive_s) == MOSQ_ERR_INVAL)
    throw InputError(fmt::format("{}: cannot connect to {}", flag_, address_));
  started_ = true;
  network_ = std::thread([this] { run(); });
}

void MqttConnection::run() {
  using Clock = std::chrono::steady_clock;
  const auto first = std::chrono::seconds(std::max(1, options_.reconnect_delay_s));
  const auto longest = std::max(first, std::chrono::seconds(options_.reconnect_delay_max_s));
  auto delay = first;                          // until the next attempt; doubles up to `longest`
  auto next_attempt = Clock::now() + delay;    // start() made the first one
  auto stop_deadline = Clock::time_point::max();
  constexpr int kLoopMs = 100;                 // how soon stop() is noticed; publishing wakes the loop at once
  while (true) {
    if (stopping_ && stop_deadline == Clock::time_point::max())
      stop_deadline = Clock::now() + std::chrono::seconds(2);  // for the farewell and the DISCONNECT to go out
    if (connected_) delay = first;  // a connection worked: the backoff starts over
    if (mosquitto_socket(mosq_) < 0) {  // no connection, nor one under way
      if (stopping_) break;
      const bool gave_up = [&] {
        std::lock_guard lock(mutex_);
        return !stats_.refused.empty();  // credentials or TLS refused: retrying cannot help
      }();
      if (gave_up || Clock::now() < next_attempt) {
        std::this_thread::sleep_for(std::chrono::milliseconds(kLoopMs));
        continue;
      }
      mosquitto_reconnect_async(mosq_);  // a failure leaves no socket: the next attempt after `delay`
      next_attempt = Clock::now() + delay;
      delay = std::min(2 * delay, longest);
      continue;
    }
    if (Clock::now() > stop_deadline) break;
    // Reads, writes, the TLS handshake and keepalive; an error closes the socket (and calls
    // disconnected_cb), and the next round connects again after the backoff.
    mosquitto_loop(mosq_, kLoopMs, 1);
  }
}

void MqttConnection::stop(const std::optional<std::pair<std::string, std::string>>& farewell) {
  if (!started_ || stopping_.exchange(true)) return;
  // Queued in order for the network thread: the farewell is written before the DISCONNECT,
  // which also makes the broker forget the will.
  if (farewell && connected_)
    mosquitto_publish(mosq_, nullptr, farewell->first.c_str(), int(farewell->second.size()), farewell->second.data(), 1,
                      true);
  mosquitto_disconnect(mosq_);
  network_.join();
}

bool MqttConnection::publish(const std::string& topic, std::string_view payload, int qos, bool retain, int* mid) {
  if (!connected_) return false;
  return mosquitto_publish(mosq_, mid, topic.c_str(), int(payload.size()), payload.data(), qos, retain) ==
         MOSQ_ERR_SUCCESS;
}

bool MqttConnection::subscribe(const std::string& filter, int qos) {
  return mosquitto_subscribe(mosq_, nullptr, filter.c_str(), qos) == MOSQ_ERR_SUCCESS;
}

MqttLinkStats MqttConnection::stats() const {
  std::lock_guard lock(mutex_);
  MqttLinkStats s = stats_;
  s.connected = connected_;
  return s;
}

void MqttConnection::connected_cb(mosquitto* mosq, void* self, int rc) {
  auto& c = *static_cast<MqttConnection*>(self);
  if (rc != 0) {
    std::lock_guard lock(c.mutex_);
    ++c.stats_.disconnects;
    if (refusal_is_final(rc)) {
      c.stats_.refused = fmt::format("{}: {} refused the connection: {}", c.flag_, c.address_, mosquitto_connack_string(rc));
      mosquitto_disconnect(mosq);  // no retries: the same credentials would be refused again
    }
    return;
  }
  {
    std::lock_guard lock(c.mutex_);
    ++c.stats_.connects;
  }
  c.connected_ = true;
  if (c.on_connect_) c.on_connect_();
}

void MqttConnection::disconnected_cb(mosquitto*, void* self, int) {
  auto& c = *static_cast<MqttConnection*>(self);
  if (!c.connected_.exchange(false)) return;  // a refused connection was counted already
  std::lock_guard lock(c.mutex_);
  ++c.stats_.disconnects;
}

void MqttConnection::message_cb(mosquitto*, void* self, const mosquitto_message* m) {
  auto& c = *static_cast<MqttConnection*>(self);
  if (c.on_message_)
    c.on_message_(m->topic, std::string_view(static_cast<const char*>(m->payload), size_t(std::max(0, m->payloadlen))));
}

void MqttConnection::published_cb(mosquitto*, void* self, int mid) {
  auto& c = *static_cast<MqttConnection*>(self);
  if (c.on_delivered_) c.on_delivered_(mid);
}

void MqttConnection::log_cb(mosquitto*, void* self, int level, const char* text) {
  // A TLS failure comes without a callback of its own; its log line is the only word of it.
  // Before any connection worked it is the setup's fault (an unknown CA, a name mismatch):
  // fatal. Afterwards it is a lost connection, which run() restores.
  auto& c = *static_cast<MqttConnection*>(self);
  if (level != MOSQ_LOG_ERR || std::string_view(text).rfind("OpenSSL Error", 0) != 0) return;
  std::lock_guard lock(c.mutex_);
  if (c.stats_.connects == 0) {
    if (c.stats_.refused.empty()) c.stats_.refused = fmt::format("{}: TLS with {} failed: {}", c.flag_, c.address_, text);
    return;
  }
  if (c.connected_.exchange(false)) ++c.stats_.disconnects;
}

std::string mqtt_link_metrics(const std::vector<std::pair<std::string, MqttLinkStats>>& links) {
  std::string m =
      "# HELP lightprobe_mqtt_connected 1 while the link to the MQTT broker is up.\n"
      "# TYPE lightprobe_mqtt_connected gauge\n";
  for (const auto& [name, s] : links) m += fmt::format("lightprobe_mqtt_connected{{link=\"{}\"}} {}\n", name, int(s.connected));
  m += "# HELP lightprobe_mqtt_connects_total Connections the broker accepted (the first and every reconnect).\n"
       "# TYPE lightprobe_mqtt_connects_total counter\n";
  for (const auto& [name, s] : links) m += fmt::format("lightprobe_mqtt_connects_total{{link=\"{}\"}} {}\n", name, s.connects);
  m += "# HELP lightprobe_mqtt_disconnects_total Connections lost or refused.\n"
       "# TYPE lightprobe_mqtt_disconnects_total counter\n";
  for (const auto& [name, s] : links)
    m += fmt::format("lightprobe_mqtt_disconnects_total{{link=\"{}\"}} {}\n", name, s.disconnects);
  return m;
}

}  // namespace lp
