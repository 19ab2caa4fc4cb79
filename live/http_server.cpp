// The event-driven HTTP server: see http_server.h for the policy and why it is our own.
#include "live/http_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/error.h"

namespace lp {

std::string http_error_json(const std::string& message) {
  // error_handler_t::replace: a path with bytes such as %ff must not throw (issue 22).
  return nlohmann::json{{"error", message}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

const char* http_reason(int status) {
  switch (status) {
    case 200: return "OK";
    case 204: return "No Content";
    case 304: return "Not Modified";
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 406: return "Not Acceptable";
    case 408: return "Request Timeout";
    case 413: return "Content Too Large";
    case 414: return "URI Too Long";
    case 417: return "Expectation Failed";
    case 431: return "Request Header Fields Too Large";
    case 500: return "Internal Server Error";
    case 503: return "Service Unavailable";
    case 505: return "HTTP Version Not Supported";
    default: return "Unknown";
  }
}

bool http_etag_matches(const std::string* if_none_match, const std::string& etag) {
  if (!if_none_match || etag.empty()) return false;
  const auto opaque = [](std::string_view t) {
    while (!t.empty() && (t.front() == ' ' || t.front() == '\t')) t.remove_prefix(1);
    while (!t.empty() && (t.back() == ' ' || t.back() == '\t')) t.remove_suffix(1);
    if (t.substr(0, 2) == "W/") t.remove_prefix(2);
    return t;
  };
  const std::string_view mine = opaque(etag);
  std::string_view list = *if_none_match;
  while (!list.empty()) {
    const size_t comma = list.find(',');
    const std::string_view tag = opaque(list.substr(0, comma));
    if (tag == "*" || (!tag.empty() && tag == mine)) return true;
    list = comma == std::string_view::npos ? std::string_view{} : list.substr(comma + 1);
  }
  return false;
}

HttpResponse http_not_modified(const std::string& etag, const std::string& cache_control) {
  HttpResponse r;
  r.status = 304;
  r.headers = {{"ETag", etag}, {"Cache-Control", cache_control}};
  return r;
}

void HttpResponse::set_body(std::string text, std::string type) {
  body = std::make_shared<const std::string>(std::move(text));
  content_type = std::move(type);
}

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

constexpr uint64_t kListenerId = 0, kWakeId = 1;
constexpr size_t kReadChunk = 16 * 1024;
constexpr size_t kMaxLingering = 4096;     // closing sockets draining at once (below the file limit too)
constexpr auto kLingerTime = 2s;           // how long a closing socket is drained
constexpr size_t kMaxLingerBytes = 1 << 20;
constexpr auto kSweepInterval = 25ms;
constexpr size_t kMaxTarget = 8 * 1024;
constexpr size_t kMaxHeaders = 100;

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Percent-decoding; false on a broken escape. `plus_is_space` for query values.
bool percent_decode(std::string_view in, std::string& out, bool plus_is_space) {
  out.clear();
  out.reserve(in.size());
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '%') {
      if (i + 2 >= in.size()) return false;
      const int hi = hex_value(in[i + 1]), lo = hex_value(in[i + 2]);
      if (hi < 0 || lo < 0) return false;
      out += char(hi * 16 + lo);
      i += 2;
    } else {
      out += plus_is_space && in[i] == '+' ? ' ' : in[i];
    }
  }
  return true;
}

bool is_tchar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || std::strchr("!#$%&'*+-.^_`|~", c) != nullptr;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// An RFC 9110 IMF-fixdate of now, cached per second (the loop thread only).
const std::string& http_date() {
  static std::string cached;
  static std::time_t cached_at = 0;
  const std::time_t now = std::time(nullptr);
  if (now != cached_at) {
    std::tm tm{};
    gmtime_r(&now, &tm);
    char buf[64];
    std::strftime(buf, sizeof buf, "%a, %d %b %Y %H:%M:%S GMT", &tm);
    cached = buf;
    cached_at = now;
  }
  return cached;
}

std::string address_of(const sockaddr_storage& ss) {
  char buf[INET6_ADDRSTRLEN] = {0};
  if (ss.ss_family == AF_INET)
    ::inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in&>(ss).sin_addr, buf, sizeof buf);
  else if (ss.ss_family == AF_INET6)
    ::inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6&>(ss).sin6_addr, buf, sizeof buf);
  return buf;
}

// A request-policy failure: the status to answer and why.
struct Refusal {
  Refusal(int s, std::string m, std::vector<std::pair<std::string, std::string>> h = {})
      : status(s), message(std::move(m)), headers(std::move(h)) {}
  int status;
  std::string message;
  std::vector<std::pair<std::string, std::string>> headers;
};

// The mailbox between the loop and other threads: deferred answers and stream flushes.
struct Mailbox {
  std::mutex mutex;
  bool alive = true;
  int wake_fd = -1;
  std::vector<std::pair<uint64_t, HttpResponse>> answers;
  std::vector<uint64_t> flushes;
  void wake() {  // under mutex
    const uint64_t one = 1;
    if (alive && wake_fd >= 0) [[maybe_unused]] auto n = ::write(wake_fd, &one, sizeof one);
  }
  void post_answer(uint64_t id, HttpResponse r) {
    std::lock_guard lock(mutex);
    if (!alive) return;
    answers.emplace_back(id, std::move(r));
    wake();
  }
  void post_flush(uint64_t id) {
    std::lock_guard lock(mutex);
    if (!alive) return;
    flushes.push_back(id);
    wake();
  }
};

class DeferredImpl final : public HttpDeferred {
 public:
  DeferredImpl(std::shared_ptr<Mailbox> mailbox, uint64_t id) : mailbox_(std::move(mailbox)), id_(id) {}
  ~DeferredImpl() override {
    if (!sent_.exchange(true)) {
      HttpResponse r;
      r.status = 500;
      r.set_body(http_error_json("internal error: the answer was never given"), "application/json");
      mailbox_->post_answer(id_, std::move(r));
    }
  }
  void send(HttpResponse response) override {
    if (sent_.exchange(true)) return;
    mailbox_->post_answer(id_, std::move(response));
  }

 private:
  std::shared_ptr<Mailbox> mailbox_;
  uint64_t id_;
  std::atomic<bool> sent_{false};
};

class StreamImpl final : public HttpStream {
 public:
  StreamImpl(std::shared_ptr<Mailbox> mailbox, uint64_t id, HttpStreamOptions options)
      : mailbox_(std::move(mailbox)), id_(id), options_(std::move(options)) {
    options_.queue_pieces = std::max<size_t>(1, options_.queue_pieces);
  }
  int push(std::shared_ptr<const std::string> piece) override {
    bool notify = false;
    int dropped = 0;
    {
      std::lock_guard lock(mutex_);
      if (closed_) return -1;
      while (queue_.size() >= options_.queue_pieces) {
        queue_.pop_front();
        ++dropped;
      }
      queue_.push_back(std::move(piece));
      notify = !flagged_;
      flagged_ = true;
    }
    if (notify) mailbox_->post_flush(id_);
    return dropped;
  }
  bool closed() const override {
    std::lock_guard lock(mutex_);
    return closed_;
  }
  // Loop thread.
  std::vector<std::shared_ptr<const std::string>> take() {
    std::lock_guard lock(mutex_);
    flagged_ = false;
    std::vector<std::shared_ptr<const std::string>> out(queue_.begin(), queue_.end());
    queue_.clear();
    return out;
  }
  void close() {
    {
      std::lock_guard lock(mutex_);
      if (closed_) return;
      closed_ = true;
      queue_.clear();
    }
    if (options_.on_close) options_.on_close();
  }
  const HttpStreamOptions& options() const { return options_; }

 private:
  std::shared_ptr<Mailbox> mailbox_;
  uint64_t id_;
  HttpStreamOptions options_;
  mutable std::mutex mutex_;
  std::deque<std::shared_ptr<const std::string>> queue_;
  bool closed_ = false, flagged_ = false;
};

enum class Phase { Head, Waiting, Writing, Streaming, Lingering };

struct Conn {
  uint64_t id = 0;
  int fd = -1;
  std::string address;
  bool counted = true;  // against the caps (false: a 503 being drained)
  Phase phase = Phase::Head;
  std::string in;
  size_t scan = 0;        // start of the first line not yet looked at
  size_t head_start = 0;  // start of the request line (leading empty lines skipped)
  std::vector<std::pair<size_t, size_t>> lines;  // [begin, end) of the head's lines, no EOL
  bool request_started = false;
  Clock::time_point phase_since, last_line, last_progress;
  std::string out_head;
  std::shared_ptr<const std::string> out_body;
  size_t out_sent = 0;
  bool want_out = false;   // EPOLLOUT registered
  bool peer_eof = false;   // the client shut its side: answer what was asked, then close
  bool head_request = false;
  bool close_after = false;
  bool chunked = false;
  int requests = 0;
  int minor_version = 1;
  size_t lingered = 0;
  std::shared_ptr<StreamImpl> stream;
  size_t out_size() const { return out_head.size() + (out_body ? out_body->size() : 0); }
};

}  // namespace

const std::string* HttpRequest::header(std::string_view lower_name) const {
  for (const auto& [k, v] : headers)
    if (k == lower_name) return &v;
  return nullptr;
}

std::optional<std::string> HttpRequest::query_param(std::string_view name) const {
  std::string_view q = query;
  while (!q.empty()) {
    const size_t amp = q.find('&');
    const std::string_view pair = q.substr(0, amp);
    q = amp == std::string_view::npos ? std::string_view{} : q.substr(amp + 1);
    const size_t eq = pair.find('=');
    std::string key, value;
    if (!percent_decode(pair.substr(0, eq), key, true) || key != name) continue;
    if (eq != std::string_view::npos && !percent_decode(pair.substr(eq + 1), value, true)) continue;
    return value;
  }
  return std::nullopt;
}

std::optional<std::string> HttpRequest::query_problem(std::initializer_list<std::string_view> allowed) const {
  std::string_view q = query;
  std::vector<std::string> seen;
  while (!q.empty()) {
    const size_t amp = q.find('&');
    const std::string_view pair = q.substr(0, amp);
    q = amp == std::string_view::npos ? std::string_view{} : q.substr(amp + 1);
    if (pair.empty()) continue;
    const size_t eq = pair.find('=');
    std::string key, value;
    if (!percent_decode(pair.substr(0, eq), key, true) ||
        (eq != std::string_view::npos && !percent_decode(pair.substr(eq + 1), value, true)))
      return "query parameter '" + std::string(pair.substr(0, 60)) + "' is not percent-encoded text";
    if (std::find(allowed.begin(), allowed.end(), std::string_view(key)) == allowed.end())
      return allowed.size() == 0 ? "this path takes no query parameters, got '" + key.substr(0, 60) + "'"
                                 : "unknown query parameter '" + key.substr(0, 60) + "'";
    if (std::find(seen.begin(), seen.end(), key) != seen.end()) return "query parameter '" + key + "' is given twice";
    seen.push_back(key);
  }
  return std::nullopt;
}

namespace {

// A q value as RFC 9110 writes it: 0, 1, or 0.ddd / 1.000 (at most three decimals).
std::optional<double> parse_qvalue(std::string_view v) {
  if (v.empty() || v.size() > 5 || (v[0] != '0' && v[0] != '1')) return std::nullopt;
  if (v.size() > 1 && v[1] != '.') return std::nullopt;
  int thousandths = (v[0] - '0') * 1000, scale = 100;  // in integers: "0.7" is the double 0.7
  for (size_t i = 2; i < v.size(); ++i, scale /= 10) {
    if (v[i] < '0' || v[i] > '9') return std::nullopt;
    thousandths += (v[i] - '0') * scale;
  }
  return thousandths <= 1000 ? std::optional<double>(thousandths / 1000.0) : std::nullopt;
}

}  // namespace

double HttpRequest::accept_quality(std::string_view media_type) const {
  const std::string* accept = header("accept");
  if (!accept || trim(*accept).empty()) return 1;
  const size_t slash = media_type.find('/');
  const std::string_view type = media_type.substr(0, slash), subtype = media_type.substr(slash + 1);
  int best_specificity = -1;
  double best_q = 0;
  std::string_view rest = *accept;
  while (!rest.empty()) {
    const size_t comma = rest.find(',');
    std::string_view element = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    const size_t semi = element.find(';');
    const std::string_view range = trim(element.substr(0, semi));
    if (range.empty()) continue;  // "a,,b" is allowed
    const size_t rs = range.find('/');
    if (rs == std::string_view::npos || rs == 0 || rs + 1 == range.size()) return 1;  // not a media range
    const std::string_view rtype = range.substr(0, rs), rsub = range.substr(rs + 1);
    double q = 1;
    for (std::string_view params = semi == std::string_view::npos ? std::string_view{} : element.substr(semi + 1);
         !params.empty();) {
      const size_t next = params.find(';');
      const std::string_view param = trim(params.substr(0, next));
      params = next == std::string_view::npos ? std::string_view{} : params.substr(next + 1);
      const size_t eq = param.find('=');
      if (eq == std::string_view::npos || lower(trim(param.substr(0, eq))) != "q") continue;
      const auto parsed = parse_qvalue(trim(param.substr(eq + 1)));
      if (!parsed) return 1;
      q = *parsed;
    }
    int specificity = -1;
    if (rtype == "*" && rsub == "*")
      specificity = 0;
    else if (lower(rtype) == type && rsub == "*")
      specificity = 1;
    else if (lower(rtype) == type && lower(rsub) == subtype)
      specificity = 2;
    if (specificity > best_specificity) best_specificity = specificity, best_q = q;
  }
  return best_specificity < 0 ? 0 : best_q;
}

namespace {

// Splits the complete lines of a request head from `scan` on ([begin, end), no EOL) into
// `lines`, skipping empty lines before a request line; true once the empty line that ends
// the head is read (`scan` is then just past it).
bool split_head_lines(std::string_view in, size_t& scan, size_t& head_start,
                      std::vector<std::pair<size_t, size_t>>& lines) {
  size_t pos;
  while ((pos = in.find('\n', scan)) != std::string_view::npos) {
    size_t end = pos;
    if (end > scan && in[end - 1] == '\r') --end;
    const size_t begin = scan;
    scan = pos + 1;
    if (end != begin) {
      lines.emplace_back(begin, end);
    } else if (lines.empty()) {
      head_start = scan;  // empty lines before a request: ignored
    } else {
      return true;
    }
  }
  return false;
}

// 431 for a head (so far, up to `head_end`) over the byte or line cap.
std::optional<Refusal> head_too_big(std::string_view in, size_t head_end, size_t head_start,
                                    const std::vector<std::pair<size_t, size_t>>& lines, const HttpLimits& limits) {
  if (head_end - head_start <= limits.max_head_bytes && lines.size() <= kMaxHeaders + 1) return std::nullopt;
  return Refusal{431, fmt::format("request head over {} bytes or {} lines", limits.max_head_bytes, kMaxHeaders)};
}

// The request line and headers, then the policy: no bodies, no expectations, GET/HEAD.
std::optional<Refusal> parse_head_lines(std::string_view in, const std::vector<std::pair<size_t, size_t>>& lines,
                                        HttpRequest& req) {
  const auto line = [&](size_t k) { return in.substr(lines[k].first, lines[k].second - lines[k].first); };
  const std::string_view request_line = line(0);
  const size_t sp1 = request_line.find(' '), sp2 = request_line.rfind(' ');
  if (sp1 == std::string_view::npos || sp2 == sp1) return Refusal{400, "malformed request line"};
  const std::string_view method = request_line.substr(0, sp1), version = request_line.substr(sp2 + 1);
  const std::string_view target = request_line.substr(sp1 + 1, sp2 - sp1 - 1);
  if (method.empty() || !std::all_of(method.begin(), method.end(), is_tchar)) return Refusal{400, "malformed method"};
  if (version.size() != 8 || version.substr(0, 5) != "HTTP/" || version[6] != '.')
    return Refusal{400, "malformed HTTP version"};
  if (version[5] != '1' || (version[7] != '0' && version[7] != '1'))
    return Refusal{505, fmt::format("HTTP version {} not supported (1.0 or 1.1)", version)};
  req.minor_version = version[7] - '0';
  if (target.size() > kMaxTarget) return Refusal{414, fmt::format("request target over {} bytes", kMaxTarget)};
  if (target.empty() || target.find(' ') != std::string_view::npos) return Refusal{400, "malformed request target"};
  req.method = std::string(method);
  req.target = std::string(target);
  for (size_t k = 1; k < lines.size(); ++k) {
    const std::string_view h = line(k);
    const size_t colon = h.find(':');
    if (h.front() == ' ' || h.front() == '\t') return Refusal{400, "obsolete header line folding"};
    if (colon == std::string_view::npos || colon == 0) return Refusal{400, "malformed header line"};
    const std::string_view name = h.substr(0, colon);
    if (!std::all_of(name.begin(), name.end(), is_tchar)) return Refusal{400, "malformed header name"};
    const std::string_view value = trim(h.substr(colon + 1));
    for (char ch : value)
      if ((static_cast<unsigned char>(ch) < 0x20 && ch != '\t') || ch == 0x7f)
        return Refusal{400, "control character in a header value"};
    req.headers.emplace_back(lower(name), std::string(value));
  }
  // Bodies: lengths must agree and be digits; any body is refused (we take none).
  std::optional<uint64_t> length;
  for (const auto& [k, v] : req.headers) {
    if (k != "content-length") continue;
    std::string_view rest = v;
    while (!rest.empty()) {
      const size_t comma = rest.find(',');
      const std::string_view item = trim(rest.substr(0, comma));
      rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
      uint64_t n = 0;
      bool overflow = false;
      if (item.empty() || !std::all_of(item.begin(), item.end(), [](char ch) { return ch >= '0' && ch <= '9'; }))
        return Refusal{400, fmt::format("bad Content-Length '{}'", std::string(v).substr(0, 40))};
      for (char ch : item) {
        if (n > (UINT64_MAX - 9) / 10) overflow = true;
        n = n * 10 + uint64_t(ch - '0');
      }
      if (overflow) n = UINT64_MAX;
      if (length && *length != n) return Refusal{400, "conflicting Content-Length values"};
      length = n;
    }
  }
  const bool has_body = req.header("transfer-encoding") || (length && *length > 0);
  if (const std::string* expect = req.header("expect")) {
    if (lower(*expect) != "100-continue") return Refusal{417, fmt::format("unsupported Expect '{}'", expect->substr(0, 40))};
    if (has_body) return Refusal{417, "no request body is accepted (Expect: 100-continue refused)"};
  }
  if (req.method != "GET" && req.method != "HEAD")
    return Refusal{405, fmt::format("method {} not allowed (GET or HEAD only)", req.method.substr(0, 20)),
                   {{"Allow", "GET, HEAD"}}};
  if (has_body) return Refusal{413, "no request body is accepted"};
  // The target: origin form only.
  const size_t q = req.target.find('?');
  if (req.target[0] != '/') return Refusal{400, "request target must be a path"};
  if (!percent_decode(std::string_view(req.target).substr(0, q), req.path, false))
    return Refusal{400, "broken percent escape in the path"};
  if (q != std::string::npos) req.query = req.target.substr(q + 1);
  return std::nullopt;
}

}  // namespace

struct HttpServer::Impl {
  HttpServerOptions options;
  HttpHandler handler;
  int listen_fd = -1, epoll_fd = -1;
  int bound_port = 0;
  std::thread thread;
  std::mutex lifecycle;
  bool started = false, stopped = false;
  std::atomic<bool> stopping{false};
  std::shared_ptr<Mailbox> mailbox = std::make_shared<Mailbox>();

  // Loop thread only.
  std::unordered_map<uint64_t, std::unique_ptr<Conn>> conns;
  std::unordered_map<std::string, int> per_address;
  int64_t counted_open = 0;
  size_t lingering = 0;
  uint64_t next_id = 2;
  std::vector<uint64_t> ready;  // connections with a pipelined request to look at
  bool accept_paused = false;
  Clock::time_point accept_resume{}, last_sweep{};
  int max_connections = 0;
  size_t max_lingering = kMaxLingering;

  // Counters, read by stats() from any thread.
  std::atomic<uint64_t> accepted{0}, rejected_address{0}, rejected_global{0}, head_timeouts{0}, idle_closed{0},
      write_timeouts{0}, bad_requests{0}, requests{0}, responses{0}, handler_errors{0};
  std::atomic<int64_t> open{0}, streams{0};

  Impl(HttpServerOptions o, HttpHandler h) : options(std::move(o)), handler(std::move(h)) {}

  void bind_and_listen();
  void run();
  void handle_event(uint64_t id, uint32_t events);
  void accept_all();
  void reject(int fd, const std::string& address, bool global);
  Conn* add_conn(int fd, std::string address, bool counted);
  void close_conn(Conn& c);
  void read_from(Conn& c);
  void process_head(Conn& c);
  std::optional<Refusal> parse_request(Conn& c, HttpRequest& req);
  void dispatch(Conn& c, HttpRequest& req);
  void start_response(Conn& c, const HttpResponse& r, bool head_only);
  void start_stream(Conn& c, const HttpResponse& r, std::shared_ptr<StreamImpl> stream);
  void refuse(Conn& c, const Refusal& r);
  void flush(Conn& c);
  void after_write(Conn& c);
  void fill_stream(Conn& c);
  void start_lingering(Conn& c);
  void drain_mailbox();
  void sweep(Clock::time_point now);
  void set_out_interest(Conn& c, bool want, bool force = false);
  void shutdown_all();
};

namespace {

// What a handler is given: acts on its connection, on the loop thread.
class ExchangeImpl final : public HttpExchange {
 public:
  ExchangeImpl(HttpServer::Impl& s, Conn& c) : s_(s), c_(c) {}
  void respond(HttpResponse response) override {
    if (used_) throw std::logic_error("HttpExchange: answered twice");
    used_ = true;
    s_.start_response(c_, response, c_.head_request);
  }
  std::shared_ptr<HttpDeferred> defer() override {
    if (used_) throw std::logic_error("HttpExchange: answered twice");
    used_ = true;
    return std::make_shared<DeferredImpl>(s_.mailbox, c_.id);
  }
  std::shared_ptr<HttpStream> stream(HttpResponse response, HttpStreamOptions options) override {
    if (used_) throw std::logic_error("HttpExchange: answered twice");
    used_ = true;
    auto st = std::make_shared<StreamImpl>(s_.mailbox, c_.id, std::move(options));
    s_.start_stream(c_, response, st);
    return st;
  }
  bool used() const { return used_; }

 private:
  HttpServer::Impl& s_;
  Conn& c_;
  bool used_ = false;
};

}  // namespace

void HttpServer::Impl::bind_and_listen() {
  std::string host = options.host;
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string port = std::to_string(options.port);
  if (::getaddrinfo(host.c_str(), port.c_str(), &hints, &found) != 0 || !found)
    throw InputError(fmt::format("light server: cannot resolve listening address '{}'", options.host));
  std::string why = "no address";
  for (addrinfo* a = found; a && listen_fd < 0; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (a->ai_family == AF_INET6) ::setsockopt(fd, IPPROTO_IPV6, IPV6_V6ONLY, &one, sizeof one);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd, SOMAXCONN) == 0) {
      listen_fd = fd;
    } else {
      why = std::strerror(errno);
      ::close(fd);
    }
  }
  ::freeaddrinfo(found);
  if (listen_fd < 0)
    throw InputError(fmt::format("light server: cannot listen on {}:{} ({})", options.host, options.port, why));
  sockaddr_storage ss{};
  socklen_t len = sizeof ss;
  ::getsockname(listen_fd, reinterpret_cast<sockaddr*>(&ss), &len);
  bound_port = ss.ss_family == AF_INET6 ? ntohs(reinterpret_cast<sockaddr_in6&>(ss).sin6_port)
                                        : ntohs(reinterpret_cast<sockaddr_in&>(ss).sin_port);
  // The global cap must stay below the file limit, or accept() fails before it applies.
  rlimit rl{};
  max_connections = options.limits.max_connections;
  if (::getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) {
    const rlim_t budget = rl.rlim_cur > 128 ? (rl.rlim_cur - 64) / 2 : 32;  // half for open, half for closing
    max_connections = int(std::min<rlim_t>(rlim_t(max_connections), budget));
    max_lingering = size_t(std::min<rlim_t>(kMaxLingering, budget));
  }
  epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  mailbox->wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (epoll_fd < 0 || mailbox->wake_fd < 0) throw std::runtime_error("light server: epoll/eventfd failed");
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = kListenerId;
  ::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, listen_fd, &ev);
  ev.data.u64 = kWakeId;
  ::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, mailbox->wake_fd, &ev);
}

void HttpServer::Impl::run() {
  std::vector<epoll_event> events(256);
  while (!stopping) {
    const int n = ::epoll_wait(epoll_fd, events.data(), int(events.size()), int(kSweepInterval / 1ms));
    for (int i = 0; i < n; ++i) {
      // A failure while serving one connection closes that connection, never the server.
      try {
        handle_event(events[size_t(i)].data.u64, events[size_t(i)].events);
      } catch (const std::exception&) {
        auto it = conns.find(events[size_t(i)].data.u64);
        if (it != conns.end()) close_conn(*it->second);
      }
    }
    try {
      std::vector<uint64_t> now_ready;
      now_ready.swap(ready);
      for (uint64_t id : now_ready) {
        auto it = conns.find(id);
        if (it != conns.end() && it->second->phase == Phase::Head) process_head(*it->second);
      }
      drain_mailbox();
      const auto now = Clock::now();
      if (now - last_sweep >= kSweepInterval) {
        sweep(now);
        last_sweep = now;
      }
      if (accept_paused && now >= accept_resume) {
        accept_paused = false;
        epoll_event ev{};
        ev.events = EPOLLIN;
        ev.data.u64 = kListenerId;
        ::epoll_ctl(epoll_fd, EPOLL_CTL_MOD, listen_fd, &ev);
        accept_all();
      }
    } catch (const std::exception&) {
      // Out of memory or similar in the bookkeeping: carry on with the next round.
    }
  }
  shutdown_all();
}

void HttpServer::Impl::handle_event(uint64_t id, uint32_t events) {
  if (id == kListenerId) {
    if (!accept_paused) accept_all();
    return;
  }
  if (id == kWakeId) {
    uint64_t v;
    [[maybe_unused]] auto r = ::read(mailbox->wake_fd, &v, sizeof v);
    return;  // the mailbox is drained after the events
  }
  auto it = conns.find(id);
  if (it == conns.end()) return;
  Conn& c = *it->second;
  if (c.peer_eof && (events & (EPOLLHUP | EPOLLERR))) {  // gone for good while we answered
    close_conn(c);
    return;
  }
  if (events & (EPOLLIN | EPOLLRDHUP | EPOLLHUP | EPOLLERR)) {
    read_from(c);
    if (!conns.count(id)) return;
  }
  if (events & EPOLLOUT) flush(c);
}

void HttpServer::Impl::accept_all() {
  for (int k = 0; k < 1024; ++k) {
    sockaddr_storage ss{};
    socklen_t len = sizeof ss;
    const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&ss), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
        // Out of descriptors: stop watching the listener for a moment instead of spinning on it.
        accept_paused = true;
        accept_resume = Clock::now() + 100ms;
        epoll_event ev{};
        ev.data.u64 = kListenerId;
        ::epoll_ctl(epoll_fd, EPOLL_CTL_MOD, listen_fd, &ev);
      }
      return;
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    accepted.fetch_add(1);
    std::string address = address_of(ss);
    if (counted_open >= max_connections) {
      reject(fd, address, true);
    } else if (per_address[address] >= options.limits.max_connections_per_address) {
      reject(fd, address, false);
    } else {
      add_conn(fd, std::move(address), true);
    }
  }
}

// 503 at once, then drain what the client sends until it closes: closing a socket with
// unread input would reset the connection and could destroy the answer before it is read.
void HttpServer::Impl::reject(int fd, const std::string& address, bool global) {
  (global ? rejected_global : rejected_address).fetch_add(1);
  if (!global && per_address[address] == 0) per_address.erase(address);
  const std::string body = http_error_json(
      global ? fmt::format("server busy: {} connections open (at most {})", counted_open, max_connections)
             : fmt::format("too many connections from {} (at most {})", address, options.limits.max_connections_per_address));
  const std::string answer = fmt::format(
      "HTTP/1.1 503 Service Unavailable\r\nDate: {}\r\nRetry-After: {}\r\nContent-Type: application/json\r\n"
      "Content-Length: {}\r\nConnection: close\r\n\r\n{}",
      http_date(), options.limits.retry_after_s, body.size(), body);
  [[maybe_unused]] auto n = ::send(fd, answer.data(), answer.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(fd, SHUT_WR);
  if (lingering >= max_lingering) {
    ::close(fd);
    return;
  }
  Conn* c = add_conn(fd, address, false);
  if (c) {
    c->phase = Phase::Lingering;
    ++lingering;
  }
}

Conn* HttpServer::Impl::add_conn(int fd, std::string address, bool counted) {
  auto c = std::make_unique<Conn>();
  c->id = next_id++;
  c->fd = fd;
  c->counted = counted;
  c->phase_since = c->last_line = c->last_progress = Clock::now();
  epoll_event ev{};
  ev.events = EPOLLIN | EPOLLRDHUP;
  ev.data.u64 = c->id;
  if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &ev) != 0) {
    ::close(fd);
    return nullptr;
  }
  if (counted) {
    ++per_address[address];
    ++counted_open;
    open.fetch_add(1);
  }
  c->address = std::move(address);
  Conn* raw = c.get();
  conns.emplace(raw->id, std::move(c));
  return raw;
}

void HttpServer::Impl::close_conn(Conn& c) {
  const uint64_t id = c.id;
  if (c.stream) {
    streams.fetch_sub(1);
    auto s = std::move(c.stream);
    s->close();
  }
  ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c.fd, nullptr);
  ::close(c.fd);
  if (c.counted) {
    auto it = per_address.find(c.address);
    if (it != per_address.end() && --it->second <= 0) per_address.erase(it);
    --counted_open;
    open.fetch_sub(1);
  } else if (c.phase == Phase::Lingering) {
    --lingering;
  }
  conns.erase(id);
}

void HttpServer::Impl::set_out_interest(Conn& c, bool want, bool force) {
  if (c.want_out == want && !force) return;
  c.want_out = want;
  epoll_event ev{};
  ev.events = (c.peer_eof ? 0u : EPOLLIN | EPOLLRDHUP) | (want ? EPOLLOUT : 0u);
  ev.data.u64 = c.id;
  ::epoll_ctl(epoll_fd, EPOLL_CTL_MOD, c.fd, &ev);
}

void HttpServer::Impl::read_from(Conn& c) {
  char buf[kReadChunk];
  const uint64_t id = c.id;
  for (int round = 0; round < 4; ++round) {
    const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 || (n == 0 && (c.phase == Phase::Lingering || c.phase == Phase::Streaming))) {  // reset, or done
      close_conn(c);
      return;
    }
    if (n == 0) {  // the client shut its side: answer a request it completed, then close
      c.peer_eof = true;
      c.close_after = true;
      if (c.phase == Phase::Head) process_head(c);
      if (!conns.count(id)) return;
      if (c.phase == Phase::Head) {
        close_conn(c);
        return;
      }
      set_out_interest(c, c.want_out, true);
      return;
    }
    switch (c.phase) {
      case Phase::Lingering:
      case Phase::Streaming:  // a stream client has nothing to say: discard
        c.lingered += size_t(n);
        if (c.phase == Phase::Lingering && c.lingered > kMaxLingerBytes) {
          close_conn(c);
          return;
        }
        continue;
      case Phase::Head:
        if (!c.request_started) {
          c.request_started = true;
          c.phase_since = c.last_line = Clock::now();
        }
        [[fallthrough]];
      case Phase::Waiting:
      case Phase::Writing:
        c.in.append(buf, size_t(n));
        // A client that pipelines more than a head's worth while we answer: too much.
        if (c.in.size() > 2 * options.limits.max_head_bytes + kReadChunk) {
          close_conn(c);
          return;
        }
    }
  }
  if (conns.count(id) && c.phase == Phase::Head) process_head(c);
}

void HttpServer::Impl::process_head(Conn& c) {
  const size_t scanned = c.scan;
  const bool complete = split_head_lines(c.in, c.scan, c.head_start, c.lines);
  if (c.scan != scanned) c.last_line = Clock::now();
  if (auto too_big = head_too_big(c.in, complete ? c.scan : c.in.size(), c.head_start, c.lines, options.limits)) {
    bad_requests.fetch_add(1);
    refuse(c, *too_big);
    return;
  }
  if (!complete) return;
  HttpRequest req;
  std::optional<Refusal> refusal = parse_request(c, req);
  c.in.erase(0, c.scan);
  c.scan = c.head_start = 0;
  c.lines.clear();
  c.request_started = !c.in.empty();
  if (refusal) {
    bad_requests.fetch_add(1);
    refuse(c, *refusal);
    return;
  }
  dispatch(c, req);
}

std::optional<Refusal> HttpServer::Impl::parse_request(Conn& c, HttpRequest& req) {
  std::optional<Refusal> refusal = parse_head_lines(c.in, c.lines, req);
  c.minor_version = req.minor_version;
  req.peer = c.address;
  return refusal;
}

void HttpServer::Impl::dispatch(Conn& c, HttpRequest& req) {
  const std::string* connection = req.header("connection");
  const std::string conn_value = connection ? lower(*connection) : "";
  const bool keep_alive = req.minor_version == 1 ? conn_value.find("close") == std::string::npos
                                                 : conn_value.find("keep-alive") != std::string::npos;
  ++c.requests;
  c.close_after = c.peer_eof || !keep_alive || c.requests >= options.limits.max_requests_per_connection || stopping;
  c.phase = Phase::Waiting;
  requests.fetch_add(1);
  const uint64_t id = c.id;
  c.head_request = req.is_head();
  ExchangeImpl exchange(*this, c);
  try {
    handler(req, exchange);
    if (!exchange.used()) throw std::logic_error("handler gave no answer");
  } catch (const std::exception&) {
    handler_errors.fetch_add(1);
    if (!exchange.used() && conns.count(id)) {
      HttpResponse r;
      r.status = 500;
      r.set_body(http_error_json("internal error"), "application/json");
      start_response(c, r, req.is_head());
    }
  }
}

void HttpServer::Impl::refuse(Conn& c, const Refusal& r) {
  HttpResponse res;
  res.status = r.status;
  res.headers = r.headers;
  res.set_body(http_error_json(r.message), "application/json");
  c.close_after = true;  // whatever follows a refused head is not to be trusted
  start_response(c, res, false);
}

void HttpServer::Impl::start_response(Conn& c, const HttpResponse& r, bool head_only) {
  const bool no_body = r.status == 204 || r.status == 304 || (r.status >= 100 && r.status < 200);
  std::string& h = c.out_head;
  h = fmt::format("HTTP/1.{} {} {}\r\nDate: {}\r\nServer: lightprobe\r\n", c.minor_version, r.status,
                  http_reason(r.status), http_date());
  if (!r.content_type.empty() && !no_body) h += fmt::format("Content-Type: {}\r\n", r.content_type);
  if (!no_body) h += fmt::format("Content-Length: {}\r\n", r.body ? r.body->size() : 0);
  for (const auto& [k, v] : r.headers) h += fmt::format("{}: {}\r\n", k, v);
  if (stopping) c.close_after = true;
  h += c.close_after ? "Connection: close\r\n\r\n" : (c.minor_version == 0 ? "Connection: keep-alive\r\n\r\n" : "\r\n");
  c.out_body = (head_only || no_body) ? nullptr : r.body;
  c.out_sent = 0;
  c.phase = Phase::Writing;
  c.last_progress = Clock::now();
  flush(c);
}

void HttpServer::Impl::start_stream(Conn& c, const HttpResponse& r, std::shared_ptr<StreamImpl> stream) {
  c.chunked = c.minor_version == 1;
  std::string& h = c.out_head;
  h = fmt::format("HTTP/1.{} {} {}\r\nDate: {}\r\nServer: lightprobe\r\n", c.minor_version, r.status,
                  http_reason(r.status), http_date());
  if (!r.content_type.empty()) h += fmt::format("Content-Type: {}\r\n", r.content_type);
  for (const auto& [k, v] : r.headers) h += fmt::format("{}: {}\r\n", k, v);
  h += c.chunked ? "Transfer-Encoding: chunked\r\n\r\n" : "Connection: close\r\n\r\n";
  c.out_body = nullptr;
  c.out_sent = 0;
  c.phase = Phase::Streaming;
  c.close_after = true;
  c.in.clear();
  c.stream = std::move(stream);
  c.last_progress = Clock::now();
  streams.fetch_add(1);
  flush(c);
}

void HttpServer::Impl::flush(Conn& c) {
  const uint64_t id = c.id;
  while (c.out_sent < c.out_size()) {
    iovec iov[2];
    int count = 0;
    const size_t hs = c.out_head.size();
    if (c.out_sent < hs) iov[count++] = {const_cast<char*>(c.out_head.data()) + c.out_sent, hs - c.out_sent};
    if (c.out_body) {
      const size_t off = c.out_sent > hs ? c.out_sent - hs : 0;
      if (off < c.out_body->size()) iov[count++] = {const_cast<char*>(c.out_body->data()) + off, c.out_body->size() - off};
    }
    msghdr msg{};
    msg.msg_iov = iov;
    msg.msg_iovlen = size_t(count);
    const ssize_t n = ::sendmsg(c.fd, &msg, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      set_out_interest(c, true);
      return;
    }
    if (n < 0) {
      close_conn(c);
      return;
    }
    c.out_sent += size_t(n);
    c.last_progress = Clock::now();
  }
  set_out_interest(c, false);
  if (conns.count(id)) after_write(c);
}

void HttpServer::Impl::after_write(Conn& c) {
  c.out_head.clear();
  c.out_body.reset();
  c.out_sent = 0;
  if (c.phase == Phase::Streaming) {
    fill_stream(c);
    return;
  }
  if (c.phase != Phase::Writing) return;
  responses.fetch_add(1);
  if (c.close_after) {
    start_lingering(c);
    return;
  }
  c.phase = Phase::Head;
  c.phase_since = c.last_line = Clock::now();
  c.request_started = !c.in.empty();
  if (!c.in.empty()) ready.push_back(c.id);  // a pipelined request waits already: next round
  else if (c.peer_eof) close_conn(c);
}

// Moves what waits in the stream's queue into the output, framed as chunks.
void HttpServer::Impl::fill_stream(Conn& c) {
  if (!c.stream || c.out_sent < c.out_size()) return;
  const auto pieces = c.stream->take();
  if (pieces.empty()) return;
  std::string out;
  for (const auto& p : pieces) {
    if (!p || p->empty()) continue;
    if (c.chunked) out += fmt::format("{:x}\r\n", p->size());
    out += *p;
    if (c.chunked) out += "\r\n";
  }
  if (out.empty()) return;
  c.out_head = std::move(out);
  c.out_sent = 0;
  flush(c);
}

void HttpServer::Impl::start_lingering(Conn& c) {
  if (c.peer_eof) {  // everything the client sent is read: closing cannot reset anything
    close_conn(c);
    return;
  }
  ::shutdown(c.fd, SHUT_WR);
  if (c.counted) {  // no longer holds a slot of its address
    auto it = per_address.find(c.address);
    if (it != per_address.end() && --it->second <= 0) per_address.erase(it);
    --counted_open;
    open.fetch_sub(1);
    c.counted = false;
  }
  if (lingering >= max_lingering) {
    close_conn(c);
    return;
  }
  ++lingering;
  c.phase = Phase::Lingering;
  c.phase_since = Clock::now();
  c.in.clear();
}

void HttpServer::Impl::drain_mailbox() {
  std::vector<std::pair<uint64_t, HttpResponse>> answers;
  std::vector<uint64_t> flushes;
  {
    std::lock_guard lock(mailbox->mutex);
    answers.swap(mailbox->answers);
    flushes.swap(mailbox->flushes);
  }
  for (auto& [id, response] : answers) {
    auto it = conns.find(id);
    if (it == conns.end() || it->second->phase != Phase::Waiting) continue;  // the client left
    start_response(*it->second, response, it->second->head_request);
  }
  for (uint64_t id : flushes) {
    auto it = conns.find(id);
    if (it != conns.end()) fill_stream(*it->second);
  }
}

void HttpServer::Impl::sweep(Clock::time_point now) {
  std::vector<uint64_t> expired, idle, timed_out, stalled, heartbeat;
  for (auto& [id, cp] : conns) {
    Conn& c = *cp;
    switch (c.phase) {
      case Phase::Head:
        if (!c.request_started) {
          if (now - c.phase_since > seconds(options.limits.keep_alive_timeout_s)) idle.push_back(id);
        } else if (now - c.last_line > seconds(options.limits.header_line_timeout_s) ||
                   now - c.phase_since > seconds(options.limits.request_head_timeout_s)) {
          timed_out.push_back(id);
        }
        break;
      case Phase::Writing:
        if (now - c.last_progress > seconds(options.limits.write_timeout_s)) stalled.push_back(id);
        break;
      case Phase::Streaming:
        if (c.out_sent < c.out_size()) {
          if (now - c.last_progress > seconds(options.limits.stream_stall_timeout_s)) stalled.push_back(id);
        } else if (c.stream && !c.stream->options().heartbeat.empty() &&
                   now - c.last_progress > seconds(c.stream->options().heartbeat_s)) {
          heartbeat.push_back(id);
        }
        break;
      case Phase::Lingering:
        if (now - c.phase_since > kLingerTime) expired.push_back(id);
        break;
      case Phase::Waiting:
        break;
    }
  }
  const auto each = [&](const std::vector<uint64_t>& ids, auto fn) {
    for (uint64_t id : ids) {
      auto it = conns.find(id);
      if (it != conns.end()) fn(*it->second);
    }
  };
  each(expired, [&](Conn& c) { close_conn(c); });
  each(heartbeat, [&](Conn& c) {
    // SSE comments keep proxies from timing out and let a dead peer be noticed.
    c.stream->push(std::make_shared<const std::string>(c.stream->options().heartbeat));
    fill_stream(c);
  });
  each(idle, [&](Conn& c) {
    idle_closed.fetch_add(1);
    close_conn(c);
  });
  each(stalled, [&](Conn& c) {
    write_timeouts.fetch_add(1);
    close_conn(c);
  });
  each(timed_out, [&](Conn& c) {
    head_timeouts.fetch_add(1);
    refuse(c, {408, fmt::format("request head too slow (a line within {} s, the head within {} s)",
                                options.limits.header_line_timeout_s, options.limits.request_head_timeout_s)});
  });
}

void HttpServer::Impl::shutdown_all() {
  {
    std::lock_guard lock(mailbox->mutex);
    mailbox->alive = false;
  }
  // Streams end properly (the last chunk), answers in flight get a last chance.
  std::vector<uint64_t> ids;
  for (auto& [id, c] : conns) ids.push_back(id);
  for (uint64_t id : ids) {
    auto it = conns.find(id);
    if (it == conns.end()) continue;
    Conn& c = *it->second;
    if (c.phase == Phase::Streaming && c.chunked && c.out_sent >= c.out_size()) {
      c.out_head = "0\r\n\r\n";
      c.out_sent = 0;
      c.phase = Phase::Writing;  // after this write: closed
      c.close_after = true;
      auto st = std::move(c.stream);
      streams.fetch_sub(1);
      if (st) st->close();
      flush(c);
    }
  }
  while (!conns.empty()) close_conn(*conns.begin()->second);
  ::close(listen_fd);
  ::close(epoll_fd);
  std::lock_guard lock(mailbox->mutex);
  ::close(mailbox->wake_fd);
  mailbox->wake_fd = -1;
  listen_fd = epoll_fd = -1;
}

HttpServer::HttpServer(HttpServerOptions options, HttpHandler handler) {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (options.port < 0 || options.port > 65535)
    throw InputError(fmt::format("light server: port {} is not in 0..65535", options.port));
  if (options.host.empty()) throw InputError("light server: empty host");
  if (options.limits.max_connections < 1 || options.limits.max_connections_per_address < 1)
    throw InputError("light server: connection caps must be at least 1");
  if (!positive(options.limits.header_line_timeout_s) || !positive(options.limits.request_head_timeout_s) ||
      !positive(options.limits.keep_alive_timeout_s) || !positive(options.limits.write_timeout_s) ||
      !positive(options.limits.stream_stall_timeout_s))
    throw InputError("light server: timeouts must be positive seconds");
  if (options.limits.max_head_bytes < 1024) throw InputError("light server: max_head_bytes must be at least 1024");
  if (options.limits.max_requests_per_connection < 1) throw InputError("light server: max_requests_per_connection must be >= 1");
  if (!handler) throw std::logic_error("HttpServer: no handler");
  impl_ = std::make_unique<Impl>(std::move(options), std::move(handler));
}

HttpServer::~HttpServer() { stop(); }

int HttpServer::start() {
  Impl& s = *impl_;
  std::lock_guard lock(s.lifecycle);
  if (s.started || s.stopped) throw std::logic_error("HttpServer::start: already started");
  s.bind_and_listen();
  s.started = true;
  s.thread = std::thread([&s] { s.run(); });
  return s.bound_port;
}

void HttpServer::stop() {
  if (!impl_) return;
  Impl& s = *impl_;
  std::lock_guard lock(s.lifecycle);
  if (!s.started) return;
  s.stopping = true;
  {
    std::lock_guard mlock(s.mailbox->mutex);
    s.mailbox->wake();
  }
  if (s.thread.joinable()) s.thread.join();
  s.started = false;
  s.stopped = true;
}

int HttpServer::port() const { return impl_->bound_port; }

HttpServerStats HttpServer::stats() const {
  const Impl& s = *impl_;
  HttpServerStats st;
  st.connections_accepted = s.accepted.load();
  st.rejected_per_address = s.rejected_address.load();
  st.rejected_global = s.rejected_global.load();
  st.head_timeouts = s.head_timeouts.load();
  st.idle_closed = s.idle_closed.load();
  st.write_timeouts = s.write_timeouts.load();
  st.bad_requests = s.bad_requests.load();
  st.requests = s.requests.load();
  st.responses = s.responses.load();
  st.handler_errors = s.handler_errors.load();
  st.connections_open = s.open.load();
  st.streams_open = s.streams.load();
  return st;
}

HttpHeadParse http_parse_head(std::string_view head, const HttpLimits& limits) {
  HttpHeadParse out;
  size_t scan = 0, head_start = 0;
  std::vector<std::pair<size_t, size_t>> lines;
  const bool complete = split_head_lines(head, scan, head_start, lines);
  std::optional<Refusal> refusal = head_too_big(head, complete ? scan : head.size(), head_start, lines, limits);
  if (!refusal && !complete) return out;
  HttpRequest req;
  if (!refusal) refusal = parse_head_lines(head, lines, req);
  if (refusal) {
    out.status = refusal->status;
    out.message = refusal->message;
  } else {
    out.request = std::move(req);
  }
  return out;
}

}  // namespace lp
