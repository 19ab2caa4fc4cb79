// Abusive HTTP clients for the server tests (issue 22): slowloris sockets that send one
// header line every so often, a crowd that connects all at once, and a poller that times
// GET /lights meanwhile. Every socket comes from a loopback source address of its own
// group (127.0.0.2, 127.0.0.3, ...: all of 127/8 is loopback on Linux), so that a server's
// per-address cap applies to the attackers and not to the poller. Bounded in time.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace lp::test {

using AttackClock = std::chrono::steady_clock;

// A non-blocking TCP socket from `source` (dotted IPv4, loopback) to 127.0.0.1:port,
// connect started; -1 on failure.
inline int start_connect(const char* source, int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in src{};
  src.sin_family = AF_INET;
  ::inet_pton(AF_INET, source, &src.sin_addr);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&src), sizeof src) != 0) {
    ::close(fd);
    return -1;
  }
  sockaddr_in dst{};
  dst.sin_family = AF_INET;
  dst.sin_port = htons(uint16_t(port));
  dst.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&dst), sizeof dst) != 0 && errno != EINPROGRESS) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// The status code at the start of `answer`; 0 when it is not an HTTP status line yet.
inline int status_of(const std::string& answer) {
  if (answer.size() < 12 || answer.rfind("HTTP/1.", 0) != 0) return 0;
  return std::atoi(answer.c_str() + 9);
}

// Sends `request` as is on a fresh connection from `source` and reads until the peer
// closes, `timeout_s` passes, or (with `one_answer`) one whole answer has come (head and
// Content-Length body). The status of the first answer (0: none) and the time taken.
struct RawAnswer {
  int status = 0;
  double seconds = 0;
  bool closed = false;  // the server closed the connection
  std::string answer;
};
inline RawAnswer raw_request(int port, const std::string& request, double timeout_s, bool one_answer = true,
                             const char* source = "127.0.0.1") {
  RawAnswer r;
  const auto t0 = AttackClock::now();
  const auto deadline = t0 + std::chrono::duration_cast<AttackClock::duration>(std::chrono::duration<double>(timeout_s));
  const int fd = start_connect(source, port);
  if (fd < 0) return r;
  size_t sent = 0;
  bool done = false;
  char buf[65536];
  while (!done && AttackClock::now() < deadline) {
    pollfd p{fd, short(sent < request.size() ? POLLOUT | POLLIN : POLLIN), 0};
    const int ms = int(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - AttackClock::now()).count());
    if (::poll(&p, 1, std::max(1, ms)) <= 0) continue;
    if (sent < request.size() && (p.revents & POLLOUT)) {
      const ssize_t n = ::send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
      if (n > 0) sent += size_t(n);
      else if (n < 0 && errno != EAGAIN) sent = request.size();  // the server closed: read what it said
    }
    if (!(p.revents & (POLLIN | POLLHUP | POLLERR))) continue;
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n < 0 && errno == EAGAIN) continue;
    if (n <= 0) {
      r.closed = true;
      break;
    }
    r.answer.append(buf, size_t(n));
    const size_t head = r.answer.find("\r\n\r\n");
    if (!one_answer || head == std::string::npos) continue;
    size_t length = 0;
    std::string lower = r.answer.substr(0, head);
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    const size_t cl = lower.find("\r\ncontent-length:");
    if (cl != std::string::npos) length = size_t(std::atoll(lower.c_str() + cl + 17));
    if (r.answer.size() >= head + 4 + length) done = true;
  }
  ::close(fd);
  r.seconds = std::chrono::duration<double>(AttackClock::now() - t0).count();
  r.status = status_of(r.answer);
  return r;
}

// One GET on a fresh connection from `source`; the status (0: none) and the time to the
// whole answer.
struct TimedGet {
  int status = 0;
  double seconds = 0;
  std::string answer;
};
inline TimedGet timed_get(int port, const std::string& path, double timeout_s, const char* source = "127.0.0.1",
                          const std::string& extra_headers = "") {
  const RawAnswer a =
      raw_request(port, "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + extra_headers + "\r\n", timeout_s, true, source);
  TimedGet r;
  r.seconds = a.seconds;
  r.answer = a.answer;
  // Whole answers only: a status line without its body does not count.
  const size_t head = a.answer.find("\r\n\r\n");
  if (head != std::string::npos) r.status = a.status;
  return r;
}

// The value of a header in an answer (name in any case); "" when absent.
inline std::string header_of(const std::string& answer, const std::string& name) {
  std::string lower = answer.substr(0, answer.find("\r\n\r\n"));
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  std::string key = "\r\n" + name + ":";
  std::transform(key.begin(), key.end(), key.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const size_t at = lower.find(key);
  if (at == std::string::npos) return "";
  const size_t begin = answer.find_first_not_of(' ', at + key.size()), end = answer.find("\r\n", at + key.size());
  return answer.substr(begin, end - begin);
}

// The body of an answer (after the head).
inline std::string body_of(const std::string& answer) {
  const size_t head = answer.find("\r\n\r\n");
  return head == std::string::npos ? "" : answer.substr(head + 4);
}

struct AttackOptions {
  int slow_clients = 200;            // slowloris sockets, from slow_source
  double slow_line_interval_s = 2;   // one header line per socket this often
  const char* slow_source = "127.0.0.2";
  int crowd = 500;                   // connections opened at once in each wave, from crowd_source
  double crowd_wave_s = 1.0;         // a new wave this often (the old one is closed)
  const char* crowd_source = "127.0.0.3";
  double duration_s = 6;             // how long the poller polls while the attack goes on
  double poll_interval_s = 0.05;
  double poll_timeout_s = 2;         // a poll that takes longer counts as failed
  std::string poll_path = "/lights";
};

struct AttackReport {
  std::vector<double> poll_seconds;  // every poll's latency, in order
  int polls_failed = 0;              // no 200 within poll_timeout_s
  // Slowloris: how their sockets ended.
  int slow_connected = 0, slow_got_status = 0, slow_got_503 = 0, slow_closed_silently = 0, slow_still_open = 0;
  // The crowd, over all waves: every connection's first answer.
  int crowd_total = 0, crowd_200 = 0, crowd_503 = 0, crowd_other = 0, crowd_closed_silently = 0, crowd_no_answer = 0;
  double percentile(double q) const {
    if (poll_seconds.empty()) return NAN;
    std::vector<double> s = poll_seconds;
    std::sort(s.begin(), s.end());
    return s[std::min(s.size() - 1, size_t(q * double(s.size() - 1) + 0.5))];
  }
};

namespace detail {

struct Sock {
  int fd = -1;
  std::string in;
  bool sent_request = false, ended = false;
  int lines = 0;
};

inline void run_slowloris(const AttackOptions& o, int port, std::atomic<bool>& stop, AttackReport& r) {
  std::vector<Sock> socks(size_t(std::max(0, o.slow_clients)));
  for (Sock& s : socks) s.fd = start_connect(o.slow_source, port);
  auto next_line = AttackClock::now();
  char buf[4096];
  while (!stop) {
    const auto now = AttackClock::now();
    const bool send_now = now >= next_line;
    if (send_now)
      next_line = now + std::chrono::duration_cast<AttackClock::duration>(std::chrono::duration<double>(o.slow_line_interval_s));
    for (Sock& s : socks) {
      if (s.fd < 0 || s.ended) continue;
      if (send_now) {
        const std::string line = s.lines == 0 ? "GET /lights HTTP/1.1\r\n" : "X-Slow-" + std::to_string(s.lines) + ": a\r\n";
        const ssize_t n = ::send(s.fd, line.data(), line.size(), MSG_NOSIGNAL);
        if (n > 0) s.sent_request = true, ++s.lines;
      }
      const ssize_t n = ::recv(s.fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) s.in.append(buf, size_t(n));
      if (n == 0 || (n < 0 && errno != EAGAIN)) s.ended = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  for (Sock& s : socks) {
    if (s.fd < 0) continue;
    if (s.sent_request) ++r.slow_connected;
    const int status = status_of(s.in);
    if (status) ++r.slow_got_status;
    if (status == 503) ++r.slow_got_503;
    if (s.ended && !status) ++r.slow_closed_silently;
    if (!s.ended) ++r.slow_still_open;
    ::close(s.fd);
  }
}

inline void run_crowd(const AttackOptions& o, int port, std::atomic<bool>& stop, AttackReport& r) {
  const std::string request = "GET /lights HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  char buf[65536];
  while (!stop) {
    const auto wave_end =
        AttackClock::now() + std::chrono::duration_cast<AttackClock::duration>(std::chrono::duration<double>(o.crowd_wave_s));
    std::vector<Sock> socks(size_t(std::max(0, o.crowd)));
    for (Sock& s : socks) s.fd = start_connect(o.crowd_source, port);
    std::vector<pollfd> fds(socks.size());
    while (AttackClock::now() < wave_end) {
      for (size_t i = 0; i < socks.size(); ++i)
        fds[i] = {socks[i].ended ? -1 : socks[i].fd, short(socks[i].sent_request ? POLLIN : POLLOUT), 0};
      if (::poll(fds.data(), fds.size(), 20) <= 0) continue;
      for (size_t i = 0; i < socks.size(); ++i) {
        Sock& s = socks[i];
        if (s.fd < 0 || s.ended || !fds[i].revents) continue;
        if (!s.sent_request) {
          const ssize_t n = ::send(s.fd, request.data(), request.size(), MSG_NOSIGNAL);
          if (n == ssize_t(request.size())) s.sent_request = true;
          else if (n < 0 && errno != EAGAIN) s.ended = true;
          continue;
        }
        const ssize_t n = ::recv(s.fd, buf, sizeof buf, MSG_DONTWAIT);
        if (n > 0) s.in.append(buf, size_t(n));
        // The first status line is all we classify; the socket then hangs on (idle).
        if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR) || status_of(s.in)) s.ended = true;
      }
    }
    for (Sock& s : socks) {
      ++r.crowd_total;
      const int status = status_of(s.in);
      if (status == 200) ++r.crowd_200;
      else if (status == 503) ++r.crowd_503;
      else if (status) ++r.crowd_other;
      else if (s.ended) ++r.crowd_closed_silently;
      else ++r.crowd_no_answer;
      if (s.fd >= 0) ::close(s.fd);
    }
  }
}

}  // namespace detail

// Slowloris and the crowd start, then (after a second, so that both are in place) the
// poller polls for duration_s; then everything stops and is counted.
inline AttackReport run_attack(int port, const AttackOptions& o) {
  AttackReport r;
  AttackReport slow, crowd;
  std::atomic<bool> stop{false};
  std::thread slow_thread([&] { detail::run_slowloris(o, port, stop, slow); });
  std::thread crowd_thread([&] { detail::run_crowd(o, port, stop, crowd); });
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const auto end = AttackClock::now() + std::chrono::duration_cast<AttackClock::duration>(std::chrono::duration<double>(o.duration_s));
  while (AttackClock::now() < end) {
    const TimedGet g = timed_get(port, o.poll_path, o.poll_timeout_s);
    r.poll_seconds.push_back(g.status == 200 ? g.seconds : std::max(g.seconds, o.poll_timeout_s));
    if (g.status != 200) ++r.polls_failed;
    std::this_thread::sleep_for(std::chrono::duration<double>(o.poll_interval_s));
  }
  stop = true;
  slow_thread.join();
  crowd_thread.join();
  r.slow_connected = slow.slow_connected, r.slow_got_status = slow.slow_got_status, r.slow_got_503 = slow.slow_got_503;
  r.slow_closed_silently = slow.slow_closed_silently, r.slow_still_open = slow.slow_still_open;
  r.crowd_total = crowd.crowd_total, r.crowd_200 = crowd.crowd_200, r.crowd_503 = crowd.crowd_503;
  r.crowd_other = crowd.crowd_other, r.crowd_closed_silently = crowd.crowd_closed_silently;
  r.crowd_no_answer = crowd.crowd_no_answer;
  return r;
}

}  // namespace lp::test
