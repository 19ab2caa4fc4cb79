#include "live/mqtt_publisher.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>

#include "core/error.h"

namespace lp {

namespace {

bool valid_level(const std::string& s) { return !s.empty() && s.find_first_of("/+#") == std::string::npos; }

double now_s() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// How long lists from before a reconnect may take to be acknowledged before new ones go
// out anyway (they are re-sent first so that an older list never overwrites a newer one).
constexpr double kResyncLimitS = 5;

}  // namespace

std::string mqtt_camera_name(const std::string& name, const std::string& source, const std::string& flag) {
  if (!name.empty()) {
    if (!valid_level(name)) throw InputError(fmt::format("{}: '{}' is not one topic level (no '/', '+' or '#')", flag, name));
    if (name == "merged") throw InputError(fmt::format("{}: 'merged' is the merge's own topic", flag));
    return name;
  }
  // "kind:rest" -> "kind-LAST", LAST the last path component of rest.
  std::string kind = source, rest;
  if (const auto colon = source.find(':'); colon != std::string::npos) kind = source.substr(0, colon), rest = source.substr(colon + 1);
  while (!rest.empty() && rest.back() == '/') rest.pop_back();
  if (const auto slash = rest.rfind('/'); slash != std::string::npos) rest = rest.substr(slash + 1);
  std::string out = rest.empty() ? kind : kind + "-" + rest;
  for (char& c : out)
    if (c == '+' || c == '#' || c == '/' || c == ' ' || c == ':') c = '-';
  return out.empty() || out == "merged" ? "camera" : out;
}

MqttPublisher::MqttPublisher(const std::string& url, const std::string& flag, MqttPublisherOptions options)
    : options_(std::move(options)) {
  const MqttUrl u = parse_mqtt_url(url, flag);
  if (u.topic.find('+') != std::string::npos) throw InputError(fmt::format("{}: a topic prefix cannot hold '+'", flag));
  if (options_.qos != 0 && options_.qos != 1) throw InputError(fmt::format("{}: QoS must be 0 or 1", flag));
  if (!valid_level(options_.camera)) throw InputError(fmt::format("{}: bad camera name '{}'", flag, options_.camera));
  if (options_.max_in_flight < 1) options_.max_in_flight = 1;
  const std::string base = u.topic + (u.topic.back() == '/' ? "" : "/") + options_.camera;
  lights_topic_ = base + "/lights";
  status_topic_ = base + "/status";
  MqttWill will;
  will.topic = status_topic_;
  will.payload = nlohmann::json{{"state", "offline"}, {"camera", options_.camera}}.dump();
  connection_ = std::make_unique<MqttConnection>(
      u, flag, options_.client, will, [this] { on_connect(); }, MqttConnection::OnMessage{},
      [this](int mid) { on_delivered(mid); });
}

MqttPublisher::~MqttPublisher() { stop(); }

void MqttPublisher::start() { connection_->start(); }

void MqttPublisher::stop() {
  const std::string offline = nlohmann::json{{"state", "offline"}, {"camera", options_.camera}}.dump();
  connection_->stop(std::make_pair(status_topic_, offline));
  std::lock_guard lock(mutex_);
  if (pending_) ++stats_.lists_dropped, pending_.reset();
}

void MqttPublisher::on_connect() {
  std::lock_guard lock(mutex_);
  nlohmann::json status = nlohmann::json::parse(status_json_, nullptr, false);
  if (!status.is_object()) status = nlohmann::json::object();
  status["state"] = "online";
  status["camera"] = options_.camera;
  status["lights_topic"] = lights_topic_;
  status["qos"] = options_.qos;
  const std::string payload = status.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  connection_->publish(status_topic_, payload, 1, true);
  // QoS 0 lists of the lost connection are gone; QoS 1 ones are re-sent by libmosquitto
  // right after this callback, and newer lists must wait for them (see kResyncLimitS).
  if (options_.qos == 0) in_flight_.clear();
  link_up_ = true;
  resync_since_ = in_flight_.empty() ? 0 : now_s();
  if (pending_ && resync_since_ == 0) send_locked();
}

void MqttPublisher::on_delivered(int mid) {
  std::lock_guard lock(mutex_);
  if (in_flight_.erase(mid) == 0) return;  // the status, or a list from before a resync timeout
  ++stats_.lists_delivered;
  if (in_flight_.empty()) resync_since_ = 0;
  if (pending_ && link_up_ && resync_since_ == 0 && in_flight_.size() < options_.max_in_flight) send_locked();
}

void MqttPublisher::set_status(const std::string& json_object) {
  std::lock_guard lock(mutex_);
  status_json_ = json_object;
}

void MqttPublisher::publish(const LightList& list) {
  std::string json = to_json(list, false);
  std::lock_guard lock(mutex_);
  if (pending_) ++stats_.lists_dropped;  // replaced before it could go out
  pending_ = std::move(json);
  if (resync_since_ > 0 && now_s() - resync_since_ > kResyncLimitS) in_flight_.clear(), resync_since_ = 0;
  if (link_up_ && resync_since_ == 0 && in_flight_.size() < options_.max_in_flight) send_locked();
}

void MqttPublisher::send_locked() {
  int mid = 0;
  if (!connection_->publish(lights_topic_, *pending_, options_.qos, true, &mid)) {
    link_up_ = false;  // kept pending until the next connection
    return;
  }
  in_flight_.insert(mid);
  ++stats_.lists_published;
  pending_.reset();
}

MqttPublisherStats MqttPublisher::stats() const {
  std::lock_guard lock(mutex_);
  MqttPublisherStats s = stats_;
  s.link = connection_->stats();
  return s;
}

std::string MqttPublisher::metrics(const std::vector<std::pair<std::string, MqttLinkStats>>& other_links) const {
  const MqttPublisherStats s = stats();
  return fmt::format(
             "# HELP lightprobe_mqtt_lists_published_total Light lists handed to the MQTT broker.\n"
             "# TYPE lightprobe_mqtt_lists_published_total counter\nlightprobe_mqtt_lists_published_total {}\n"
             "# HELP lightprobe_mqtt_lists_delivered_total Light lists the broker acknowledged (QoS 1) or that were "
             "written (QoS 0).\n"
             "# TYPE lightprobe_mqtt_lists_delivered_total counter\nlightprobe_mqtt_lists_delivered_total {}\n"
             "# HELP lightprobe_mqtt_lists_dropped_total Light lists replaced by a newer one before the link let them "
             "out.\n"
             "# TYPE lightprobe_mqtt_lists_dropped_total counter\nlightprobe_mqtt_lists_dropped_total {}\n",
             s.lists_published, s.lists_delivered, s.lists_dropped) +
         [&] {
           auto links = other_links;
           links.emplace_back("publish", s.link);
           return mqtt_link_metrics(links);
         }();
}

}  // namespace lp
