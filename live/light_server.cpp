#include "live/light_server.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <random>

#include "core/error.h"
#include "live/map_views.h"
#include "live/metrics.h"
#include "live/web_assets.h"
#include "live/web_page.h"

namespace lp {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

bool is_loopback(const std::string& host) {
  if (host == "localhost" || host == "::1" || host == "[::1]") return true;
  // 127.0.0.0/8 in dotted form.
  if (host.rfind("127.", 0) != 0) return false;
  int dots = 0;
  for (char c : host) {
    if (c == '.') ++dots;
    else if (c < '0' || c > '9') return false;
  }
  return dots == 3;
}

// Time depends on the token's length only, never on where a guess first differs.
bool constant_time_equal(std::string_view given, const std::string& token) {
  unsigned char diff = given.size() == token.size() ? 0 : 1;
  for (size_t i = 0; i < token.size(); ++i) {
    const unsigned char x = i < given.size() ? static_cast<unsigned char>(given[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ static_cast<unsigned char>(token[i]));
  }
  return diff == 0;
}

std::string dump(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

HttpResponse json_response(int status, std::string body) {
  HttpResponse r;
  r.status = status;
  r.set_body(std::move(body), "application/json");
  return r;
}

HttpResponse error_response(int status, const std::string& message) {
  return json_response(status, http_error_json(message));
}

// One published frame, shared read-only by every request that serves it.
struct Snapshot {
  uint64_t generation = 0;
  std::shared_ptr<const LightList> lists;
  const LightList& list() const { return *lists; }
  std::string etag;                          // of /lights
  std::shared_ptr<const EnvMap> map;
  std::shared_ptr<const std::string> json;  // one line, no trailing newline
  std::shared_ptr<const std::string> body;  // json + "\n", as /lights and NDJSON streams send it
  std::shared_ptr<const std::string> sse;   // "data: " json "\n\n"
  std::shared_ptr<const std::string> sh;    // /sh: sh.json of the list's map SH9; null without one
  std::string sh_etag;
  double latency = NAN;                      // publish wall time - list timestamp (s)
};

// FNV-1a, for the ETag of /status (a change detector, not a secret).
uint64_t fnv1a(std::string_view text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

constexpr const char* kRevalidate = "no-cache";  // clients may keep answers but must ask (ETag) every time

HttpResponse nothing_published() {
  HttpResponse r = error_response(503, "no light list published yet");
  r.headers.emplace_back("Retry-After", "1");
  return r;
}

// A JSON answer of one published list, with its tag: a poller that has it already gets
// 304 and no body.
HttpResponse tagged_json(const HttpRequest& req, std::shared_ptr<const std::string> body, const std::string& etag) {
  if (http_etag_matches(req.header("if-none-match"), etag)) return http_not_modified(etag, kRevalidate);
  HttpResponse r;
  r.body = std::move(body);
  r.content_type = "application/json";
  r.headers = {{"ETag", etag}, {"Cache-Control", kRevalidate}};
  return r;
}

}  // namespace

struct LightServer::Impl {
  LightServerOptions options;
  std::unique_ptr<HttpServer> http;
  std::mutex lifecycle;
  bool started = false, stopped = false;
  std::atomic<bool> stopping{false};
  const Clock::time_point created = Clock::now();

  // Latest state.
  mutable std::mutex state_mutex;
  std::shared_ptr<const Snapshot> latest;
  std::string pipeline_metrics;
  std::map<std::string, nlohmann::json> status_sections;
  std::deque<Clock::time_point> publish_times;  // the last few, for fps

  // Stream clients.
  std::mutex clients_mutex;
  std::map<std::shared_ptr<HttpStream>, bool> clients;  // -> NDJSON (else SSE)

  MapFrame latest_map;  // under state_mutex: the newest frame published with a map
  std::string etag_prefix;  // random per server: tags of an earlier run never match
  std::unique_ptr<MapViews> views;  // /probe.png, /probe.exr

  // Counters.
  std::atomic<uint64_t> published{0}, stream_sent{0}, stream_dropped{0};
  std::atomic<int64_t> stream_clients{0};

  explicit Impl(LightServerOptions o) : options(std::move(o)) {}

  std::shared_ptr<const Snapshot> snapshot() const {
    std::lock_guard lock(state_mutex);
    return latest;
  }

  double fps() const {
    std::lock_guard lock(state_mutex);
    if (publish_times.size() < 2) return 0;
    if (Clock::now() - publish_times.back() > 5s) return 0;
    const double span = std::chrono::duration<double>(publish_times.back() - publish_times.front()).count();
    return span > 0 ? double(publish_times.size() - 1) / span : 0;
  }

  // "Authorization: Bearer <token>", the scheme exactly so (issue 22: no lower-case
  // variants, no query parameter that would end up in logs and browser history).
  bool authorized(const HttpRequest& req) const {
    if (!options.token) return true;
    const std::string* auth = req.header("authorization");
    static constexpr std::string_view kBearer = "Bearer ";
    if (!auth || auth->size() <= kBearer.size() || auth->compare(0, kBearer.size(), kBearer) != 0) return false;
    return constant_time_equal(std::string_view(*auth).substr(kBearer.size()), *options.token);
  }

  void handle(const HttpRequest& req, HttpExchange& ex);
  void handle_stream(const HttpRequest& req, HttpExchange& ex);
  void handle_map(MapView view, const HttpRequest& req, HttpExchange& ex);
  HttpResponse lights_response(const HttpRequest& req) const;
  HttpResponse sh_response(const HttpRequest& req) const;
  HttpResponse status_response(const HttpRequest& req) const;
  HttpResponse metrics_response() const;
  nlohmann::json status_json() const;
};

void LightServer::Impl::handle(const HttpRequest& req, HttpExchange& ex) {
  if (req.path == "/") {  // static, public: it holds no data (the token comes from the fragment)
    HttpResponse r;
    r.set_body(std::string(kWebPage), "text/html; charset=utf-8");
    r.headers.emplace_back("Cache-Control", "no-cache");
    ex.respond(std::move(r));
    return;
  }
  if (answer_web_asset(req, ex)) return;  // three.js for the page: public like the page
  if (!authorized(req)) {
    HttpResponse r = error_response(401, "missing or wrong bearer token (Authorization: Bearer <token>)");
    r.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"lightprobe\"");
    ex.respond(std::move(r));
    return;
  }
  // The data routes take no query parameter but /lights/stream's format: anything else was
  // dropped (?frame=3 served the latest list) with 200.
  const bool data_route = req.path == "/lights" || req.path == "/lights/stream" || req.path == "/probe.png" ||
                          req.path == "/probe.exr" || req.path == "/status" || req.path == "/metrics" || req.path == "/sh";
  if (data_route) {
    const auto problem = req.path == "/lights/stream" ? req.query_problem({"format"}) : req.query_problem({});
    if (problem) return ex.respond(error_response(400, *problem));
  }
  // What the route serves, against the Accept header: a client that reads only JSON asking
  // for /probe.png got a PNG with 200. (The stream's format is negotiated in handle_stream.)
  if (data_route && req.path != "/lights/stream") {
    const char* type = req.path == "/probe.png"   ? "image/png"
                       : req.path == "/probe.exr" ? "image/x-exr"
                       : req.path == "/metrics"   ? "text/plain"
                                                  : "application/json";
    if (req.accept_quality(type) <= 0)
      return ex.respond(error_response(406, fmt::format("{} is {}, which the Accept header does not take", req.path, type)));
  }
  if (req.path == "/lights") return ex.respond(lights_response(req));
  if (req.path == "/lights/stream") return handle_stream(req, ex);
  if (req.path == "/probe.png") return handle_map(MapView::Png, req, ex);
  if (req.path == "/probe.exr") return handle_map(MapView::Exr, req, ex);
  if (req.path == "/status") return ex.respond(status_response(req));
  if (req.path == "/metrics") return ex.respond(metrics_response());
  if (req.path == "/sh") return ex.respond(sh_response(req));
  ex.respond(error_response(404, "no such path: " + req.path.substr(0, 200)));
}

HttpResponse LightServer::Impl::lights_response(const HttpRequest& req) const {
  const auto snap = snapshot();
  if (!snap) return nothing_published();
  return tagged_json(req, snap->body, snap->etag);
}

// sh.json as `lightprobe sh` writes it, of the map the latest list was sampled from. Only
// a list whose "sh9" is the map's: a residual is not the map's SH and would be a wrong
// answer under the same name.
HttpResponse LightServer::Impl::sh_response(const HttpRequest& req) const {
  const auto snap = snapshot();
  if (!snap) return nothing_published();
  if (!snap->sh) return error_response(404, "the latest light list carries no SH9 of its map");
  return tagged_json(req, snap->sh, snap->sh_etag);
}

void LightServer::Impl::handle_stream(const HttpRequest& req, HttpExchange& ex) {
  // ?format= chooses; without it the Accept header does (EventSource sends
  // text/event-stream, an NDJSON reader application/x-ndjson), server-sent events on a tie.
  const double q_sse = req.accept_quality("text/event-stream"), q_ndjson = req.accept_quality("application/x-ndjson");
  const std::optional<std::string> given = req.query_param("format");
  const std::string format = given ? *given : q_ndjson > q_sse ? "ndjson" : "sse";
  if (format != "sse" && format != "ndjson") return ex.respond(error_response(400, "format must be sse or ndjson"));
  const bool ndjson = format == "ndjson";
  if ((ndjson ? q_ndjson : q_sse) <= 0)
    return ex.respond(error_response(
        406, given ? fmt::format("format={} is {}, which the Accept header does not take", format,
                                 ndjson ? "application/x-ndjson" : "text/event-stream")
                   : "/lights/stream is text/event-stream or application/x-ndjson; the Accept header takes neither"));
  HttpResponse head;
  head.content_type = ndjson ? "application/x-ndjson" : "text/event-stream";
  head.headers = {{"Cache-Control", "no-cache"}, {"X-Accel-Buffering", "no"}};
  if (req.is_head()) return ex.respond(std::move(head));
  if (stopping) return ex.respond(error_response(503, "server is stopping"));
  if (stream_clients.fetch_add(1) >= options.max_streams) {
    stream_clients.fetch_sub(1);
    HttpResponse r = error_response(503, fmt::format("too many stream clients (at most {})", options.max_streams));
    r.headers.emplace_back("Retry-After", "5");
    return ex.respond(std::move(r));
  }
  auto holder = std::make_shared<std::weak_ptr<HttpStream>>();
  HttpStreamOptions so;
  so.queue_pieces = options.stream_queue;
  if (!ndjson) so.heartbeat = ": lightprobe\n\n";
  so.on_close = [this, holder] {  // on the server's loop thread
    std::lock_guard lock(clients_mutex);
    if (auto s = holder->lock(); s && clients.erase(s)) stream_clients.fetch_sub(1);
  };
  auto stream = ex.stream(std::move(head), std::move(so));
  std::lock_guard lock(clients_mutex);
  if (stream->closed()) {  // gone already (on_close ran before it was registered)
    stream_clients.fetch_sub(1);
    return;
  }
  *holder = stream;
  clients.emplace(stream, ndjson);
  // The current list first, so that a new client has something to show at once.
  if (auto snap = snapshot()) stream->push(ndjson ? snap->body : snap->sse);
}

void LightServer::Impl::handle_map(MapView view, const HttpRequest& req, HttpExchange& ex) {
  if (!options.serves_maps)
    return ex.respond(error_response(404, "this server merges light lists and has no map (ask a camera's stream)"));
  if (!snapshot()) {
    HttpResponse r = error_response(503, "no frame published yet");
    r.headers.emplace_back("Retry-After", "1");
    return ex.respond(std::move(r));
  }
  MapFrame frame;
  {
    std::lock_guard lock(state_mutex);
    frame = latest_map;
  }
  views->answer(view, frame, req, ex);
}

nlohmann::json LightServer::Impl::status_json() const {
  const auto snap = snapshot();
  const HttpServerStats h = http ? http->stats() : HttpServerStats{};
  nlohmann::json j;
  j["frame"] = snap ? nlohmann::json(snap->list().frame) : nlohmann::json(nullptr);
  j["timestamp"] = snap ? nlohmann::json(snap->list().timestamp) : nlohmann::json(nullptr);
  j["method"] = snap ? nlohmann::json(snap->list().method) : nlohmann::json(nullptr);
  j["lights"] = snap ? snap->list().lights.size() : 0;
  j["fps"] = fps();
  j["latency_seconds"] = snap && std::isfinite(snap->latency) ? nlohmann::json(snap->latency) : nlohmann::json(nullptr);
  j["lists_published"] = published.load();
  j["clients_connected"] = h.connections_open;
  j["stream_clients"] = stream_clients.load();
  j["requests_served"] = h.requests;
  j["stream_lists_dropped"] = stream_dropped.load();
  j["connections_rejected"] = h.rejected_per_address + h.rejected_global;
  j["request_timeouts"] = h.head_timeouts;
  j["uptime_seconds"] = std::chrono::duration<double>(Clock::now() - created).count();
  std::lock_guard lock(state_mutex);
  for (const auto& [section, value] : status_sections) j[section] = value;
  return j;
}

// The ETag of /status is weak: it covers every field but the three that move with every
// request (uptime, requests served, connections open), so a poller of an idle server
// gets 304 while the body it keeps differs from a fresh one only in those.
HttpResponse LightServer::Impl::status_response(const HttpRequest& req) const {
  nlohmann::json j = status_json();
  nlohmann::json stable = j;
  for (const char* volatile_field : {"uptime_seconds", "requests_served", "clients_connected"})
    stable.erase(volatile_field);
  const std::string etag = fmt::format("W/\"{}-s{:016x}\"", etag_prefix, fnv1a(dump(stable)));
  if (http_etag_matches(req.header("if-none-match"), etag)) return http_not_modified(etag, kRevalidate);
  HttpResponse r = json_response(200, dump(j) + "\n");
  r.headers = {{"ETag", etag}, {"Cache-Control", kRevalidate}};
  return r;
}

HttpResponse LightServer::Impl::metrics_response() const {
  std::string out;
  {
    std::lock_guard lock(state_mutex);
    out = pipeline_metrics;
  }
  if (!out.empty() && out.back() != '\n') out += '\n';
  const auto snap = snapshot();
  const HttpServerStats h = http ? http->stats() : HttpServerStats{};
  MetricsText m;
  m.gauge("lightprobe_frame_rate_hertz", "Light lists published per second, over the last 32.", fps());
  m.counter("lightprobe_server_lists_published_total", "Light lists published.", double(published.load()));
  m.gauge("lightprobe_server_clients_connected", "Open HTTP connections.", double(h.connections_open));
  m.gauge("lightprobe_server_stream_clients", "Clients connected to /lights/stream.", double(stream_clients.load()));
  m.counter("lightprobe_server_requests_total", "HTTP requests handled.", double(h.requests));
  m.counter("lightprobe_server_stream_lists_sent_total", "Light lists queued to stream clients and not dropped.",
            double(stream_sent.load()));
  m.counter("lightprobe_server_stream_lists_dropped_total",
            "Light lists dropped because a stream client's queue was full.", double(stream_dropped.load()));
  m.family("lightprobe_server_connections_rejected_total", "counter",
           "Connections answered 503 by the connection caps.");
  m.sample("lightprobe_server_connections_rejected_total", double(h.rejected_per_address), "cap=\"per_address\"");
  m.sample("lightprobe_server_connections_rejected_total", double(h.rejected_global), "cap=\"global\"");
  m.counter("lightprobe_server_request_timeouts_total", "Request heads too slow (a line or the whole head): 408.",
            double(h.head_timeouts));
  m.counter("lightprobe_server_bad_requests_total", "Requests refused by the request policy (400, 405, 413, 417, 431).",
            double(h.bad_requests));
  m.counter("lightprobe_server_write_timeouts_total", "Answers or streams abandoned because the client did not read.",
            double(h.write_timeouts));
  if (snap) {
    m.gauge("lightprobe_server_frame", "Frame number of the latest list.", double(snap->list().frame));
    m.gauge("lightprobe_server_lights", "Lights in the latest list.", double(snap->list().lights.size()));
    if (std::isfinite(snap->latency))
      m.gauge("lightprobe_server_list_age_seconds", "Publish time minus the latest list's timestamp.", snap->latency);
  }
  HttpResponse r;
  r.set_body(out + m.text(), "text/plain; version=0.0.4; charset=utf-8");
  r.headers.emplace_back("Cache-Control", "no-store");
  return r;
}

LightServer::LightServer(LightServerOptions options) {
  if (options.stream_queue < 1 || options.stream_queue > 100000)
    throw InputError(fmt::format("light server: stream queue is {}, expected 1..100000", options.stream_queue));
  if (options.max_streams < 0 || options.max_streams > 100000)
    throw InputError(fmt::format("light server: max streams is {}, expected 0..100000", options.max_streams));
  if (options.port < 0 || options.port > 65535)
    throw InputError(fmt::format("light server: port {} is not in 0..65535", options.port));
  if (options.host.empty()) throw InputError("light server: empty host");
  if (options.token && options.token->empty()) throw InputError("--token: empty token");
  if (!options.token && !is_loopback(options.host))
    throw InputError(fmt::format("listening on {} needs --token", options.host));
  impl_ = std::make_unique<Impl>(std::move(options));
  std::random_device rd;
  impl_->etag_prefix = fmt::format("{:08x}{:08x}", rd(), rd());
  MapViewOptions mv;
  mv.png_width = impl_->options.preview_width;
  mv.max_png_rate = impl_->options.preview_max_rate;
  mv.png_time_constant_s = impl_->options.preview_time_constant_s;
  mv.etag_prefix = impl_->etag_prefix;
  impl_->views = std::make_unique<MapViews>(mv);
  HttpServerOptions ho;
  ho.host = impl_->options.host;
  ho.port = impl_->options.port;
  ho.limits = impl_->options.limits;
  Impl* s = impl_.get();
  impl_->http = std::make_unique<HttpServer>(ho, [s](const HttpRequest& req, HttpExchange& ex) { s->handle(req, ex); });
}

LightServer::~LightServer() { stop(); }

int LightServer::start() {
  Impl& s = *impl_;
  std::lock_guard lock(s.lifecycle);
  if (s.started || s.stopped) throw std::logic_error("LightServer::start: already started");
  s.views->start();
  const int port = s.http->start();
  s.started = true;
  return port;
}

void LightServer::stop() {
  if (!impl_) return;
  Impl& s = *impl_;
  std::lock_guard lock(s.lifecycle);
  if (!s.started) return;
  s.stopping = true;
  s.http->stop();  // ends the streams, closes every connection
  s.views->stop();
  {
    std::lock_guard clients_lock(s.clients_mutex);
    s.clients.clear();
    s.stream_clients = 0;
  }
  s.started = false;
  s.stopped = true;
}

int LightServer::port() const { return impl_->http->port(); }

void LightServer::publish(const LightList& list, std::shared_ptr<const EnvMap> map_for_preview) {
  Impl& s = *impl_;
  auto snap = std::make_shared<Snapshot>();
  snap->lists = std::make_shared<const LightList>(list);
  snap->map = std::move(map_for_preview);
  const std::string json = to_json(list, false);
  snap->json = std::make_shared<const std::string>(json);
  snap->body = std::make_shared<const std::string>(json + "\n");
  snap->sse = std::make_shared<const std::string>("data: " + json + "\n\n");
  if (list.sh9 && list.sh9_content == Sh9Content::Map)
    snap->sh = std::make_shared<const std::string>(sh9_to_json(*list.sh9, list.units));
  const double now_wall = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  if (list.timestamp > 1e9) {  // looks like Unix time: latency is meaningful
    const double latency = now_wall - list.timestamp;
    if (latency > -1 && latency < 3600) snap->latency = std::max(0.0, latency);
  }
  {
    std::lock_guard lock(s.state_mutex);
    snap->generation = s.latest ? s.latest->generation + 1 : 1;
    snap->etag = fmt::format("\"{}-l{}\"", s.etag_prefix, snap->generation);
    snap->sh_etag = fmt::format("\"{}-h{}\"", s.etag_prefix, snap->generation);
    if (snap->map) s.latest_map = {snap->generation, snap->map, snap->lists};
    s.latest = snap;
    s.publish_times.push_back(Clock::now());
    while (s.publish_times.size() > 32) s.publish_times.pop_front();
  }
  s.published.fetch_add(1);
  std::lock_guard lock(s.clients_mutex);
  for (const auto& [client, ndjson] : s.clients) {
    const int dropped = client->push(ndjson ? snap->body : snap->sse);
    if (dropped < 0) continue;  // closing: on_close removes it
    s.stream_dropped.fetch_add(uint64_t(dropped));
    s.stream_sent.fetch_add(1);
    if (dropped > 0) s.stream_sent.fetch_sub(uint64_t(dropped));
  }
}

void LightServer::publish_metrics(const std::string& prometheus_text) {
  std::lock_guard lock(impl_->state_mutex);
  impl_->pipeline_metrics = prometheus_text;
}

void LightServer::publish_status(const std::string& section, const std::string& json_object) {
  nlohmann::json j = nlohmann::json::parse(json_object, nullptr, false);
  if (j.is_discarded() || !j.is_object())
    throw InputError(fmt::format("light server: status section '{}' is not a JSON object", section));
  std::lock_guard lock(impl_->state_mutex);
  impl_->status_sections[section] = std::move(j);
}

LightServerStats LightServer::stats() const {
  const Impl& s = *impl_;
  LightServerStats st;
  st.http = s.http->stats();
  st.lists_published = s.published.load();
  st.requests_served = st.http.requests;
  st.stream_lists_sent = s.stream_sent.load();
  st.stream_lists_dropped = s.stream_dropped.load();
  st.clients_connected = st.http.connections_open;
  st.stream_clients = s.stream_clients.load();
  return st;
}

void LightServer::answer(const HttpRequest& request, HttpExchange& exchange) { impl_->handle(request, exchange); }

}  // namespace lp
