// A small event-driven HTTP/1.1 server for GET and HEAD, with a connection policy that
// slow, idle or numerous clients cannot exhaust (issue 22). One thread runs an epoll
// loop over every connection; handlers run on that thread and must be quick (answer at
// once, or defer() and answer from any thread later, or stream()).
//
// Why our own and not a library (measured on this 2-core machine, 200 slowloris sockets
// sending one header line every 2 s plus waves of 500 connections at once, a poller on
// GET /lights; tests/live/http_attack.h):
//   - cpp-httplib 0.11 (Debian; what the light server used): one thread per connection
//     and per-recv timeouts only: every poll failed (no answer within 2 s), 3936 of 4000
//     crowd connections got nothing at all.
//   - libmicrohttpd 0.9.75 (Debian): event-driven, polls answered in 0.3 ms (p95 0.4 ms),
//     but past its per-address and global caps it closes connections without a word
//     (3052 of 3500 crowd connections closed silently, no 503), and it has an inactivity
//     timeout only: 60 slowloris sockets sending a line a second stayed open for good.
//   - Boost.Beast 1.74 (Debian): a parser and an event loop, but every policy above would
//     still be ours, and one minimal server translation unit takes 22 s and 560 MB to
//     compile.
// This one answers every connection: past the caps with 503 and Retry-After (then a
// lingering close, so the answer is read before the socket goes), a request head that is
// too slow with 408; under the attack above /lights answered in 0.24 ms (p50), 1.9 ms
// (p95), 24 ms at worst, none failed (docs/live.md; the test prints its own numbers).
//
// Policy (HttpServerOptions): a cap on connections per client address and a global cap;
// a timeout per header line and a deadline for the whole request head; an idle timeout
// between keep-alive requests; a write timeout; a stall timeout for streams. Requests
// carry no body: any method but GET/HEAD gets 405; a bad Content-Length 400 (RFC 9112
// 6.3), a body 413, an Expect 417, all at once, without reading the body. A request head
// over max_head_bytes gets 431, a bad request line 400. Error bodies are JSON
// {"error": "..."} (bytes that are not UTF-8 are replaced, never thrown on). The library
// prints nothing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace lp {

// The connection policy; the defaults suit a light server on a studio network.
struct HttpLimits {
  // Connections at once from one client address; past it a new connection gets 503.
  int max_connections_per_address = 64;
  // Connections at once in all (clamped below the process's file limit); past it, 503.
  int max_connections = 1024;
  // Each line of a request head (the request line included) must arrive within this of
  // the previous line, and the whole head within request_head_timeout_s of its first byte;
  // otherwise 408 and close.
  double header_line_timeout_s = 2;
  double request_head_timeout_s = 5;
  double keep_alive_timeout_s = 5;     // an idle connection (no byte of a request) is closed
  double write_timeout_s = 10;         // an answer that makes no progress this long: closed
  double stream_stall_timeout_s = 30;  // a stream client that takes nothing this long: closed
  size_t max_head_bytes = 32 * 1024;
  int max_requests_per_connection = 1000;
  int retry_after_s = 1;               // Retry-After of the 503s
};

struct HttpServerOptions {
  std::string host = "127.0.0.1";  // an address or "localhost"; IPv6 as "::1" or "[::1]"
  int port = 0;                    // 0: a free port (start() returns it)
  HttpLimits limits;
};

struct HttpRequest {
  std::string method;  // "GET" or "HEAD": nothing else reaches a handler
  std::string target;  // as sent
  std::string path;    // percent-decoded; may hold any bytes (handlers must not trust it)
  std::string query;   // raw, after '?'
  int minor_version = 1;  // HTTP/1.minor
  std::vector<std::pair<std::string, std::string>> headers;  // names lower-case, values trimmed
  std::string peer;    // client address
  bool is_head() const { return method == "HEAD"; }
  // The value of a header (name in lower case); the first if repeated.
  const std::string* header(std::string_view lower_name) const;
  // A query parameter, percent-decoded; nullopt when absent.
  std::optional<std::string> query_param(std::string_view name) const;
  // Why the query is not one the route takes: a parameter not in `allowed`, one given twice,
  // or one that does not percent-decode; nullopt when it is fine (a default was served for
  // ?format=%zz, and ?frame=3 or ?FORMAT=ndjson were dropped, with 200).
  std::optional<std::string> query_problem(std::initializer_list<std::string_view> allowed) const;
  // How much the Accept header takes `media_type` (lower case, no parameters: "image/png"):
  // the q of the most specific range that matches it (type/subtype, then type/*, then */*;
  // range parameters such as Prometheus' version=0.0.4 do not narrow the match), 0 when no
  // range does. 1 without an Accept header or with one that does not parse (RFC 9110 lets a
  // server ignore it then).
  double accept_quality(std::string_view media_type) const;
};

struct HttpResponse {
  int status = 200;
  std::string content_type;  // empty: no Content-Type
  std::vector<std::pair<std::string, std::string>> headers;  // extra header lines
  std::shared_ptr<const std::string> body;                   // null: empty (shared: not copied)
  void set_body(std::string text, std::string type);
};

// An answer promised by a handler, given from any thread later (at most once; a promise
// destroyed unkept answers 500). Kept after the connection went away, it is a no-op.
class HttpDeferred {
 public:
  virtual ~HttpDeferred() = default;
  virtual void send(HttpResponse response) = 0;
};

// A streaming answer (chunked under HTTP/1.1, until close under 1.0): push() from any
// thread; each piece waits in a bounded queue while the client is slow (the oldest piece
// goes when it is full: a live view wants the newest), never blocking the caller.
class HttpStream {
 public:
  virtual ~HttpStream() = default;
  // Queues one piece; returns how many older pieces were dropped to make room (0 or 1),
  // or -1 when the stream is closed (the client went away or the server stops).
  virtual int push(std::shared_ptr<const std::string> piece) = 0;
  virtual bool closed() const = 0;
};

struct HttpStreamOptions {
  size_t queue_pieces = 8;
  std::string heartbeat;             // written when nothing else was for heartbeat_s (empty: none)
  double heartbeat_s = 2;
  std::function<void()> on_close;    // on the server thread, once, when the stream ends
};

// What a handler does with a request: exactly one of respond(), defer(), stream().
class HttpExchange {
 public:
  virtual ~HttpExchange() = default;
  virtual void respond(HttpResponse response) = 0;
  virtual std::shared_ptr<HttpDeferred> defer() = 0;
  // Sends the head of `response` (its body is ignored) and returns the stream.
  virtual std::shared_ptr<HttpStream> stream(HttpResponse response, HttpStreamOptions options) = 0;
};

using HttpHandler = std::function<void(const HttpRequest&, HttpExchange&)>;

// Counters (monotonic unless said otherwise), for /metrics.
struct HttpServerStats {
  uint64_t connections_accepted = 0;
  uint64_t rejected_per_address = 0;  // 503: the address had max_connections_per_address
  uint64_t rejected_global = 0;       // 503: max_connections reached
  uint64_t head_timeouts = 0;         // 408: a line or the whole head too slow
  uint64_t idle_closed = 0;           // keep-alive connections closed idle
  uint64_t write_timeouts = 0;        // answers or streams abandoned by a client that did not read
  uint64_t bad_requests = 0;          // 400, 405, 413, 417, 431 from the request policy
  uint64_t requests = 0;              // requests handed to the handler
  uint64_t responses = 0;             // answers completely written
  uint64_t handler_errors = 0;        // handlers that threw (answered 500)
  int64_t connections_open = 0;       // gauge
  int64_t streams_open = 0;           // gauge
};

class HttpServer {
 public:
  // Throws InputError on bad options.
  HttpServer(HttpServerOptions options, HttpHandler handler);
  ~HttpServer();  // stop()
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;
  // Binds and serves from a thread of its own; returns the bound port. Throws InputError
  // when the address cannot be bound, std::logic_error when started twice.
  int start();
  // Ends streams (their last chunk), closes every connection, joins. Idempotent.
  void stop();
  int port() const;
  HttpServerStats stats() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// Whether an If-None-Match header (null: absent) matches `etag` by weak comparison
// (RFC 9110 13.1.2: a list of tags, "W/" ignored, "*" matches anything).
bool http_etag_matches(const std::string* if_none_match, const std::string& etag);
// 304 Not Modified for `etag`, no body, with the given Cache-Control.
HttpResponse http_not_modified(const std::string& etag, const std::string& cache_control);

// One request head parsed as the server parses it, with its request policy, without a
// socket (tests, the fuzzer). `head` holds the bytes the client sent up to and including
// the empty line that ends the head. Either the request (peer empty), or the status and
// message the server would refuse it with; status 0 and no request while incomplete.
struct HttpHeadParse {
  std::optional<HttpRequest> request;
  int status = 0;
  std::string message;
};
HttpHeadParse http_parse_head(std::string_view head, const HttpLimits& limits = {});

// {"error": message} and a newline; bytes that are not UTF-8 are replaced.
std::string http_error_json(const std::string& message);
// Standard reason phrase ("Not Found"); "Unknown" for codes it does not know.
const char* http_reason(int status);

}  // namespace lp
