#include "live/light_server.h"

#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "live/web_page.h"
#include "sampling/overlay.h"

namespace lp {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

constexpr size_t kMaxPayload = 64 * 1024;       // we accept no bodies at all
constexpr size_t kMaxHeaderBytes = 32 * 1024;   // all header lines together
constexpr auto kStreamPoll = 200ms;             // how often an idle stream checks for stop
constexpr auto kHeartbeat = 2s;                 // SSE comment so dead peers are noticed

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

bool constant_time_equal(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const size_t n = std::max(a.size(), b.size());
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ y);
  }
  return diff == 0;
}

std::string json_error(const std::string& message) { return nlohmann::json{{"error", message}}.dump() + "\n"; }

void set_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(json_error(message), "application/json");
}

// One published frame, shared read-only by every request that serves it.
struct Snapshot {
  uint64_t generation = 0;
  LightList list;
  std::shared_ptr<const EnvMap> map;
  std::shared_ptr<const std::string> json;  // one line, no trailing newline
  double latency = NAN;                      // publish wall time - list timestamp (s)
};

// A /lights/stream client: its own bounded queue of one-line JSON lists.
struct StreamClient {
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<std::shared_ptr<const std::string>> queue;
  uint64_t dropped = 0;
  bool ndjson = false;
};

// The server's task queue: a fixed pool that also counts the connections it holds
// (each task is one connection, served or waiting for a worker).
class CountingPool : public httplib::TaskQueue {
 public:
  CountingPool(size_t threads, std::atomic<int64_t>& active) : pool_(threads), active_(active) {}
  void enqueue(std::function<void()> fn) override {
    active_.fetch_add(1);
    pool_.enqueue([fn = std::move(fn), &active = active_] {
      struct Done {
        std::atomic<int64_t>& a;
        ~Done() { a.fetch_sub(1); }
      } done{active};
      fn();
    });
  }
  void shutdown() override { pool_.shutdown(); }

 private:
  httplib::ThreadPool pool_;
  std::atomic<int64_t>& active_;
};

std::string encode_png(const std::vector<float>& rgb, int width, int height) {
  cv::Mat img(height, width, CV_8UC3);
  auto encode = [](float v) {
    if (!(v > 0.0f)) return uint8_t(0);  // also NaN
    if (v >= 1.0f) return uint8_t(255);
    const double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(double(v), 1.0 / 2.4) - 0.055;
    return uint8_t(std::clamp(std::lround(s * 255.0), 0L, 255L));
  };
  for (int y = 0; y < height; ++y) {
    uint8_t* row = img.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      const float* p = &rgb[3 * (size_t(y) * size_t(width) + size_t(x))];
      row[3 * x] = encode(p[2]);  // OpenCV is BGR
      row[3 * x + 1] = encode(p[1]);
      row[3 * x + 2] = encode(p[0]);
    }
  }
  std::vector<uint8_t> buf;
  if (!cv::imencode(".png", img, buf)) throw std::runtime_error("light server: PNG encoder failed");
  return std::string(buf.begin(), buf.end());
}

void append_metric(std::string& out, const char* name, const char* type, const char* help, double value) {
  if (!std::isfinite(value)) return;
  out += fmt::format("# HELP {0} {1}\n# TYPE {0} {2}\n{0} {3}\n", name, help, type, value);
}

}  // namespace

struct LightServer::Impl {
  LightServerOptions options;
  httplib::Server server;
  std::thread thread;
  std::mutex lifecycle;  // start/stop
  bool started = false;
  bool stopped = false;  // an httplib::Server does not start twice
  int bound_port = 0;
  std::atomic<bool> stopping{false};
  const Clock::time_point created = Clock::now();

  // Latest state.
  mutable std::mutex state_mutex;
  std::shared_ptr<const Snapshot> latest;
  std::string pipeline_metrics;
  std::deque<Clock::time_point> publish_times;  // the last few, for fps

  // Stream clients.
  std::mutex clients_mutex;
  std::set<std::shared_ptr<StreamClient>> clients;

  // Preview cache; render_mutex serialises rendering so a burst of requests renders once.
  std::mutex render_mutex;
  uint64_t preview_generation = 0;
  Clock::time_point preview_time{};
  std::shared_ptr<const std::string> preview_png;

  // Counters.
  std::atomic<uint64_t> published{0}, requests{0}, stream_sent{0}, stream_dropped{0};
  std::atomic<int64_t> connections{0}, stream_clients{0};

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

  bool authorized(const httplib::Request& req) const {
    if (!options.token) return true;
    const std::string& token = *options.token;
    const std::string auth = req.get_header_value("Authorization");
    static constexpr std::string_view kBearer = "Bearer ";
    if (auth.size() > kBearer.size() && std::equal(kBearer.begin(), kBearer.end(), auth.begin(), [](char a, char b) {
          return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
        })) {
      if (constant_time_equal(auth.substr(kBearer.size()), token)) return true;
    }
    if (req.has_param("access_token") && constant_time_equal(req.get_param_value("access_token"), token)) return true;
    return false;
  }

  void setup();
  void handle_lights(const httplib::Request& req, httplib::Response& res);
  void handle_stream(const httplib::Request& req, httplib::Response& res);
  void handle_probe(const httplib::Request& req, httplib::Response& res);
  void handle_status(const httplib::Request& req, httplib::Response& res);
  void handle_metrics(const httplib::Request& req, httplib::Response& res);
  std::shared_ptr<const std::string> render_preview(const Snapshot& snap);
  nlohmann::json status_json() const;
};

void LightServer::Impl::setup() {
  const size_t stream_threads = size_t(std::max(0, options.max_streams));
  server.new_task_queue = [this, n = size_t(options.threads) + stream_threads] {
    return new CountingPool(n, connections);
  };
  server.set_payload_max_length(kMaxPayload);
  server.set_read_timeout(5, 0);
  server.set_write_timeout(5, 0);
  server.set_keep_alive_max_count(100);
  server.set_keep_alive_timeout(2);

  // Method filter, header limit and the token, before any route runs.
  server.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (req.method != "GET" && req.method != "HEAD") {
      const bool has_body = req.has_header("Transfer-Encoding") ||
                            (req.has_header("Content-Length") && req.get_header_value("Content-Length") != "0");
      const bool body_method = req.method == "POST" || req.method == "PUT" || req.method == "PATCH" ||
                               req.method == "DELETE";
      // A body is read (within the payload limit) by the 405 handlers below so that the
      // connection stays in step; without one, answer right here.
      if (has_body && body_method) return httplib::Server::HandlerResponse::Unhandled;
      res.set_header("Allow", "GET, HEAD");
      set_error(res, 405, "method " + req.method + " not allowed (GET or HEAD only)");
      return httplib::Server::HandlerResponse::Handled;
    }
    size_t header_bytes = 0;
    for (const auto& [key, value] : req.headers) header_bytes += key.size() + value.size() + 4;
    if (header_bytes > kMaxHeaderBytes) {
      set_error(res, 431, "request headers too large");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (!authorized(req)) {
      res.set_header("WWW-Authenticate", "Bearer realm=\"lightprobe\"");
      set_error(res, 401, "missing or wrong bearer token");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });

  auto not_allowed = [](const httplib::Request& req, httplib::Response& res) {
    res.set_header("Allow", "GET, HEAD");
    set_error(res, 405, "method " + req.method + " not allowed (GET or HEAD only)");
  };
  server.Post(".*", not_allowed);
  server.Put(".*", not_allowed);
  server.Patch(".*", not_allowed);
  server.Delete(".*", not_allowed);

  server.Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-cache");
    res.set_content(std::string(kWebPage), "text/html; charset=utf-8");
  });
  server.Get("/lights", [this](const httplib::Request& q, httplib::Response& r) { handle_lights(q, r); });
  server.Get("/lights/stream", [this](const httplib::Request& q, httplib::Response& r) { handle_stream(q, r); });
  server.Get("/probe.png", [this](const httplib::Request& q, httplib::Response& r) { handle_probe(q, r); });
  server.Get("/status", [this](const httplib::Request& q, httplib::Response& r) { handle_status(q, r); });
  server.Get("/metrics", [this](const httplib::Request& q, httplib::Response& r) { handle_metrics(q, r); });

  // Every error gets a JSON body unless its handler already wrote one.
  server.set_error_handler(httplib::Server::HandlerWithResponse([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty() || res.content_provider_) return httplib::Server::HandlerResponse::Unhandled;
    std::string message;
    switch (res.status) {
      case 400: message = "bad request"; break;
      case 404: message = "no such path: " + req.path.substr(0, 200); break;
      case 413: message = "payload too large"; break;
      case 414: message = "request URI too long"; break;
      case 416: message = "range not satisfiable"; break;
      default: message = fmt::format("HTTP error {}", res.status);
    }
    res.set_content(json_error(message), "application/json");
    return httplib::Server::HandlerResponse::Handled;
  }));
  server.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
    set_error(res, 500, "internal error");
  });
  server.set_logger([this](const httplib::Request&, const httplib::Response&) { requests.fetch_add(1); });
}

void LightServer::Impl::handle_lights(const httplib::Request&, httplib::Response& res) {
  res.set_header("Cache-Control", "no-store");
  const auto snap = snapshot();
  if (!snap) {
    res.set_header("Retry-After", "1");
    set_error(res, 503, "no light list published yet");
    return;
  }
  res.set_content(*snap->json + "\n", "application/json");
}

void LightServer::Impl::handle_stream(const httplib::Request& req, httplib::Response& res) {
  const std::string format = req.has_param("format") ? req.get_param_value("format") : "sse";
  if (format != "sse" && format != "ndjson") {
    set_error(res, 400, "format must be sse or ndjson");
    return;
  }
  const bool ndjson = format == "ndjson";
  const char* content_type = ndjson ? "application/x-ndjson" : "text/event-stream";
  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Accel-Buffering", "no");
  if (req.method == "HEAD") {
    res.set_header("Content-Type", content_type);
    return;
  }
  if (stopping) {
    set_error(res, 503, "server is stopping");
    return;
  }
  if (stream_clients.fetch_add(1) >= options.max_streams) {
    stream_clients.fetch_sub(1);
    res.set_header("Retry-After", "5");
    set_error(res, 503, fmt::format("too many stream clients (at most {})", options.max_streams));
    return;
  }
  auto client = std::make_shared<StreamClient>();
  client->ndjson = ndjson;
  {
    std::lock_guard lock(clients_mutex);
    clients.insert(client);
  }
  // The current list first, so that a new client has something to show at once.
  if (auto snap = snapshot()) {
    std::lock_guard lock(client->mutex);
    client->queue.push_back(snap->json);
  }

  auto last_write = std::make_shared<Clock::time_point>(Clock::time_point{});  // first call writes a hello
  res.set_chunked_content_provider(
      content_type,
      [this, client, last_write](size_t, httplib::DataSink& sink) -> bool {
        std::vector<std::shared_ptr<const std::string>> batch;
        {
          std::unique_lock lock(client->mutex);
          client->cv.wait_for(lock, kStreamPoll, [&] { return !client->queue.empty() || stopping.load(); });
          if (stopping) {
            lock.unlock();
            sink.done();
            return true;
          }
          batch.assign(client->queue.begin(), client->queue.end());
          client->queue.clear();
        }
        std::string out;
        for (const auto& json : batch) {
          if (client->ndjson) {
            out += *json;
            out += '\n';
          } else {
            out += "data: ";
            out += *json;
            out += "\n\n";
          }
        }
        const auto now = Clock::now();
        if (out.empty()) {
          // SSE comments keep proxies from timing out and let a dead peer be noticed.
          if (client->ndjson || now - *last_write < kHeartbeat) return true;
          out = ": lightprobe\n\n";
        }
        if (!sink.write(out.data(), out.size())) return false;
        *last_write = now;
        stream_sent.fetch_add(batch.size());
        return true;
      },
      [this, client](bool) {
        std::lock_guard lock(clients_mutex);
        if (clients.erase(client)) stream_clients.fetch_sub(1);
      });
}

std::shared_ptr<const std::string> LightServer::Impl::render_preview(const Snapshot& snap) {
  const EnvMap& map = *snap.map;
  int width = options.preview_width;
  if (width <= 0) width = map.layout == Layout::LatLong ? std::min(map.width, 1024) : 1024;
  width = std::max(2, width - width % 2);
  const std::vector<float> rgb = render_overlay(map, snap.list.lights, width);
  return std::make_shared<const std::string>(encode_png(rgb, width, width / 2));
}

void LightServer::Impl::handle_probe(const httplib::Request&, httplib::Response& res) {
  res.set_header("Cache-Control", "no-store");
  const auto snap = snapshot();
  if (!snap) {
    res.set_header("Retry-After", "1");
    set_error(res, 503, "no frame published yet");
    return;
  }
  std::shared_ptr<const std::string> png;
  {
    std::lock_guard lock(render_mutex);
    const auto now = Clock::now();
    const double rate = options.preview_max_rate > 0 ? options.preview_max_rate : 4;
    const auto min_interval = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
    const bool fresh = preview_png && (preview_generation == snap->generation || now - preview_time < min_interval);
    if (fresh) {
      png = preview_png;
    } else {
      // The newest frame with a map; a frame published without one keeps the last preview.
      std::shared_ptr<const Snapshot> source = snap->map ? snap : nullptr;
      if (source) {
        preview_png = render_preview(*source);
        preview_generation = source->generation;
        preview_time = now;
      }
      png = preview_png;
    }
  }
  if (!png) {
    set_error(res, 503, "no map published for the preview");
    return;
  }
  res.set_content(*png, "image/png");
}

nlohmann::json LightServer::Impl::status_json() const {
  const auto snap = snapshot();
  nlohmann::json j;
  j["frame"] = snap ? nlohmann::json(snap->list.frame) : nlohmann::json(nullptr);
  j["timestamp"] = snap ? nlohmann::json(snap->list.timestamp) : nlohmann::json(nullptr);
  j["method"] = snap ? nlohmann::json(snap->list.method) : nlohmann::json(nullptr);
  j["lights"] = snap ? snap->list.lights.size() : 0;
  j["fps"] = fps();
  j["latency_seconds"] = snap && std::isfinite(snap->latency) ? nlohmann::json(snap->latency) : nlohmann::json(nullptr);
  j["lists_published"] = published.load();
  j["clients_connected"] = connections.load();
  j["stream_clients"] = stream_clients.load();
  j["requests_served"] = requests.load();
  j["stream_lists_dropped"] = stream_dropped.load();
  j["uptime_seconds"] = std::chrono::duration<double>(Clock::now() - created).count();
  return j;
}

void LightServer::Impl::handle_status(const httplib::Request&, httplib::Response& res) {
  res.set_header("Cache-Control", "no-store");
  res.set_content(status_json().dump() + "\n", "application/json");
}

void LightServer::Impl::handle_metrics(const httplib::Request&, httplib::Response& res) {
  std::string out;
  {
    std::lock_guard lock(state_mutex);
    out = pipeline_metrics;
  }
  if (!out.empty() && out.back() != '\n') out += '\n';
  const auto snap = snapshot();
  append_metric(out, "lightprobe_server_clients_connected", "gauge",
                "HTTP connections being served or waiting for a worker.", double(connections.load()));
  append_metric(out, "lightprobe_server_stream_clients", "gauge", "Clients connected to /lights/stream.",
                double(stream_clients.load()));
  // This request is counted when its response is written; report it as served already.
  append_metric(out, "lightprobe_server_requests_total", "counter", "HTTP requests served.",
                double(requests.load() + 1));
  append_metric(out, "lightprobe_server_stream_lists_sent_total", "counter",
                "Light lists written to stream clients.", double(stream_sent.load()));
  append_metric(out, "lightprobe_server_stream_lists_dropped_total", "counter",
                "Light lists dropped because a stream client's queue was full.", double(stream_dropped.load()));
  append_metric(out, "lightprobe_server_lists_published_total", "counter", "Light lists published by the pipeline.",
                double(published.load()));
  append_metric(out, "lightprobe_server_publish_fps", "gauge", "Lists published per second, recently.", fps());
  if (snap) {
    append_metric(out, "lightprobe_server_frame", "gauge", "Frame number of the latest list.", double(snap->list.frame));
    append_metric(out, "lightprobe_server_lights", "gauge", "Lights in the latest list.",
                  double(snap->list.lights.size()));
    append_metric(out, "lightprobe_server_latency_seconds", "gauge",
                  "Publish time minus the latest list's timestamp.", snap->latency);
  }
  res.set_header("Cache-Control", "no-store");
  res.set_content(out, "text/plain; version=0.0.4; charset=utf-8");
}

LightServer::LightServer(LightServerOptions options) {
  if (options.threads < 1 || options.threads > 1024)
    throw InputError(fmt::format("light server: threads is {}, expected 1..1024", options.threads));
  if (options.stream_queue < 1 || options.stream_queue > 100000)
    throw InputError(fmt::format("light server: stream queue is {}, expected 1..100000", options.stream_queue));
  if (options.max_streams < 0 || options.max_streams > 1024)
    throw InputError(fmt::format("light server: max streams is {}, expected 0..1024", options.max_streams));
  if (options.port < 0 || options.port > 65535)
    throw InputError(fmt::format("light server: port {} is not in 0..65535", options.port));
  if (options.host.empty()) throw InputError("light server: empty host");
  if (options.token && options.token->empty()) throw InputError("--token: empty token");
  if (!options.token && !is_loopback(options.host))
    throw InputError(fmt::format("listening on {} needs --token", options.host));
  impl_ = std::make_unique<Impl>(std::move(options));
  impl_->setup();
}

LightServer::~LightServer() { stop(); }

int LightServer::start() {
  Impl& s = *impl_;
  std::lock_guard lock(s.lifecycle);
  if (s.started || s.stopped) throw std::logic_error("LightServer::start: already started");
  const std::string host = s.options.host == "[::1]" ? "::1" : s.options.host;
  int port = s.options.port;
  if (port == 0) {
    port = s.server.bind_to_any_port(host);
    if (port <= 0) throw InputError(fmt::format("light server: cannot listen on {} (no free port)", host));
  } else if (!s.server.bind_to_port(host, port)) {
    throw InputError(fmt::format("light server: cannot listen on {}:{} (address in use or not available)", host, port));
  }
  s.bound_port = port;
  s.started = true;
  s.thread = std::thread([&s] { s.server.listen_after_bind(); });
  // stop() only works once the accept loop runs; wait for it (bounded).
  const auto deadline = Clock::now() + 10s;
  while (!s.server.is_running() && Clock::now() < deadline) std::this_thread::sleep_for(1ms);
  return port;
}

void LightServer::stop() {
  if (!impl_) return;
  Impl& s = *impl_;
  std::lock_guard lock(s.lifecycle);
  if (!s.started) return;
  s.stopping = true;
  {
    std::lock_guard clients_lock(s.clients_mutex);
    for (const auto& client : s.clients) {
      std::lock_guard client_lock(client->mutex);
      client->cv.notify_all();
    }
  }
  s.server.stop();
  // listen_after_bind returns once the workers are done (streams end within kStreamPoll).
  if (s.thread.joinable()) s.thread.join();
  s.started = false;
  s.stopped = true;
}

int LightServer::port() const { return impl_->bound_port; }

void LightServer::publish(const LightList& list, std::shared_ptr<const EnvMap> map_for_preview) {
  Impl& s = *impl_;
  auto snap = std::make_shared<Snapshot>();
  snap->list = list;
  snap->map = std::move(map_for_preview);
  snap->json = std::make_shared<const std::string>(to_json(list, false));
  const double now_wall = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  if (list.timestamp > 1e9) {  // looks like Unix time: latency is meaningful
    const double latency = now_wall - list.timestamp;
    if (latency > -1 && latency < 3600) snap->latency = std::max(0.0, latency);
  }
  {
    std::lock_guard lock(s.state_mutex);
    snap->generation = s.latest ? s.latest->generation + 1 : 1;
    s.latest = snap;
    s.publish_times.push_back(Clock::now());
    while (s.publish_times.size() > 32) s.publish_times.pop_front();
  }
  s.published.fetch_add(1);
  std::lock_guard lock(s.clients_mutex);
  for (const auto& client : s.clients) {
    {
      std::lock_guard client_lock(client->mutex);
      while (client->queue.size() >= s.options.stream_queue) {
        client->queue.pop_front();  // the oldest goes: a live view wants the newest
        ++client->dropped;
        s.stream_dropped.fetch_add(1);
      }
      client->queue.push_back(snap->json);
    }
    client->cv.notify_one();
  }
}

void LightServer::publish_metrics(const std::string& prometheus_text) {
  std::lock_guard lock(impl_->state_mutex);
  impl_->pipeline_metrics = prometheus_text;
}

LightServerStats LightServer::stats() const {
  const Impl& s = *impl_;
  LightServerStats st;
  st.lists_published = s.published.load();
  st.requests_served = s.requests.load();
  st.stream_lists_sent = s.stream_sent.load();
  st.stream_lists_dropped = s.stream_dropped.load();
  st.clients_connected = s.connections.load();
  st.stream_clients = s.stream_clients.load();
  return st;
}

}  // namespace lp
