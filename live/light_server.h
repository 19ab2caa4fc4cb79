// The light server: serves the latest state of a running pipeline over HTTP, decoupled
// from the producer. The pipeline calls publish() / publish_metrics() whenever it has
// something new; those calls never wait for a client (each stream client has its own
// small bounded queue; a client that does not keep up loses lists, counted, instead of
// slowing anything down).
//
// Routes (GET and HEAD only; other methods get 405, unknown paths 404):
//   /               the live page (live/web_page.h): a 3D preview and the operator's view
//   /three/*.js     three.js for the page, embedded at build time (live/web_assets.h);
//                   public like the page
//   /lights         the latest light list, CONVENTIONS.md JSON; 503 before the first frame
//   /lights/stream  every new list as it comes: Server-Sent Events ("data: <json>\n\n"),
//                   or NDJSON with ?format=ndjson (one list per line)
//   /probe.png      tone-mapped preview of the latest map with its lights (sampling/overlay.h),
//                   its exposure smoothed over time, unseen parts hatched; rendered lazily,
//                   at most `preview_max_rate` times a second, and cached
//   /sh             the latest map's SH9 as `lightprobe sh` writes sh.json (from the list's
//                   "sh9" of content "map", live/pipeline.h); 503 before the first frame,
//                   404 when the list carries none (a merge's lists)
//   /status         JSON numbers for the page: frame, lights, fps, latency, clients, drops
//   /metrics        Prometheus text: the pipeline's (publish_metrics) plus the server's own
// The connection policy (caps per address and in all, answered with 503; timeouts per
// header line and for the whole request head; no request bodies) is live/http_server.h's.
// With a token, every route but the page needs "Authorization: Bearer <token>" exactly
// (the page is static; it reads the token from the URL fragment, /#token=T, which no
// browser sends, and sends the header itself); without one the server only listens on
// the loopback interface. Errors are JSON: {"error": "..."}. The library prints nothing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "core/envmap.h"
#include "core/light_list.h"
#include "live/http_server.h"

namespace lp {

struct LightServerOptions {
  std::string host = "127.0.0.1";
  int port = 8080;  // 0 = pick a free port (start() returns it)
  std::optional<std::string> token;
  HttpLimits limits;         // connection caps and timeouts (live/http_server.h)
  size_t stream_queue = 8;   // lists buffered per stream client before it drops the oldest
  int max_streams = 32;      // concurrent /lights/stream clients; past it, 503
  int preview_width = 0;     // /probe.png width; 0: the map's width for latlong (<= 1024), else 1024
  double preview_max_rate = 4;  // /probe.png renders per second at most
  // /probe.png's exposure follows the map over this time constant (seconds of list
  // timestamps; core/temporal_tonemap.h) instead of jumping per picture; 0: per picture.
  double preview_time_constant_s = 0.5;
  // False for a server that never publishes a map (merge): /probe.png and /probe.exr are 404,
  // not a 503 "try again" that never ends.
  bool serves_maps = true;
};

// Counters as /metrics reports them (for callers that want numbers, not text).
struct LightServerStats {
  uint64_t lists_published = 0;
  uint64_t requests_served = 0;
  uint64_t stream_lists_sent = 0;
  uint64_t stream_lists_dropped = 0;
  int64_t clients_connected = 0;  // open connections (gauge)
  int64_t stream_clients = 0;
  HttpServerStats http;           // the connection policy's counters
};

class LightServer {
 public:
  // Throws InputError on bad options, among them a host other than the loopback interface
  // without a token ("listening on 0.0.0.0 needs --token").
  explicit LightServer(LightServerOptions options = {});
  ~LightServer();  // stop()
  LightServer(const LightServer&) = delete;
  LightServer& operator=(const LightServer&) = delete;

  // Binds and serves from a thread of its own; returns the bound port. Throws InputError
  // when the address cannot be bound, std::logic_error when already started.
  int start();
  // Clean shutdown: ends streams, waits for the workers. Idempotent.
  void stop();
  int port() const;  // 0 before start()

  // Thread-safe, never blocks on clients. `map_for_preview` may be null (no /probe.png).
  void publish(const LightList& list, std::shared_ptr<const EnvMap> map_for_preview);
  // Prometheus exposition text from the pipeline, served as the head of /metrics.
  void publish_metrics(const std::string& prometheus_text);
  // A JSON object served inside /status under `section` (e.g. the merge's inputs);
  // InputError when the text is not a JSON object.
  void publish_status(const std::string& section, const std::string& json_object);

  LightServerStats stats() const;

  // Answers one request as a served connection would (token, routes, ETags), without a
  // socket: tests and the fuzzer. Needs no start(); /lights/stream asks `exchange` for
  // its stream as usual.
  void answer(const HttpRequest& request, HttpExchange& exchange);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace lp
