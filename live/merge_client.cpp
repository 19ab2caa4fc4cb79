#include "live/merge_client.h"

#include <fmt/format.h>
#include <httplib.h>

#include <chrono>
#include <memory>
#include <thread>

#include "core/error.h"

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
    if (p != "/" && !p.empty()) e.path = p;
    rest = rest.substr(0, slash);
  }
  const auto colon = rest.rfind(':');
  e.host = rest.substr(0, colon);
  if (colon != std::string::npos) {
    try {
      e.port = std::stoi(rest.substr(colon + 1));
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

}  // namespace

void run_merge_client(const std::vector<std::string>& urls, const MergeClientOptions& options,
                      const std::function<void(const LightList&, const MergeState&)>& publish,
                      const std::atomic<bool>& stop) {
  if (urls.empty()) throw InputError("merge needs at least one server URL");
  std::vector<Endpoint> endpoints;
  for (const auto& u : urls) endpoints.push_back(parse_url(u));
  std::vector<std::unique_ptr<httplib::Client>> clients;
  std::vector<MergeInput> inputs;
  for (const Endpoint& e : endpoints) {
    auto c = std::make_unique<httplib::Client>(e.host, e.port);
    const auto secs = time_t(options.request_timeout_s);
    const auto usecs = time_t((options.request_timeout_s - double(secs)) * 1e6);
    c->set_connection_timeout(secs, usecs);
    c->set_read_timeout(secs, usecs);
    if (!options.token.empty()) c->set_bearer_token_auth(options.token.c_str());
    clients.push_back(std::move(c));
    inputs.push_back({e.url, std::nullopt, 0});
  }
  MergeState state;
  int64_t last_frame_out = -1;
  while (!stop) {
    const double t = now_s();
    for (size_t i = 0; i < clients.size(); ++i) {
      auto r = clients[i]->Get(endpoints[i].path.c_str());
      if (!r || r->status != 200) continue;
      try {
        inputs[i].latest = light_list_from_json(r->body, endpoints[i].url);
        inputs[i].last_seen_s = t;
      } catch (const InputError&) {
        // A malformed answer counts as silence.
      }
    }
    LightList merged = merge_available(inputs, now_s(), options.timeout_s, state, options.merge);
    merged.frame = ++last_frame_out;
    publish(merged, state);
    std::this_thread::sleep_for(std::chrono::duration<double>(options.poll_interval_s));
  }
}

}  // namespace lp
