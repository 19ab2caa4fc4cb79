#include "live/merge_client.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <thread>

#include "core/error.h"
#include "live/http_client_plugin.h"

namespace lp {

namespace {

struct Endpoint {
  std::string url, host, path = "/lights";
  int port = 80;
};

Endpoint parse_url(const std::string& url) {
  // http://HOST:PORT[/path]; only plain HTTP (the servers listen on trusted networks).
  const std::string prefix = "http://";
  if (url.rfind(prefix, 0) != 0) throw InputError(fmt::format("{}: only http://HOST:PORT URLs are supported", url));
  Endpoint e;
  e.url = url;
  std::string rest = url.substr(prefix.size());
  const auto slash = rest.find('/');
  if (slash != std::string::npos) {
    const std::string p = rest.substr(slash);
    // A camera's lights are at /lights: /lights/stream never ends (the merge hung, past
    // --duration) and /metrics is no light list (every round failed, with exit 0).
    if (p != "/" && p != "/lights")
      throw InputError(fmt::format("{}: give the camera's server, http://HOST:PORT (its lights at /lights), not {}", url, p));
    rest = rest.substr(0, slash);
  }
  const auto colon = rest.rfind(':');
  e.host = rest.substr(0, colon);
  if (colon != std::string::npos) {
    try {
      size_t used = 0;
      e.port = std::stoi(rest.substr(colon + 1), &used);
      if (used != rest.size() - colon - 1 || e.port < 1 || e.port > 65535) throw std::invalid_argument("port");
    } catch (const std::exception&) {
      throw InputError(fmt::format("{}: bad port", url));
    }
  }
  if (e.host.empty()) throw InputError(fmt::format("{}: no host", url));
  return e;
}

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// One upstream: its connection.
struct Upstream {
  Endpoint endpoint;
  std::unique_ptr<detail::HttpGetClient> client;  // cpp-httplib's, in live/http_client_plugin.h's plugin
};

// Fetches one upstream's list into `input` (and `status`, and `malformed`: why its answer
// was not a light list); never throws.
void poll(Upstream& up, MergeInput& input, MergeInputStatus& status, std::string& malformed,
          const MergeClientOptions& options, double t) {
  // No If-None-Match: cpp-httplib 0.11 reads a 304 (which has no body and no length) until
  // the connection closes, so every conditional poll would time out.
  // The whole request within request_timeout_s, however the upstream trickles its bytes.
  const double deadline = now_s() + options.request_timeout_s;
  auto progress = [&](uint64_t current) { return now_s() < deadline && current <= options.max_body_bytes; };
  int code = 0;
  std::string body;
  if (!up.client->get(up.endpoint.path, progress, code, body) || code != 200) {
    ++status.polls_failed;
    return;
  }
  ++status.polls_ok;
  try {
    input.latest = light_list_from_json(body, up.endpoint.url);
    input.last_seen_s = t;
    malformed.clear();
  } catch (const std::exception& e) {
    // Alive but unusable: its older list must not stand in for it.
    input.latest.reset();
    malformed = e.what();
  }
}

// Fills the per-input states from the round's merge report.
void update_status(MergeClientStatus& status, const std::vector<std::string>& malformed, const MergeState& st) {
  for (size_t i = 0; i < status.inputs.size(); ++i) {
    MergeInputStatus& in = status.inputs[i];
    in.reason.clear();
    in.detail.clear();
    in.state = "silent";
    if (std::find(st.used.begin(), st.used.end(), in.name) != st.used.end()) in.state = "used";
    for (const MergeSkip& s : st.skipped)
      if (s.name == in.name) in.state = "skipped", in.reason = s.code, in.detail = s.detail;
    if (i < malformed.size() && !malformed[i].empty()) in.state = "skipped", in.reason = "malformed", in.detail = malformed[i];
    if (in.state == "skipped") ++in.skipped[in.reason];
  }
}

std::string label_value(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

}  // namespace

std::optional<LightList> merge_round(const std::vector<MergeInput>& inputs, const std::vector<std::string>& malformed,
                                     const MergeClientOptions& options, MergeClientStatus& status) {
  for (size_t i = status.inputs.size(); i < inputs.size(); ++i) status.inputs.emplace_back().name = inputs[i].name;
  LightList merged = merge_available(inputs, now_s(), options.timeout_s, status.state, options.merge);
  ++status.rounds;
  update_status(status, malformed, status.state);
  status.error = status.state.error;
  if (status.state.stale) {
    ++status.stale_rounds;
    return std::nullopt;
  }
  status.mode = to_string(status.state.mode);
  merged.frame = int64_t(status.lists_out++);
  return merged;
}

void run_merge_client(const std::vector<std::string>& urls, const MergeClientOptions& options,
                      const std::function<void(const LightList&, const MergeClientStatus&)>& publish,
                      const std::atomic<bool>& stop) {
  if (urls.empty()) throw InputError("merge needs at least one server URL");
  std::vector<Upstream> ups;
  std::vector<MergeInput> inputs;
  MergeClientStatus status;
  for (const std::string& u : urls) {
    Upstream up;
    up.endpoint = parse_url(u);
    // The same server twice counted its camera twice (2/3 of the weight beside a third).
    auto same_host = [](const std::string& a, const std::string& b) {
      auto loopback = [](const std::string& h) { return h == "localhost" || h == "127.0.0.1" || h == "::1" || h == "[::1]"; };
      return a == b || (loopback(a) && loopback(b));
    };
    for (const Upstream& seen : ups)
      if (seen.endpoint.port == up.endpoint.port && same_host(seen.endpoint.host, up.endpoint.host))
        throw InputError(fmt::format("{} and {} are the same server: each camera once", seen.endpoint.url, u));
    up.client.reset(detail::http_client_plugin().new_client(up.endpoint.host, up.endpoint.port,
                                                            options.request_timeout_s, options.token));
    inputs.push_back({u, std::nullopt, 0});
    status.inputs.emplace_back().name = u;
    ups.push_back(std::move(up));
  }
  std::vector<std::string> malformed(ups.size());
  while (!stop) {
    try {
      const double t = now_s();
      for (size_t i = 0; i < ups.size(); ++i) poll(ups[i], inputs[i], status.inputs[i], malformed[i], options, t);
      if (std::optional<LightList> merged = merge_round(inputs, malformed, options, status)) publish(*merged, status);
    } catch (const std::exception& e) {
      // A bad option is found before the loop; anything else ends this round only.
      status.error = e.what();
      ++status.stale_rounds;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(options.poll_interval_s));
  }
}

std::string merge_status_json(const MergeClientStatus& status) {
  nlohmann::json j;
  j["rounds"] = status.rounds;
  j["stale_rounds"] = status.stale_rounds;
  j["mode"] = status.mode;
  j["error"] = status.error;
  j["inputs"] = nlohmann::json::array();
  for (const MergeInputStatus& in : status.inputs) {
    nlohmann::json o{{"url", in.name}, {"state", in.state}, {"polls_ok", in.polls_ok},
                     {"polls_failed", in.polls_failed}, {"skipped", in.skipped}};
    if (!in.reason.empty()) o["reason"] = in.reason, o["detail"] = in.detail;
    j["inputs"].push_back(o);
  }
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string merge_metrics_text(const MergeClientStatus& status) {
  size_t used = 0;
  for (const MergeInputStatus& in : status.inputs) used += in.state == "used";
  std::string m = fmt::format(
      "# HELP lightprobe_merge_inputs_used Inputs merged by the last round.\n"
      "# TYPE lightprobe_merge_inputs_used gauge\nlightprobe_merge_inputs_used {}\n"
      "# HELP lightprobe_merge_rounds_total Merge rounds attempted.\n"
      "# TYPE lightprobe_merge_rounds_total counter\nlightprobe_merge_rounds_total {}\n"
      "# HELP lightprobe_merge_stale_rounds_total Rounds that merged nothing (no usable input, or the merge failed).\n"
      "# TYPE lightprobe_merge_stale_rounds_total counter\nlightprobe_merge_stale_rounds_total {}\n",
      used, status.rounds, status.stale_rounds);
  m += "# HELP lightprobe_merge_input_polls_total Polls of each input, by outcome.\n"
       "# TYPE lightprobe_merge_input_polls_total counter\n";
  for (const MergeInputStatus& in : status.inputs) {
    const std::string url = label_value(in.name);
    m += fmt::format("lightprobe_merge_input_polls_total{{input=\"{}\",outcome=\"ok\"}} {}\n", url, in.polls_ok);
    m += fmt::format("lightprobe_merge_input_polls_total{{input=\"{}\",outcome=\"failed\"}} {}\n", url,
                     in.polls_failed);
  }
  m += "# HELP lightprobe_merge_input_skipped_total Merge rounds that left an input's list out, by reason.\n"
       "# TYPE lightprobe_merge_input_skipped_total counter\n";
  for (const MergeInputStatus& in : status.inputs)
    for (const auto& [reason, count] : in.skipped)
      m += fmt::format("lightprobe_merge_input_skipped_total{{input=\"{}\",reason=\"{}\"}} {}\n", label_value(in.name),
                       label_value(reason), count);
  return m + status.link_metrics;
}

}  // namespace lp
